# usbmon capture replay (umockdev pcap, the libfprint way): a session of the virtual USB-6009 is
# recorded as a usbmon capture (the format Wireshark/usbmon give on real hardware), then pof-daqd
# runs against the replayed capture alone; it must publish the same scans with the same volts.
# Captures of real devices placed in tests/data/usb_captures/<name>/ (docs/daq.md,
# "Recording a capture of real hardware") are replayed too: capture.pcap plus a file `model` holding 6008 or 6009.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6009 --duration 2 --rate 4000 --decimate 1 --block-scans 20 \
     --record-pcap "$WORK_DIR/session.pcap"
recorded=$(report scans_published)
[ "$recorded" -gt 1000 ] || fail "recording published only $recorded scans"
vdaq --model 6009 --duration 2 --rate 4000 --decimate 1 --block-scans 20 --min-rate-ratio 0 \
     --replay-pcap "$WORK_DIR/session.pcap"
replayed=$(report scans_published)
[ "$replayed" = "$recorded" ] || fail "replay published $replayed scans, the recording $recorded"
echo "recorded and replayed $recorded scans, max error $(report max_value_error_lsb) LSB"
shopt -s nullglob
for dir in "$SOURCE_DIR"/tests/data/usb_captures/*/; do
  model=$(cat "$dir/model")
  # Real data: the values are unknown, so only the stream's integrity is checked (a capture of
  # hardware does not follow the model's waveform: the value check is off via a huge LSB bound).
  umockdev_wrapper "$BIN_DIR/pof-vdaq" --daemon "$BIN_DIR/pof-daqd" --report "$WORK_DIR/real.json" \
    --model "$model" --duration 3 --min-rate-ratio 0 --replay-pcap "$dir/capture.pcap" \
    -- -s acquisition.data_timeout_ms=5000 >"$WORK_DIR/real.out" 2>&1 || true
  "$PY" "$SOURCE_DIR/tests/e2e/daq_report.py" stream-intact "$WORK_DIR/real.json" ||
    fail "replay of $dir: see $WORK_DIR/real.out"
  echo "replayed $dir: $(report blocks "$WORK_DIR/real.json") blocks"
done
echo ok
