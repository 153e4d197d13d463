# `pof gap` end to end: a simulated session with hidden creep (pof sim, scenario written
# here) analysed from the CSV file alone; the outputs, the quiet pipe, and the exit codes; then a
# fibre of the dynamic model's kind, for which model.toml makes the dynamic baseline active.
source "$(dirname "$0")/lib.sh"

cat >creep.toml <<'TOML'
schema_version = 1
name = "e2e-creep"
[sensor.creep]
enabled = true
terms = [ { tau_s = 4.0, gain_v_per_deg = -0.0015 } ]
TOML
gap_protocol >>creep.toml
expect_exit 0 "$BIN_DIR/pof" sim creep.toml -o creep.csv --seed 3
expect_exit 0 "$BIN_DIR/pof" gap creep.csv --out report
[ -z "$err" ] || fail "pof gap printed on stderr in a pipe (progress must be terminal-only): $err"
grep -q "creep" <<<"$out" || fail "summary does not name creep: $out"
grep -q "^angle .* deg vs forward .* deg" <<<"$out" || fail "summary does not compare the angle with the forward gap: $out"
for f in gap.json model.toml report.md series.csv residual_time.png residual_angle.png residual_velocity.png loops.png gap_steps.png compensated.png; do
  [ -s "report/$f" ] || fail "report/$f missing"
done
"$PY" "$SOURCE_DIR/tests/e2e/gap_cli_check.py" report/gap.json || fail "gap.json content"
[ ! -e report/.pof-gap-stage ] || fail "the staging folder of the report was left behind"
grep -q '^schema_version = ' report/model.toml || fail "model.toml has no schema_version"
grep -Eq "effect = ['\"]creep['\"]" report/model.toml || fail "model.toml lacks the creep term"
# The loop closed: pof compensate applies the [gap] terms, and its angle is closer to the
# reference than with the same file without them (docs/gap.md, section 5).
expect_exit 0 "$BIN_DIR/pof" compensate creep.csv --cal report/model.toml --csv compensated.csv
sed '/^\[gap\]/,$d' report/model.toml >nogap.toml
expect_exit 0 "$BIN_DIR/pof" compensate creep.csv --cal nogap.toml --csv compensated_nogap.csv
"$PY" "$SOURCE_DIR/tests/e2e/gap_cli_check.py" --applied compensated.csv compensated_nogap.csv || fail "the [gap] terms did not help"

# Written as it goes (docs/gap.md, section 5): a run stopped as a time limit stops it (its whole
# process group, the plotting included) once its first stage is in leaves a report whole up to
# the last stage it reached: the numbers, that stage's plots, and no model.toml yet.
setsid "$BIN_DIR/pof" gap creep.csv --out stopped >stopped.log 2>&1 &
pid=$!
pids+=("$pid")
wait_until --timeout 120 -- test -s stopped/gap.json || fail "no stage of the report within 120 s: $(cat stopped.log)"
kill -TERM -- "-$(ps -o pgid= -p "$pid" | tr -d ' ')"
wait "$pid" || true
"$PY" - stopped <<'PY' || fail "the stopped run's report is not whole up to its stage"
import json, sys
from pathlib import Path
d = Path(sys.argv[1])
g = json.loads((d / "gap.json").read_text())
assert "stage" in g, "the run ended before it was stopped: gap.json has no stage"
assert g["stage"] in (d / "report.md").read_text(), "report.md does not say the stage gap.json is at"
for f in ("residual_time.png", "residual_angle.png", "residual_velocity.png", "loops.png", "gap_steps.png"):
    assert (d / f).read_bytes()[:4] == b"\x89PNG", f + " missing or not a PNG"
rows = (d / "series.csv").read_text().count("\n")
assert rows > 1000, f"series.csv has {rows} lines"
assert not (d / "model.toml").exists(), "model.toml written before the compensator checked the model"
assert len(g["steps"]) == 0 or g["steps"][-1]["gap_deg"] <= g["baseline_gap_deg"]
PY

# A fibre of the dynamic model's kind (no branch steps: a memory loop and a Prony relaxation;
# docs/gap.md, section 1): pof gap takes the dynamic baseline, model.toml makes it the active
# model, and pof compensate runs it, closer to the reference than the paper structure in the
# same file (--model paper).
cat >fibre.toml <<'TOML'
schema_version = 1
name = "e2e-dynamic-fibre"
[sensor.hysteresis]
enabled = false
[sensor.memory_hysteresis]
enabled = true
family = "maxwell_slip"
amplitude_v = 0.02
thresholds_deg = [1.5, 5.0, 12.0]
weights = [1.0, 1.0, 1.0]
[sensor.creep]
enabled = true
terms = [ { tau_s = 3.0, gain_v_per_deg = -0.0008 } ]
TOML
gap_protocol >>fibre.toml
expect_exit 0 "$BIN_DIR/pof" sim fibre.toml -o fibre.csv --seed 4
expect_exit 0 "$BIN_DIR/pof" gap fibre.csv --out fibre_report --no-plots
grep -q '^active_model = "dynamic"' fibre_report/model.toml || fail "model.toml of a dynamic-kind fibre does not make the dynamic model active: $(grep active_model fibre_report/model.toml)"
grep -q '^\[dynamic\]' fibre_report/model.toml || fail "model.toml has no [dynamic] section"
grep -q 'Baseline taken: the dynamic model' fibre_report/report.md || fail "report.md does not say which baseline was taken"
expect_exit 0 "$BIN_DIR/pof" compensate fibre.csv --cal fibre_report/model.toml --csv fibre_dynamic.csv
grep -q "dynamic model" <<<"$out$err" || fail "pof compensate did not run the dynamic model: $out$err"
expect_exit 0 "$BIN_DIR/pof" compensate fibre.csv --cal fibre_report/model.toml --model paper --csv fibre_paper.csv
"$PY" "$SOURCE_DIR/tests/e2e/gap_cli_check.py" --applied fibre_dynamic.csv fibre_paper.csv || fail "the dynamic baseline did not beat the paper structure online"

# Exit codes and messages of the brief.
expect_exit 2 "$BIN_DIR/pof" gap creep.csv
expect_exit 66 "$BIN_DIR/pof" gap no_such.csv --out x
grep -q "no_such.csv" <<<"$out$err" || fail "missing-file message does not name the file: $err"
{ head -5 creep.csv; echo "1.0,abc,4.0,3.0,3.0"; } >bad.csv
expect_exit 65 "$BIN_DIR/pof" gap bad.csv --out x
grep -q "bad.csv:6: column sensor_v" <<<"$out$err" || fail "bad-number message does not name file/line/column: $err"
printf 't_s,sensor_v\n0,1\n' >nocol.csv
expect_exit 65 "$BIN_DIR/pof" gap nocol.csv --out x
grep -q "reference_v" <<<"$out$err" || fail "missing-column message: $err"
head -2000 creep.csv >short.csv
expect_exit 65 "$BIN_DIR/pof" gap short.csv --out x
# A failed run leaves an existing report untouched.
cp report/gap.json before.json
expect_exit 65 "$BIN_DIR/pof" gap bad.csv --out report
cmp -s before.json report/gap.json || fail "a failed run changed an existing gap.json"
touch notadir
expect_exit 74 "$BIN_DIR/pof" gap creep.csv --out notadir/sub --no-plots
# `pof gap` is the program pof-gap beside pof: its help passes through, and a pof without it (a
# build of the demo's targets only) says what to build.
expect_exit 0 "$BIN_DIR/pof" gap --help
grep -q "^Usage: pof gap " <<<"$out" || fail "pof gap --help is not pof-gap's help: $(head -2 <<<"$out")"
mkdir -p lone && cp "$BIN_DIR/pof" lone/
expect_exit 78 lone/pof gap creep.csv --out x
grep -q "lone/pof-gap, which is not there: build it (cmake --build build --target pof-gap)" <<<"$err" ||
  fail "a missing pof-gap is not named: $err"
echo "ok"
