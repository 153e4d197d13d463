# Short packets (valid, 2 bytes short every 7th transfer) lose nothing; an odd-length garbage
# packet is rejected whole (never published), counted, and the daemon recovers with the gap
# flagged. A packet with padding bits set is kept (no public source checks those bits; protocol
# [9]) and counted; here the device then stops, and the daemon recovers from the silence.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6008 --scenario short --short-every 7 --duration 4 --rate 2000 --decimate 1 \
     --block-scans 10
summary
vdaq --model 6008 --scenario garbage --duration 4 --event-at 1.5 --rate 2000 --decimate 1 \
     --block-scans 10 --expect-gap --min-usb-errors 1 --max-dropped 2000 --min-rate-ratio 0
summary
report states_seen | grep -q "odd-length" || fail "garbage: the fault does not say why"
vdaq --model 6008 --scenario padding --duration 4 --event-at 1.5 --rate 2000 --decimate 1 \
     --block-scans 10 --expect-gap --max-dropped 2000 --min-rate-ratio 0 \
     --daemon-byte-order big --expect-variant "padding bits set"
summary
[ "$(report status.padding_set)" -ge 30 ] || fail "padding: not counted: $(report status)"
report states_seen | grep -q "no data" || fail "padding: the silence that follows is not reported"
echo ok
