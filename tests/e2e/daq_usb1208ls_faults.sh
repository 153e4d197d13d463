# MCC USB-1208LS where the public sources leave the device's behaviour open (docs/daq.md,
# "Protocol fact" 14), each against a virtual device answering the way one source reads it;
# the checker compares every published volt with what the device digitised (1 LSB) unless the
# block is flagged doubtful. 250 scans/s, 3 channels scanned as a queue of 4 (1000 S/s). The rate
# bound is 5 %: the measured slope reads the emulator's pacing on a loaded host (242.6 of 250.7
# scans/s at load 5.5 on 2 cores); a wrong prescale is a factor of 2.
source "$(dirname "$0")/daq_lib.sh"

# 1. Scan reports of 104 bytes on the wire (wjasper's Python port and the libusb-0.1 reading: the
#    C struct without its record number). Was: "short scan report (105 bytes)", a re-open loop.
vdaq --model 1208ls --duration 3 --rate 250 --decimate 1 --block-scans 10 --report-bytes 104 \
     --expect-variant "scan report 104 bytes" --min-rate-ratio 0.95
summary
at_most "$(report max_value_error_lsb)" 1.0 || fail "104-byte reports: value error above 1 LSB"
[ "$(report status.usb_errors)" = 0 ] || fail "104-byte reports: usb_errors $(report status.usb_errors)"
#    ... and the 105-byte reading (record number first), the same data exactly.
vdaq --model 1208ls --duration 3 --rate 250 --decimate 1 --block-scans 10 --report-bytes 105 \
     --expect-variant "record-first" --min-rate-ratio 0.95
summary
at_most "$(report max_value_error_lsb)" 1.0 || fail "105-byte reports: value error above 1 LSB"

echo ok
