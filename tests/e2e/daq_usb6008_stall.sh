# A stalled data endpoint (-EPIPE): counted as a USB error, state `fault` with the reason, the
# daemon re-opens the device (clear halt, new session) and streams again with the gap flagged.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6008 --scenario stall --duration 5 --event-at 2 --rate 2000 --decimate 10 \
     --expect-gap --expect-state 3 --min-usb-errors 1 --min-reconnects 1 \
     --max-dropped 1000 --min-rate-ratio 0
summary
report states_seen | grep -q "stalled" || fail "the fault state does not name the stall"
echo ok
