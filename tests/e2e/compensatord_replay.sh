# The running system over real LCM (udpm on loopback): a simulated session is played by
# stock lcm-logplayer into pof-compensatord, `pof record` records what it publishes, and then:
#   - every scan produced one angle, in sequence (no gaps), and per-cycle statistics arrived;
#   - the live daemon's angles equal `pof compensate` on the same log, bit for bit (float);
#   - the angles track the simulator's ground truth within the calibration's accuracy;
#   - SIGHUP with a broken calibration keeps the daemon running on the old one and says why.
source "$(dirname "$0")/lib.sh"
PORT=$((20000 + RANDOM % 30000))   # ttl=0 multicast is host-wide: keep other runs out
URL="udpm://239.255.76.67:$PORT?ttl=0"
POF="$BIN_DIR/pof"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

"$POF" sim paper -o cal.csv --seed 11 2>/dev/null
"$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
"$POF" sim validation -o val.lcmlog --seconds 100 --seed 12 2>/dev/null
cp cal.toml live.toml

"$BIN_DIR/pof-compensatord" --cal live.toml --lcm-url "$URL" 2>daemon.log &
pids+=($!); daemon=$!
"$POF" record -o rec.lcmlog --lcm-url "$URL" -c 'POF_(ANGLE|STATS|COMPENSATOR_STATUS)' -q 2>record.log &
pids+=($!); recorder=$!
sleep 1.5   # both subscribed (the daemon logs once it is)
grep -q "POF_RAW -> POF_ANGLE" daemon.log || fail "daemon did not start: $(cat daemon.log)"

lcm-logplayer -s 10 -l "$URL" val.lcmlog >/dev/null 2>&1 || fail "lcm-logplayer failed"
sleep 1

# A broken calibration on SIGHUP: kept out, named, daemon alive.
printf 'schema_version = 1\n[quasi_static]\nc9 = "oops"\n' > live.toml
kill -HUP "$daemon"
sleep 1.2
kill -0 "$daemon" || fail "daemon died on a bad reload"
grep -q "reload failed, keeping the previous one" daemon.log || fail "bad reload not reported: $(cat daemon.log)"

kill -TERM "$daemon"; wait "$daemon" || fail "daemon exit status $? on SIGTERM"
sleep 0.5
kill -INT "$recorder"; wait "$recorder" || true

"$POF" export rec.lcmlog -c POF_ANGLE -o live.csv 2>/dev/null
"$POF" export rec.lcmlog -c POF_STATS -o stats.csv 2>/dev/null || fail "no POF_STATS recorded"
"$POF" export val.lcmlog -c POF_RAW -o raw.csv 2>/dev/null
"$POF" compensate val.lcmlog --cal cal.toml --csv offline.csv >/dev/null 2>&1

/usr/bin/python3 - <<'PY' || fail "comparison failed"
import csv, math, sys
import numpy as np
live = list(csv.DictReader(open("live.csv")))
raw = list(csv.DictReader(open("raw.csv")))
off = list(csv.DictReader(open("offline.csv")))
stats = list(csv.DictReader(open("stats.csv")))
n = len(raw)
assert len(live) == n, f"{len(live)} angles for {n} scans"
seqs = [int(r["seq"]) for r in live]
assert seqs == list(range(n)), "angle sequence numbers not continuous"
assert [int(r["scan_index"]) for r in live] == [int(r["scan_index"]) for r in raw], "scan indices differ"
assert len(off) == n
same = sum(1 for a, b in zip(live, off)
           if (math.isnan(float(a["angle_deg"])) and math.isnan(float(b["angle_deg"])))
           or np.float32(a["angle_deg"]) == np.float32(float(b["angle_deg"])))
assert same == n, f"live and offline differ on {n - same} of {n} scans"
err = np.array([float(a["angle_deg"]) - float(r["angle_true"]) for a, r in zip(live, raw)
                if int(a["quality"]) == 0])
rmse = float(np.sqrt(np.mean(err ** 2)))
print(f"{n} scans, {len(stats)} cycles, RMSE vs ground truth {rmse:.3f} deg over {err.size} clean scans")
assert len(stats) >= 1, "no cycle statistics"
assert rmse < 1.0, f"RMSE {rmse:.3f} deg"
PY
echo ok
