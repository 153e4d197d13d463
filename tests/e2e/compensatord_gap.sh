# [gap] effect terms in the real programs (docs/calibration.md, "`[gap]`: effect terms and how the
# compensator applies them"): pof-compensatord and pof compensate refuse, with exit 78 and a
# message naming the file, the term and why, a calibration with a term they cannot apply; the
# daemon applies a good one over udpm exactly as `pof compensate` does, and a SIGHUP to a file it
# cannot apply keeps the previous calibration.
source "$(dirname "$0")/lib.sh"
private_bus
POF="$BIN_DIR/pof"

"$POF" sim paper -o cal.csv --seed 11 2>/dev/null
"$POF" calibrate cal.csv -o cal.toml >/dev/null 2>&1 || fail "pof calibrate failed"
"$POF" sim validation -o val.lcmlog --seconds 30 --seed 12 2>/dev/null

gap_head='
[gap]
schema_version = 1
delay_s = 0.01
backlash_deg = 0.8
[[gap.terms]]
effect = "creep"
theta = 5.0
coefficients_v = [ -0.0015 ]
[gap.terms.parameters]
tau_s = 5.0'
{ cat cal.toml; echo "$gap_head"; } >good.toml
{ cat cal.toml; echo "$gap_head"; printf '[[gap.terms]]\neffect = "drift"\ncoefficients_v = [ 0.002 ]\n'; } >drift.toml
drift_line=$(grep -n '^effect = "drift"' drift.toml | cut -d: -f1)
drift_line=$((drift_line - 1))   # the term's [[gap.terms]] line
why="[gap] term 2 'drift': a trend over the calibration recording cannot be applied online; remove it or recalibrate"
{ cat cal.toml; printf '\n[gap]\nschema_version = 1\n[[gap.terms]]\neffect = "periodic_interference"\ntheta = 60.0\ncoefficients_v = [ 0.001, 0.0, 0.0, 0.0 ]\n'; } >mains60.toml

# --- refused at start: exit 78, the file, the term's line, number, effect and why
expect_exit 78 "$BIN_DIR/pof-compensatord" --cal drift.toml --lcm-url "$URL" --duration 0.1
grep -qF "pof-compensatord: error: drift.toml:$drift_line: $why" <<<"$err" || fail "daemon's refusal: $err"
expect_exit 78 "$POF" compensate val.lcmlog --cal drift.toml
grep -qF "drift.toml:$drift_line: $why" <<<"$err" || fail "pof compensate's refusal: $err"
# A 60 Hz notch runs at 200 Hz but not at 100 Hz (--scan-rate, the rate the daemon expects).
expect_exit 78 "$BIN_DIR/pof-compensatord" --cal mains60.toml --scan-rate 100 --lcm-url "$URL" --duration 0.1
grep -qF "the frequency 60 Hz is at or above the Nyquist frequency 50 Hz of 100 Hz scans" <<<"$err" || fail "Nyquist refusal: $err"
expect_exit 0 "$POF" compensate val.lcmlog --cal mains60.toml

# --- a good file is applied live, as offline
cp good.toml live.toml
start_ready notify daemon.log "$BIN_DIR/pof-compensatord" --cal live.toml --lcm-url "$URL"
pids+=($!); daemon=$!
start_ready notify record.log "$POF" record -o rec.lcmlog --lcm-url "$URL" -c 'POF_ANGLE' -q
pids+=($!); recorder=$!
lcm-logplayer -s 10 -l "$URL" val.lcmlog >/dev/null 2>&1 || fail "lcm-logplayer failed"
blocks=$("$POF" record --check val.lcmlog | awk '$1 == "POF_RAW" { print $3 }')
caught_up --lcm-url "$URL" --blocks "$blocks" || fail "pof-compensatord did not take the $blocks blocks played"

# --- SIGHUP to a file it cannot apply: refused, named, the previous calibration kept
cp drift.toml live.toml
kill -HUP "$daemon"
wait_until -- grep -qF "reload failed, keeping the previous one: live.toml:$drift_line: $why" daemon.log ||
  fail "bad reload not reported: $(cat daemon.log)"
kill -0 "$daemon" || fail "daemon died on a bad reload"
kill -TERM "$daemon"; wait "$daemon" || fail "daemon exit status $? on SIGTERM"
wait_until --drained "$PORT" || fail "pof record did not read what was sent"
kill -INT "$recorder"; wait "$recorder" || true

"$POF" export rec.lcmlog -c POF_ANGLE -o live.csv 2>/dev/null
"$POF" compensate val.lcmlog --cal good.toml --csv offline.csv >/dev/null 2>&1 || fail "pof compensate good.toml"
"$POF" compensate val.lcmlog --cal cal.toml --csv plain.csv >/dev/null 2>&1 || fail "pof compensate cal.toml"
"$PY" - <<'PY' || fail "live vs offline"
import csv, math, sys
import numpy as np
live = [float(r["angle_deg"]) for r in csv.DictReader(open("live.csv"))]
off = [float(r["angle_deg"]) for r in csv.DictReader(open("offline.csv"))]
plain = [float(r["angle_deg"]) for r in csv.DictReader(open("plain.csv"))]
if len(live) != len(off) or not live:
    sys.exit(f"FAIL: {len(live)} live angles, {len(off)} offline")
same = sum(1 for a, b in zip(live, off) if (math.isnan(a) and math.isnan(b)) or np.float32(a) == np.float32(b))
moved = max(abs(a - b) for a, b in zip(off, plain) if not (math.isnan(a) or math.isnan(b)))
print(f"{len(live)} scans: live = offline (with [gap]) on {same}; [gap] moves the angle by up to {moved:.3f} deg")
if same != len(live):
    sys.exit(f"FAIL: live and offline differ on {len(live) - same} scans")
if moved < 0.1:
    sys.exit("FAIL: the [gap] terms changed nothing")
PY
echo ok
