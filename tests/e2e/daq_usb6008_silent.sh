# A device that never answers a command, no device at all, and not the device asked for: the daemon publishes `fault`
# (naming the command and the timeout) or `disconnected`, retries, never exits on its own, and
# stops cleanly with exit 0 on SIGTERM.
source "$(dirname "$0")/daq_lib.sh"
vdaq --model 6008 --scenario silent --duration 4 --expect-no-data --expect-state 3
report states_seen | grep -q "did not answer" || fail "fault text: $(report states_seen)"
# Back-off: hello times out after 300 ms, then the wait is 200, 400, 800, 1600 ms ... (retry_ms
# doubling): 4 attempts in 4 s where a fixed 200 ms wait would make 8.
hellos=$(report device_hellos)
[ "$hellos" -ge 3 ] && [ "$hellos" -le 5 ] || fail "expected 3-5 attempts in 4 s with back-off, got $hellos"
vdaq --model 6008 --scenario absent --duration 1.5 --expect-no-data --expect-state 2
report states_seen | grep -q "no NI USB-6008" || fail "disconnected text: $(report states_seen)"
# Selection by serial number (read from the device's string descriptor): the right one streams;
# a serial that is not attached leaves the device present unused, and the status says why.
vdaq --model 6008 --scenario normal --duration 1.5 --device-serial 01F2A3B4 -- --serial 01F2A3B4
[ "$(report status.serial)" = 01F2A3B4 ] || fail "status serial: $(report status)"
vdaq --model 6008 --scenario normal --duration 1.5 --device-serial 01F2A3B4
[ "$(report status.serial)" = 01F2A3B4 ] || fail "status serial without --serial: $(report status)"
vdaq --model 6008 --scenario normal --duration 1.5 --device-serial 01F2A3B4 --expect-no-data \
     --expect-state 2 -- --serial ABC123
report states_seen | grep -q "with serial 'ABC123' attached (1 with other serials)" ||
  fail "serial text: $(report states_seen)"
echo ok
