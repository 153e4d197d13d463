# Golden outputs: fixed inputs through the real binaries give the outputs kept in tests/e2e/golden/,
# so that a change meant to leave behaviour alone (a refactor, a move) is proved to:
#   - cal.toml of `pof calibrate` on two simulated calibration sessions: the paper's sensor (the
#     paper model active) and a viscoelastic fibre (the dynamic model active);
#   - `pof compensate` (per-scan CSV and statistics JSON) of a held-out session on each;
#   - the POF_ANGLE stream pof-compensatord publishes from a log played by stock lcm-logplayer
#     (every field but publish_utime, the wall clock);
#   - `pof gap` on a session with a hidden creep: gap.json and model.toml;
#   - the fibre's calibration as a schema_version 2 file (no [estimator]) and the new file with
#     `--dynamic-angle invert`: both give the per-scan inverse's output of before the estimator,
#     and the same bytes as each other.
# A per-scan CSV is kept as its digest (golden_digest.py: every 50th row, each column's sum or hash),
# the small files whole; the calibration files' `date` (the wall clock) is taken out. numdiff
# compares them: words exactly, numbers to 1e-8 relative or 1e-9 absolute. Not bytes: glibc's libm
# takes other code paths on a processor without FMA, and the last bits of an exp() move; seen
# between FMA on and off (GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F), the largest
# difference was 4e-9 relative, 2e-11 absolute, on a reduction near zero in gap.json. What passes
# unseen: a change below 1e-8 of a kept number, or of a float column's sum in the rows not kept
# (a stateful estimator carries a change into the kept rows); integer columns are hashed whole.
# (Eigen's blocking, the other machine dependence, is pinned in compensator/CMakeLists.txt.)
# A change that is meant to change behaviour regenerates the references (`POF_GOLDEN_UPDATE=1`,
# the test then writes them and passes) and says why in its commit body.
source "$(dirname "$0")/lib.sh"
POF="$BIN_DIR/pof"
GOLDEN="$SOURCE_DIR/tests/e2e/golden"
command -v numdiff >/dev/null || fail "numdiff is missing: ./pofkit setup installs it (the Debian package numdiff)"

# --- Calibrations and offline compensation --------------------------------------------------------
"$POF" sim paper -o paper-cal.csv --seed 11 2>/dev/null
"$POF" sim validation -o paper-val.lcmlog --seconds 60 --seed 12 2>/dev/null
"$POF" calibrate paper-cal.csv -o paper-cal.toml --no-plots >/dev/null 2>&1 || fail "pof calibrate (paper) failed"
"$POF" compensate paper-val.lcmlog --cal paper-cal.toml --csv paper-comp.csv --json paper-comp.json >/dev/null 2>&1 ||
  fail "pof compensate (paper) failed"

"$POF" sim fibre_calibration -o fibre-cal.csv --seed 1 2>/dev/null
"$POF" sim fibre_session -o fibre-session.csv --seconds 60 --seed 2 2>/dev/null
"$POF" calibrate fibre-cal.csv -o fibre-cal.toml --no-plots >/dev/null 2>&1 || fail "pof calibrate (fibre) failed"
"$POF" compensate fibre-session.csv --cal fibre-cal.toml --csv fibre-comp.csv --json fibre-comp.json >/dev/null 2>&1 ||
  fail "pof compensate (fibre) failed"

# --- The daemon's POF_ANGLE stream, played by lcm-logplayer ---------------------------------------
private_bus
start_ready notify daemon.log "$BIN_DIR/pof-compensatord" --cal paper-cal.toml --lcm-url "$URL"
pids+=($!); daemon=$!
start_ready notify record.log "$POF" record -o angles.lcmlog --lcm-url "$URL" -c 'POF_ANGLE' -q
pids+=($!); recorder=$!
lcm-logplayer -s 10 -l "$URL" paper-val.lcmlog >/dev/null 2>&1 || fail "lcm-logplayer failed"
blocks=$("$POF" record --check paper-val.lcmlog | awk '$1 == "POF_RAW" { print $3 }')
caught_up --lcm-url "$URL" --blocks "$blocks" || fail "pof-compensatord did not take the $blocks blocks played"
kill -TERM "$daemon"; wait "$daemon" || fail "pof-compensatord exit status $? on SIGTERM"
wait_until --drained "$PORT" || fail "pof record did not read what was sent"
kill -INT "$recorder"; wait "$recorder" || true
"$POF" export angles.lcmlog -c POF_ANGLE -o angles-export.csv 2>/dev/null || fail "pof export failed"
"$PY" - angles-export.csv angles.csv <<'PY' || fail "POF_ANGLE export unreadable"
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
if not rows:
    sys.exit("no POF_ANGLE recorded")
keep = [k for k in rows[0] if k != "publish_utime"]
with open(sys.argv[2], "w", newline="") as f:
    w = csv.DictWriter(f, keep, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
PY

# --- pof gap on a hidden creep ---------------------------------------------------------------------
cat >creep.toml <<'TOML'
schema_version = 1
name = "golden-creep"
[sensor.creep]
enabled = true
terms = [ { tau_s = 4.0, gain_v_per_deg = -0.0015 } ]
TOML
gap_protocol >>creep.toml
"$POF" sim creep.toml -o creep.csv --seed 3 2>/dev/null
"$POF" gap creep.csv --out gap --no-plots >/dev/null 2>&1 || fail "pof gap failed"
# --- Every appliable [gap] term and both kinematic effects, on either model ------------------------
# (the compensator's term chains, its solve and the play's inverse: docs/calibration.md, "[gap]")
terms() {
  cat <<'TOML'

[gap]
schema_version = 1
delay_s = 0.03
backlash_deg = 1.0
[[gap.terms]]
effect = "static_nonlinearity"
coefficients_v = [0.002, -0.001, 0.0005, 0.0]
[[gap.terms]]
effect = "creep"
theta = 4.0
coefficients_v = [0.0015]
[[gap.terms]]
effect = "rate_dependent_hysteresis"
theta = 0.2
coefficients_v = [0.002, 0.001]
[[gap.terms]]
effect = "acceleration_dependence"
theta = 0.05
coefficients_v = [0.002]
[[gap.terms]]
effect = "source_power_coupling"
coefficients_v = [0.01, 0.0]
[[gap.terms]]
effect = "periodic_interference"
theta = 50.0
coefficients_v = [0.001, 0.0, 0.0, 0.0]
[[gap.terms]]
effect = "memory_hysteresis"
thresholds_deg = [1.0, 3.0, 6.0]
coefficients_v = [0.001, 0.0008, 0.0005]
[[gap.terms]]
effect = "viscoelastic_relaxation"
time_constants_s = [0.5, 5.0]
coefficients_v = [0.001, 0.0005]
TOML
}
{ cat paper-cal.toml; terms; } >paper-terms.toml
{ cat fibre-cal.toml; terms; } >fibre-terms.toml
"$POF" compensate paper-val.lcmlog --cal paper-terms.toml --csv paper-terms.csv >/dev/null 2>&1 ||
  fail "pof compensate (paper, every term) failed"
"$POF" compensate fibre-session.csv --cal fibre-terms.toml --csv fibre-terms.csv >/dev/null 2>&1 ||
  fail "pof compensate (fibre, every term) failed"
"$POF" compensate paper-val.lcmlog --cal paper-cal.toml --reversal-window 0.1 --csv paper-reversal.csv >/dev/null 2>&1 ||
  fail "pof compensate (paper, reversal window) failed"
# An older calibration file: schema 2 had no [estimator].
"$PY" - fibre-cal.toml fibre-cal-v2.toml <<'PY' || fail "cannot write the schema 2 file"
import re, sys
text = open(sys.argv[1]).read().replace("schema_version = 3\n", "schema_version = 2\n", 1)
text = re.sub(r"\n\[estimator\][^\[]*", "\n", text)
open(sys.argv[2], "w").write(text)
PY
grep -q '^\[estimator\]' fibre-cal.toml || fail "fibre-cal.toml has no [estimator]"
! grep -q 'estimator' fibre-cal-v2.toml || fail "fibre-cal-v2.toml still has an [estimator]"
"$POF" compensate fibre-session.csv --cal fibre-cal-v2.toml --csv fibre-comp-v2.csv >/dev/null 2>&1 ||
  fail "pof compensate (fibre, schema 2 file) failed"
"$POF" compensate fibre-session.csv --cal fibre-cal.toml --dynamic-angle invert --csv fibre-comp-invert.csv >/dev/null 2>&1 ||
  fail "pof compensate (fibre, --dynamic-angle invert) failed"
{ cat fibre-cal-v2.toml; terms; } >fibre-terms-v2.toml
"$POF" compensate fibre-session.csv --cal fibre-terms-v2.toml --csv fibre-terms-v2.csv >/dev/null 2>&1 ||
  fail "pof compensate (fibre, schema 2 file, every term) failed"

cp gap/gap.json gap.json
cp gap/model.toml gap-model.toml
for f in paper-cal.toml fibre-cal.toml gap-model.toml; do sed -i '/^date = /d' "$f"; done

cmp -s fibre-comp-v2.csv fibre-comp-invert.csv ||
  fail "the schema 2 file and --dynamic-angle invert differ (fibre-comp-v2.csv, fibre-comp-invert.csv)"

files=(paper-cal.toml paper-comp.csv paper-comp.json fibre-cal.toml fibre-comp.csv fibre-comp.json angles.csv gap.json
  gap-model.toml paper-terms.csv fibre-terms.csv paper-reversal.csv fibre-comp-v2.csv fibre-terms-v2.csv)
mkdir -p kept
for f in "${files[@]}"; do
  case "$f" in
    *.csv) "$PY" "$SOURCE_DIR/tests/e2e/golden_digest.py" "$f" "kept/$f" || fail "cannot digest $f" ;;
    *) cp "$f" "kept/$f" ;;
  esac
done
if [ "${POF_GOLDEN_UPDATE:-0}" = 1 ]; then
  rm -f "$GOLDEN"/*
  cp kept/* "$GOLDEN/"
  echo "wrote ${#files[@]} references to $GOLDEN"
  exit 0
fi
# Fields split at these characters; numbers within 1e-8 relative or 1e-9 absolute are equal.
same=(-s ' \t\n,=[]{}:"|' -r 1e-8 -a 1e-9)
differ=()
for f in "${files[@]}"; do
  [ -s "$GOLDEN/$f" ] || fail "$GOLDEN/$f missing: run this test once with POF_GOLDEN_UPDATE=1"
  numdiff -q "${same[@]}" "$GOLDEN/$f" "kept/$f" >/dev/null || differ+=("$f")
done
for f in "${differ[@]}"; do
  echo "--- $f differs from the golden one (first differences; '<==' golden, '==>' now):"
  numdiff "${same[@]}" "$GOLDEN/$f" "kept/$f" | head -20 || true
done
[ ${#differ[@]} = 0 ] || fail "${#differ[@]} output(s) differ from the golden ones: ${differ[*]} (work files kept in $WORK_DIR)"
echo "ok: ${#files[@]} outputs as the golden ones"
