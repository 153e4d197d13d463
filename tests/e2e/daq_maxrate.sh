# Both NI devices at their maximum for 20 s, at the same time (two virtual devices, two pof-daqd):
#   USB-6008: 10 kS/s aggregate (3333.333 scans/s x 3 channels, 12-bit), blocks of 10;
#   USB-6009: 48 kS/s aggregate (16000 scans/s x 3 channels, 14-bit), blocks of 50.
# Each: zero dropped scans, every value within 1 LSB of what the device sent, continuous indices.
# Side by side they load the 2-core host more than either alone; the timestamp bound is loose
# (5 ms) for that reason, daq_usb6008_drift.sh holds the tight (1 ms) one. The test runs alone
# (RUN_SERIAL), so it is kept short: BENCHMARKS.md, "Drops, CPU and latency at maximum rate", has
# the 10-min runs with the CPU and latency figures.
source "$(dirname "$0")/daq_lib.sh"
run() {  # run <name> <pof-vdaq args...>
  local name=$1; shift
  umockdev_wrapper "$BIN_DIR/pof-vdaq" --daemon "$BIN_DIR/pof-daqd" --report "$WORK_DIR/$name.json" \
    --duration 20 --warmup 2 --decimate 1 --max-ts-error-us 5000 "$@" >"$WORK_DIR/$name.out" 2>"$WORK_DIR/$name.err"
}
run usb6008 --model 6008 --rate 3333.333 --block-scans 10 & p8=$!
run usb6009 --model 6009 --rate 16000 --block-scans 50 & p9=$!
status=0
wait $p8 || status=1
wait $p9 || status=1
for name in usb6008 usb6009; do
  r="$WORK_DIR/$name.json"
  echo "$name: $(summary "$r")"
  [ "$(report pass "$r")" = true ] || { tail -n 20 "$WORK_DIR/$name.err" >&2; fail "$name: $(report failures "$r")"; }
done
[ $status = 0 ] || fail "pof-vdaq failed"
echo ok
