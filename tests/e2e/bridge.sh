# `pof bridge`: pof-testpub's session (angles at 100 Hz, raw blocks, statistics, DAQ status and a
# foreign channel, suffix _LEFT_KNEE) on a private udpm bus, bridged to a local UDP port where a
# listener keeps every datagram; tests/e2e/bridge_check.py checks them as PlotJuggler's UDP Server
# would read them (JSON, a numeric "timestamp", one object per channel, NaN as null) against what
# pof-testpub sent, the angles thinned to --max-rate by message time, and pof bridge's counts
# (received = sent + decimated, no send failure); then with nobody listening, the failed sends are
# counted and nothing waits.
source "$(dirname "$0")/lib.sh"
POF="$BIN_DIR/pof"
TESTPUB="$BIN_DIR/../tests/pof-testpub"
CHECK="$SOURCE_DIR/tests/e2e/bridge_check.py"

private_bus
UPORT=$((PORT + 1))
start_ready "$UPORT" listener.err "$PY" "$CHECK" listen "$UPORT" datagrams.json
listener=$!; pids+=($listener)
start_ready "$PORT" bridge.err "$POF" bridge --lcm-url "$URL" --udp "127.0.0.1:$UPORT" --max-rate 20 --raw
bridge=$!; pids+=($bridge)
"$TESTPUB" --lcm-url "$URL" session --duration 2.5 --suffix _LEFT_KNEE || fail "pof-testpub failed"
wait_until --drained "$PORT" || fail "pof bridge did not read what was published"
kill -INT "$bridge"; wait "$bridge" || fail "pof bridge exit status $? on SIGINT: $(cat bridge.err)"
wait_until --drained "$UPORT" || fail "the listener did not read what pof bridge sent"
kill -TERM "$listener"; wait "$listener" || fail "listener: $(cat listener.err)"
cat bridge.err
"$PY" "$CHECK" check datagrams.json bridge.err 20 || fail "see above"

# Nobody listening: the kernel refuses every other datagram (ECONNREFUSED from the ICMP of the one
# before); pof bridge counts them, goes on and is not held up (--max-rate 0: every message).
private_bus
start_ready "$PORT" alone.err "$POF" bridge --lcm-url "$URL" --udp "127.0.0.1:$((PORT + 2))" --max-rate 0
bridge=$!; pids+=($bridge)
"$TESTPUB" --lcm-url "$URL" session --duration 1 || fail "pof-testpub failed"
wait_until --drained "$PORT" || fail "pof bridge (nobody listening) did not read what was published"
kill -INT "$bridge"; wait "$bridge" || fail "pof bridge exit status $? on SIGINT: $(cat alone.err)"
cat alone.err
grep -q "every message" alone.err || fail "--max-rate 0 not reported: $(cat alone.err)"
line=$(grep "POF_ANGLE: received" alone.err) || fail "no angle counts: $(cat alone.err)"
read -r received sent failures < <(sed -E 's/.*received ([0-9]+), sent ([0-9]+), decimated 0, send failures ([0-9]+)/\1 \2 \3/' <<<"$line")
[ "$received" -ge 90 ] && [ "$failures" -gt 0 ] && [ $((sent + failures)) -eq "$received" ] ||
  fail "nobody listening: expected failures counted and every angle accounted for: $line"

# Usage errors name the option.
expect_exit 2 "$POF" bridge --lcm-url "$URL" --udp localhost
[[ "$err" == *"--udp 'localhost': expected HOST:PORT"* ]] || fail "--udp without a port: $err"
expect_exit 2 "$POF" bridge --lcm-url "$URL" --udp 127.0.0.1:70000
[[ "$err" == *"expected a port 1-65535"* ]] || fail "--udp port: $err"
echo ok
