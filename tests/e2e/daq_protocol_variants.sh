# pof-daqd against each protocol variant the public sources show where they disagree
# (docs/daq.md, "Protocol facts"), a few seconds each; the checker fails on any published value
# more than 1 LSB from what the device sent unless the block carries FLAG_DOUBTFUL, on utime
# stepping back, on `streaming` before any scan, and on requests whose header byte differs from
# the device's replies.
source "$(dirname "$0")/daq_lib.sh"
# Replies begin 00 01 (chrismerck/usb-6000, datalogger-rpi usb6008.py; ni_usb6501.c): accepted,
# spoken back with 00 01, reported.
vdaq --model 6008 --duration 2.5 --rate 1000 --decimate 1 --block-scans 10 --reply-header 1 \
     --expect-variant "reply header 00 01"
summary
vdaq --model 6009 --duration 2.5 --rate 1000 --decimate 1 --block-scans 10 --reply-header 1 \
     --expect-variant "reply header 00 01"
summary
# Padding bits set (no source checks them): counted, every sample kept.
vdaq --model 6008 --duration 2.5 --rate 1000 --decimate 1 --block-scans 10 --padding-noise \
     --expect-variant "padding bits set"
summary
[ "$(report status.padding_set)" -gt 1000 ] || fail "padding_set not counted: $(report status)"
[ "$(report status.usb_errors)" = 0 ] || fail "padding counted as USB errors"
# Little-endian samples (datalogger-rpi usb6008.py) of a steady +0.03 V with +-1 LSB noise: the
# reading a padding check alone lets through as -2.46 V. Told from the data; the blocks before the
# first verdict (one window of 256 scans) are flagged doubtful, every other value is exact.
vdaq --model 6008 --duration 2.5 --rate 1000 --decimate 1 --block-scans 10 --byte-order little \
     --steady-volts 0.03 --expect-variant "little-endian"
summary
doubtful=$(report doubtful_blocks)
[ "$doubtful" -gt 0 ] && [ "$doubtful" -le 30 ] || fail "doubtful blocks: $doubtful"
# A perfectly steady input (no noise at all) reads smooth in both byte orders: nothing tells the
# order, so every block stays doubtful and the status says why (read big-endian, this
# little-endian +0.03 V would be -2.46 V) ...
vdaq --model 6008 --duration 2.5 --rate 1000 --decimate 1 --block-scans 10 --byte-order little \
     --steady-volts 0.03 --steady-noise-lsb 0 --expect-variant "sample byte order undecided: the signal has not told it"
summary
[ "$(report doubtful_blocks)" = "$(report blocks)" ] || fail "steady input: $(report doubtful_blocks) of $(report blocks) blocks doubtful"
# ... until the configuration pins it (docs/daq.md, fact 9): then every value is exact.
vdaq --model 6008 --duration 2.5 --rate 1000 --decimate 1 --block-scans 10 --byte-order little \
     --steady-volts 0.03 --steady-noise-lsb 0 --daemon-byte-order little --expect-variant "samples little-endian"
summary
[ "$(report doubtful_blocks)" = 0 ] || fail "pinned byte order: $(report doubtful_blocks) doubtful blocks"
# ... and big-endian (comedi's family) with the knee signal, with nonzero padding as well.
vdaq --model 6008 --duration 2.5 --rate 1000 --decimate 1 --block-scans 10 --padding-noise \
     --expect-variant "big-endian"
summary
# `pof-daqd --probe` (docs/hardware-bringup.md): stops by itself once the variant is told and
# prints it on one line.
vdaq --model 6008 --duration 4 --rate 1000 --decimate 1 --block-scans 10 --reply-header 1 \
     --byte-order little -- --probe
grep -q "pof-daqd probe: usb6008 3923:717a: streaming .*protocol variant: reply header 00 01; samples little-endian" \
  "$WORK_DIR/vdaq.out" || fail "probe line: $(grep probe "$WORK_DIR/vdaq.out")"
grep -q "padding_set 0;" "$WORK_DIR/vdaq.out" || fail "padding counted while the byte order was untold"
# A 3-channel list on the USB-1208LS is padded to its 4-entry queue and the layout of the data-first
# sources is detected: covered by daq_usb1208ls.sh.
echo ok
