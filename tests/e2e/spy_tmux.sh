# pof spy as a person uses it: in a terminal (tmux), fed by a small publisher of every pofkit type
# plus a foreign channel; the screen must show rates, decoded values and fingerprints, and 'q'
# must quit. Then the --once/--duration snapshot mode for scripts.
source "$(dirname "$0")/lib.sh"
# A random port: other test runs on this host (ttl=0 multicast is host-wide) must not cross in.
PORT=${PORT:-$((20000 + RANDOM % 30000))}
URL="udpm://239.255.76.67:$PORT?ttl=0"
PUB="$BIN_DIR/../tests/pof-testpub"
POF="$BIN_DIR/pof"
command -v tmux >/dev/null || fail "tmux is missing (it is in ./pofkit TEST_PACKAGES)"

sock="$WORK_DIR/tmux.sock"
tm() { tmux -S "$sock" "$@"; }
cleanup() { tm kill-server 2>/dev/null || true; [ -n "${pub:-}" ] && kill "$pub" 2>/dev/null || true; }
trap cleanup EXIT

"$PUB" --lcm-url "$URL" session --duration 12 --suffix _LEFT_KNEE &
pub=$!
# The pane stays after pof spy exits (remain-on-exit), so its exit status can be read from it.
tm new-session -d -s spy -x 132 -y 50 "'$POF' spy --lcm-url '$URL'; echo SPY-EXITED \$?" \; \
  set-option -t spy remain-on-exit on
# Wait until a cycle-statistics row (every 2 s) and the foreign channel are on the screen and the
# angle rate has settled at its 100/s (+-15 %); the checks below say what is missing when that does
# not happen within 10 s.
wait_until --timeout 10 -- sh -c 'tmux -S "$0" capture-pane -p -t spy >screen.txt &&
  grep -q "cycle statistics" screen.txt && grep -q FOREIGN_TELEMETRY screen.txt &&
  awk "\$1 == \"POF_ANGLE_LEFT_KNEE\" && \$2 == \"angle_t\" { ok = \$3 > 85 && \$3 < 115 } END { exit !ok }" screen.txt' \
  "$sock" || true
cat screen.txt
for want in "POF_RAW_LEFT_KNEE" "raw_block_t" "POF_ANGLE_LEFT_KNEE" "angle_t" "POF_STATS_LEFT_KNEE" \
  "POF_DAQ_STATUS_LEFT_KNEE" "STREAMING (streaming)" "sensor_id LEFT_KNEE" "reference 4.3500 V" \
  "cycle statistics" "# angle  | reference  * both" "FOREIGN_TELEMETRY" "fp:6e6f74206120706f" "(q quits)"; do
  grep -qF "$want" screen.txt || fail "spy screen lacks '$want'"
done
# POF_ANGLE is published at 100 Hz: the rate column must say so (+-15 %), with no gaps.
rate=$(awk '$1 == "POF_ANGLE_LEFT_KNEE" && $2 == "angle_t" {print $3}' screen.txt)
awk -v r="$rate" 'BEGIN { exit !(r > 85 && r < 115) }' || fail "POF_ANGLE rate shown as '$rate', expected ~100/s"
awk '$1 == "POF_ANGLE_LEFT_KNEE" && $2 == "angle_t" { exit !($6 == 0 && $7 == 0) }' screen.txt ||
  fail "spy reports sequence gaps on a loss-free loopback stream"

tm send-keys -t spy q
wait_until --timeout 5 -- sh -c 'tmux -S "$0" capture-pane -p -t spy | grep -q "SPY-EXITED 0"' "$sock" ||
  fail "'q' did not quit pof spy with exit 0: $(tm capture-pane -p -t spy | grep SPY-EXITED)"

# Snapshot mode: plain text (no escape codes), exits by itself.
expect_exit 0 "$POF" spy --lcm-url "$URL" --duration 1.5
grep -q "POF_ANGLE_LEFT_KNEE" <<<"$out" || fail "--duration snapshot lacks the angle channel: $out"
if grep -q $'\x1b' <<<"$out"; then fail "--duration snapshot contains escape codes"; fi
# SIGINT ends the live view cleanly too.
"$POF" spy --lcm-url "$URL" >live.out &
spy=$!
wait_until -- test -s live.out || fail "pof spy drew no frame"   # its first frame: SIGINT is its own
kill -INT $spy
wait $spy || fail "pof spy exited $? on SIGINT"
echo ok
