# MCC USB-1208LS (virtual, through hidapi's libusb flavour): AInScan bursts back to back and single
# AIn reads; decoded
# volts equal what the device sent within 1 LSB, continuous indices; unplug/replug mid-stream.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 1208ls --scenario normal --duration 4 --rate 1000 --decimate 1 --block-scans 10
summary
[ "$(report 'r["max_value_error_lsb"] <= 1.0')" = True ] || fail "value error above 1 LSB"
vdaq --model 1208ls --scenario unplug --event-at 1.5 --unplug-for 1 --duration 5 --rate 1000 \
     --decimate 1 --block-scans 10 --expect-gap --expect-state 2 --min-reconnects 1 \
     --max-dropped 100000 --min-rate-ratio 0
summary
# Single AIn reads (one output + one input report per channel per scan), host-paced.
vdaq --model 1208ls --scenario normal --duration 3 --rate 50 --decimate 1 --block-scans 1 --min-rate-ratio 0.97 \
     -- -s 'acquisition.mcc_mode="single"'
summary
[ "$(report 'r["max_value_error_lsb"] <= 1.0')" = True ] || fail "single reads: value error above 1 LSB"
echo ok
