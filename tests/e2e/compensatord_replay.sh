# The running system over real LCM (udpm on loopback): a simulated session is played by
# stock lcm-logplayer into pof-compensatord, `pof record` records what it publishes, and then:
#   - every scan produced one angle, in sequence (no gaps), and per-cycle statistics arrived;
#   - the live daemon's angles equal `pof compensate` on the same log, bit for bit (float);
#   - the angles track the simulator's ground truth within the calibration's accuracy;
#   - SIGHUP with a broken calibration keeps the daemon running on the old one and says why.
source "$(dirname "$0")/lib.sh"
private_bus
POF="$BIN_DIR/pof"

"$POF" sim paper -o cal.csv --seed 11 2>/dev/null
"$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
"$POF" sim validation -o val.lcmlog --seconds 100 --seed 12 2>/dev/null
cp cal.toml live.toml

start_ready notify daemon.log "$BIN_DIR/pof-compensatord" --cal live.toml --lcm-url "$URL"
pids+=($!); daemon=$!
start_ready notify record.log "$POF" record -o rec.lcmlog --lcm-url "$URL" -c 'POF_(ANGLE|STATS|COMPENSATOR_STATUS)' -q
pids+=($!); recorder=$!

lcm-logplayer -s 10 -l "$URL" val.lcmlog >/dev/null 2>&1 || fail "lcm-logplayer failed"
blocks=$("$POF" record --check val.lcmlog | awk '$1 == "POF_RAW" { print $3 }')
caught_up --lcm-url "$URL" --blocks "$blocks" || fail "pof-compensatord did not take the $blocks blocks played"

# A broken calibration on SIGHUP: kept out, named, daemon alive.
printf 'schema_version = 1\n[quasi_static]\nc9 = "oops"\n' > live.toml
kill -HUP "$daemon"
wait_until -- grep -q "reload failed, keeping the previous one" daemon.log || fail "bad reload not reported: $(cat daemon.log)"
kill -0 "$daemon" || fail "daemon died on a bad reload"

kill -TERM "$daemon"; wait "$daemon" || fail "daemon exit status $? on SIGTERM"
wait_until --drained "$PORT" || fail "pof record did not read what was sent"
kill -INT "$recorder"; wait "$recorder" || true

"$POF" export rec.lcmlog -c POF_ANGLE -o live.csv 2>/dev/null
"$POF" export rec.lcmlog -c POF_STATS -o stats.csv 2>/dev/null || fail "no POF_STATS recorded"
"$POF" export val.lcmlog -c POF_RAW -o raw.csv 2>/dev/null
"$POF" compensate val.lcmlog --cal cal.toml --csv offline.csv >/dev/null 2>&1

"$PY" "$SOURCE_DIR/tests/e2e/compensatord_replay_check.py" || fail "comparison failed"
echo ok
