# The whole system on the virtual USB-6008: separate processes over udpm on
# loopback, as deployed:
#
#   virtual USB-6008 (umockdev; its analog inputs see the simulated knee)  -> pof-daqd (real libusb)
#     -> POF_RAW -> pof-compensatord -> POF_ANGLE / POF_STATS;  pof record records every POF_* channel
#
# A 3-cycle subject session (the demo's `session` scenario at 0.35 rad/s) is scanned at 2 kS/s per
# channel and decimated to 200 Hz. Checks:
#   - pof-vdaq's own: every published volt equals what the device sent (1 LSB), continuous scan
#     indices, no dropped scans, clean SIGTERM;
#   - no gaps: one angle per published scan, sequence numbers continuous on every channel, no
#     QUALITY_GAP;
#   - the recorded angles match the simulator's ground truth (the device's --truth file: the true
#     knee angle of every device scan, averaged over each decimated scan) within the calibration's
#     accuracy, and better than the uncompensated f5 angle;
#   - the per-cycle statistics arrived;
#   - lcm-logplayer replay of the recorded POF_RAW through a fresh compensator reproduces the
#     angles bit for bit (float) and the same statistics.
source "$(dirname "$0")/daq_lib.sh"
private_bus 239.255.77.67
REPLAY_URL="udpm://239.255.77.67:$((PORT + 1))?ttl=0"
POF="$BIN_DIR/pof"

# Calibration on the simulated rig (the paper's protocol), and the simulated potentiometer.
"$POF" sim paper -o cal.csv --seed 11 2>/dev/null
"$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
printf 'schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n' > pot.toml
# The session: the demo's scenario, three cycles at 0.35 rad/s (inside the calibrated range).
{ cat "$SOURCE_DIR/daq/sim/scenarios/session.toml"; printf 'velocities_rad_s = [0.35]\ncycles_per_velocity = 3\n'; } > short.toml
DECIMATE=10

start_ready notify record.log "$POF" record -o live.lcmlog --lcm-url "$URL" -c 'POF_.*' -q
pids+=($!); recorder=$!
start_ready notify compensatord.log "$BIN_DIR/pof-compensatord" --cal cal.toml --pot-cal pot.toml --lcm-url "$URL"
pids+=($!); compensator=$!

# 34 s: the scenario lasts 34.7 s; the device's signal loops after that, which is not wanted here.
vdaq --model 6008 --scenario normal --duration 34 --rate 2000 --decimate $DECIMATE --block-scans 1 \
     --lcm-port "$PORT" --sim-scenario short.toml --truth "$WORK_DIR/truth.csv"
summary
# Stop the compensator once it took every published block, and the recorder once it read everything
# queued for it (it does not drain the socket after SIGINT).
caught_up --lcm-url "$URL" --blocks "$(report blocks)" || fail "pof-compensatord did not take every block"
kill -TERM "$compensator"; wait "$compensator" || fail "pof-compensatord exit status $? on SIGTERM"
wait_until --drained "$PORT" || fail "pof record did not read what was sent"
kill -INT "$recorder"; wait "$recorder" || fail "pof record exit status $?"

"$POF" record --check live.lcmlog > check.txt || fail "recorded log damaged: $(cat check.txt)"
cat check.txt
for ch in POF_RAW POF_ANGLE POF_STATS POF_DAQ_STATUS POF_COMPENSATOR_STATUS; do
  grep -qE "^  $ch +[a-z_]+ .* 0 gaps \(0 missing\), 0 restarts" check.txt || fail "$ch missing from the log, with sequence gaps or restarts"
done

# Replay: stock lcm-logplayer plays the recorded raw stream into a fresh compensator.
start_ready notify record-replay.log "$POF" record -o replay.lcmlog --lcm-url "$REPLAY_URL" -c 'POF_(ANGLE|STATS)' -q
pids+=($!); recorder2=$!
start_ready notify compensatord-replay.log "$BIN_DIR/pof-compensatord" --cal cal.toml --pot-cal pot.toml --lcm-url "$REPLAY_URL"
pids+=($!); compensator2=$!
lcm-logplayer -s 10 -e '^POF_RAW$' -l "$REPLAY_URL" live.lcmlog >/dev/null 2>&1 || fail "lcm-logplayer failed"
caught_up --lcm-url "$REPLAY_URL" --blocks "$(report blocks)" || fail "the replay compensator did not take every block"
kill -TERM "$compensator2"; wait "$compensator2" || fail "replay compensator exit status $?"
wait_until --drained "$((PORT + 1))" || fail "the replay pof record did not read what was sent"
kill -INT "$recorder2"; wait "$recorder2" || fail "replay pof record exit status $?"

for what in RAW ANGLE STATS; do
  "$POF" export live.lcmlog -c POF_$what -o live-$what.csv 2>/dev/null || fail "no POF_$what recorded"
done
for what in ANGLE STATS; do
  "$POF" export replay.lcmlog -c POF_$what -o replay-$what.csv 2>/dev/null || fail "replay: no POF_$what"
done

"$PY" "$SOURCE_DIR/tests/e2e/system_usb6008_check.py" "$DECIMATE" || fail "system check failed"
echo ok
