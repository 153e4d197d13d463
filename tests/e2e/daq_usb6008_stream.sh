# USB-6008 (virtual): decoded volts equal what the device sent within 1 LSB, scan rate, continuous
# scan indices, timestamps against the device clock, clean SIGTERM. Both byte orders (protocol [9]).
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6008 --scenario normal --duration 5 --rate 2000 --decimate 10 \
     --max-ts-error-us 2000
summary
at_most "$(report max_value_error_lsb)" 1.0 || fail "value error above 1 LSB"
[ "$(report status.dropped_scans)" = 0 ] || fail "dropped scans"
vdaq --model 6008 --scenario normal --duration 3 --rate 1000 --decimate 1 --block-scans 5 \
     --byte-order little
summary
echo ok
