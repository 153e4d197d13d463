#!/usr/bin/env bash
# The main job on the built-in simulated exoskeleton (`./pofkit demo` runs this after building).
#
#   1. calibration: the paper's protocol (quasi-static steps + table-1 velocity cycles) is simulated
#      on a viscoelastic PMMA fibre (daq/sim/scenarios/fibre_calibration.toml: a hysteresis loop with
#      memory and Prony relaxation, not the paper's step model) and fitted: `pof calibrate` fits the
#      paper's model and the dynamic model, marks the one with the lower held-out error active and
#      writes cal.toml and a report with the paper's figures and the dynamic model's;
#   2. live session: pof-daqd streams the first 62 s of a simulated session on the same fibre
#      (sim:fibre_session: a hold and three subject cycles; $POF_DEMO_SECONDS, up to 115 s, adds
#      the last two cycles and the point-to-point moves with part-way reversals) in real time over
#      LCM on this host; pof-compensatord compensates every scan; pof record records every POF_*
#      channel losslessly;
#   3. summary: the per-cycle statistics (table 3) the daemon published, and a plot.
# Everything printed is measured in this run. Output: demo-output/<UTC time>/ (or $POF_DEMO_DIR).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=$PWD/build/bin
OUT=${POF_DEMO_DIR:-$PWD/demo-output/$(date -u +%Y%m%dT%H%M%SZ)}
mkdir -p "$OUT"
cd "$OUT"
# The live session's length: 62 s ends just after the third subject cycle (the daemon publishes a
# cycle's statistics once the next one starts), most of the demo's run time.
SECONDS_LIVE=${POF_DEMO_SECONDS:-62}
case "$SECONDS_LIVE" in '' | *[!0-9]*) echo "demo: POF_DEMO_SECONDS takes whole seconds, got '$SECONDS_LIVE'" >&2; exit 2 ;; esac
PORT=$((20000 + RANDOM % 30000))        # a private LCM bus for this run (ttl=0: this host only)
URL="udpm://239.255.76.67:$PORT?ttl=0"
say() { printf '\n\033[1m== %s\033[0m\n' "$*"; }
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

say "1/3 calibration on the simulated rig (paper protocol)"
"$BIN/pof" sim fibre_calibration -o calibration-session.csv --seed 1
"$BIN/pof" calibrate calibration-session.csv -o cal.toml --report calibration-report
# The simulated potentiometer: angle = 22.5 deg/V (pot_v - 0.5 V) (daq/sim/scenarios/*.toml, [knee]).
cat > pot.toml <<'TOML'
schema_version = 1
[potentiometer]
deg_per_volt = 22.5
zero_v = 0.5
TOML

say "2/3 live session: pof-daqd (sim:fibre_session) -> pof-compensatord -> pof record, LCM $URL"
"$BIN/pof" record -o session.lcmlog --lcm-url "$URL" -q 2>record.log &
pids+=($!); recorder=$!
"$BIN/pof-compensatord" --cal cal.toml --pot-cal pot.toml --lcm-url "$URL" 2>compensatord.log &
pids+=($!); compensator=$!
# The live view in a browser (docs/dashboard.md): this host only, on a free port it prints.
"$BIN/pof" dash --lcm-url "$URL" --port "${POF_DASH_PORT:-0}" >dash.log 2>&1 &
pids+=($!)
sleep 1
"$BIN/pof-daqd" --device sim:fibre_session --duration "$SECONDS_LIVE" --lcm-url "$URL" 2>daqd.log &
pids+=($!); daqd=$!
grep -o 'http://[^ ]*' dash.log | sed 's/^/watch it live in a browser: /' || echo "pof dash did not start: see $OUT/dash.log"
sleep 20
echo "what is on the bus 20 s in (pof spy snapshot; run 'build/bin/pof spy --lcm-url \"$URL\"' for the live view):"
"$BIN/pof" spy --lcm-url "$URL" --duration 2 || true
echo "... the session goes on for $SECONDS_LIVE s in real time"
wait "$daqd" || { cat daqd.log; exit 1; }
sleep 1
kill -TERM "$compensator"; wait "$compensator" || true
kill -INT "$recorder"; wait "$recorder" || true
"$BIN/pof" record --check session.lcmlog

say "3/3 summary"
"$BIN/pof" export session.lcmlog -c POF_ANGLE -o angles.csv
"$BIN/pof" export session.lcmlog -c POF_STATS -o stats.csv
/usr/bin/python3 "$OLDPWD/tools/plot/session_report.py" angles.csv stats.csv session.png \
  --title "pofkit demo: live compensation of a simulated session"  # the script adds the cycle count
/usr/bin/python3 - <<'PY'
import csv, math
angles = list(csv.DictReader(open("angles.csv")))
stats = list(csv.DictReader(open("stats.csv")))
print(f"{len(angles)} angles published on POF_ANGLE, sequence gaps: "
      f"{sum(1 for a, b in zip(angles, angles[1:]) if int(b['seq']) != int(a['seq']) + 1)}")
print(f"{'cycle':>5} {'w [rad/s]':>10} {'RMSE [deg]':>11} {'uncomp [deg]':>13} {'H [%]':>7} {'uncomp [%]':>11} {'max [deg]':>10}")
for s in stats:
    print(f"{s['cycle']:>5} {float(s['velocity_rad_s']):>10.3f} {float(s['rmse_comp_deg']):>11.3f} "
          f"{float(s['rmse_uncomp_deg']):>13.3f} {float(s['hysteresis_comp_pct']):>7.2f} "
          f"{float(s['hysteresis_uncomp_pct']):>11.2f} {float(s['max_error_deg']):>10.3f}")
PY
echo
echo "session log:        $OUT/session.lcmlog (lcm-logplayer plays it; pof compensate --cal cal.toml replays it)"
echo "calibration:        $OUT/cal.toml, report in $OUT/calibration-report/"
echo "session plot:       $OUT/session.png"
