# pof calibrate / pof compensate end to end on recordings generated from the model
# (tests/support/gen_recording): outputs, formats, exit codes 65 (with the line) / 66 / 78 (with
# the key), no overwrite of good files by a failed run, quiet in pipes.
source "$(dirname "$0")/lib.sh"
POF="$BIN_DIR/pof"
GEN="$BIN_DIR/../tests/gen_recording"
CHECK="$SOURCE_DIR/tests/e2e/calibrate_compensate_check.py"

"$GEN" cal.csv calibration
"$GEN" val.csv validation
"$GEN" cal_pot.csv calibration pot

# --- calibrate, with the report
expect_exit 0 "$POF" calibrate cal.csv -o cal.toml --report rep --sensor-id LEFT_KNEE
grep -q '^schema_version = 3$' cal.toml || fail "cal.toml has no schema_version = 3"
grep -Eq '^active_model = "(paper|dynamic)"$' cal.toml || fail "cal.toml has no active_model"
grep -q '^\[dynamic\]' cal.toml || fail "cal.toml has no [dynamic] model"
grep -Eq 'held-out .*paper RMSE [0-9.]+ deg.*dynamic RMSE [0-9.]+ deg' <<<"$out" || fail "both held-out errors not printed: $out"
grep -q '^sensor_id = "LEFT_KNEE"$' cal.toml || fail "sensor id not stored"
grep -q 'alpha_f = (' <<<"$out" || fail "eq. (11) not printed: $out"
grep -q 'alpha_e = (' <<<"$out" || fail "eq. (12) not printed: $out"
grep -Eq '^speeds +identified up to [0-9.]+ rad/s' <<<"$out" || fail "the identified speed range not printed: $out"
[[ "$out$err" != *$'\r'* ]] || fail "progress output in a pipe"
for f in calibration.json compensated.csv fig6_quasi_static.png fig7_regressions.png loops.png error_vs_angle.png \
  dynamic.csv dynamic_loop.png heldout_error.png; do
  [ -s "rep/$f" ] || fail "report file rep/$f missing or empty"
done
"$PY" "$CHECK" calibration rep/calibration.json || fail "calibration.json lacks figures"

# --- compensate: the CSV and JSON formats other tools read
expect_exit 0 "$POF" compensate val.csv --cal cal.toml --csv out.csv --json stats.json
[ "$(head -1 out.csv)" = "t_s,angle_deg,angle_uncomp_deg,angle_ref_deg,velocity_rad_s,phase,quality" ] || fail "out.csv header: $(head -1 out.csv)"
# quality: the QUALITY_* bits; the settling start is flagged (64), most scans are clean (0).
awk -F, 'NR > 1 && $7 == 0 { found = 1 } END { exit !found }' out.csv || fail "no clean scan in the quality column"
awk -F, 'NR > 1 && int($7 / 64) % 2 == 1 { found = 1 } END { exit !found }' out.csv || fail "no settling flag in the quality column"
[ "$(wc -l <out.csv)" -eq "$(wc -l <val.csv)" ] || fail "out.csv must have one row per input scan"
cut -d, -f6 out.csv | tail -n +2 | sort -u | tr '\n' ' ' | grep -qx "extension flexion hold " || fail "phases: $(cut -d, -f6 out.csv | sort -u)"
grep -q '^overall ' <<<"$out" || fail "no table-3 summary printed: $out"
"$PY" "$CHECK" stats stats.json || fail "stats.json keys or values wrong"
# '-' is standard output, not a file named '-', and stdout is the JSON alone (the summary on stderr).
expect_exit 0 "$POF" compensate val.csv --cal cal.toml --json - --csv stdout_check.csv
[ ! -e ./- ] || fail "--json - wrote a file named '-'"
printf '%s' "$out" >stdout.json
"$PY" "$CHECK" has-overall stdout.json || fail "--json - did not print the JSON alone on stdout"
grep -q '^overall ' <<<"$err" || fail "--json -: no table-3 summary on stderr"

# --- model steps (docs/calibration.md, "Model steps"), on by default: the generated sensor follows
# eqs. (11)/(12) and steps at starts, stops and reversals; with --no-model-steps those steps are
# read as motion again and the paper model's error grows.
expect_exit 0 "$POF" compensate val.csv --cal cal.toml --model paper --json steps_on.json
expect_exit 0 "$POF" compensate val.csv --cal cal.toml --model paper --no-model-steps --json steps_off.json
"$PY" "$CHECK" lower steps_on.json steps_off.json || fail "model steps did not lower the paper model's RMSE"

# --- the model: the file's active one, or either by --model
expect_exit 0 "$POF" compensate val.csv --cal cal.toml --model dynamic
grep -q "dynamic model" <<<"$out" || fail "--model dynamic not used: $out"
expect_exit 0 "$POF" compensate val.csv --cal cal.toml --model paper
grep -q "paper model" <<<"$out" || fail "--model paper not used: $out"
expect_exit 2 "$POF" compensate val.csv --cal cal.toml --model lstm
expect_exit 0 "$POF" calibrate cal.csv -o cal_paper.toml --model paper
grep -q '^active_model = "paper"$' cal_paper.toml || fail "--model paper not stored"
sed '/^\[dynamic\]/,/^$/d; /^\[estimator\]/,/^$/d' cal_paper.toml >no_dynamic.toml
expect_exit 78 "$POF" compensate val.csv --cal no_dynamic.toml --model dynamic
grep -q "no_dynamic.toml: --model dynamic: the file has no \[dynamic\] section" <<<"$err" || fail "missing dynamic model not named: $err"
sed '/^\[dynamic\]/,/^$/d' cal_paper.toml >estimator_alone.toml
expect_exit 78 "$POF" compensate val.csv --cal estimator_alone.toml
grep -q "key 'estimator': needs a \[dynamic\] section" <<<"$err" || fail "[estimator] without [dynamic] not named: $err"
sed 's/^voltage_noise_v = .*/voltage_noise_v = -0.001/' cal.toml >bad_estimator.toml
expect_exit 78 "$POF" compensate val.csv --cal bad_estimator.toml
grep -q "key 'estimator.voltage_noise_v': expected a number > 0" <<<"$err" || fail "damaged [estimator] not named: $err"
expect_exit 0 "$POF" compensate val.csv --cal cal.toml --model dynamic --dynamic-angle invert
expect_exit 2 "$POF" compensate val.csv --cal cal.toml --dynamic-angle guess
# A fixed lag: each row still the scan it describes; the last 5 (25 ms at 200 Hz) have no output.
expect_exit 0 "$POF" compensate val.csv --cal cal.toml --model dynamic --estimator-lag 25 --csv lag.csv
"$PY" - lag.csv <<'PY' || fail "lag.csv: the last rows are not the ones without output"
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
tail = [r for r in rows[-5:] if math.isnan(float(r["angle_deg"]))]
body = [r for r in rows[:-5] if not math.isnan(float(r["angle_deg"]))]
sys.exit(0 if len(tail) == 5 and len(body) > 0.9 * (len(rows) - 5) else f"{len(tail)} NaN tail rows, {len(body)} finite")
PY
expect_exit 78 "$POF" compensate val.csv --cal cal.toml --model paper --estimator-lag 25
grep -q "estimator_lag_s needs the dynamic model's angle estimated" <<<"$err" || fail "a lag without the estimator: $err"
sed 's/^poly = .*/poly = [1.0]/' cal.toml >damaged.toml
expect_exit 78 "$POF" compensate val.csv --cal damaged.toml
grep -q "key 'dynamic.poly': expected degree + 1" <<<"$err" || fail "damaged dynamic section not named: $err"

# --- the same from LCM logs (pof.raw_block_t on POF_RAW, channels by name)
"$GEN" cal.lcmlog calibration
"$GEN" val.lcmlog validation
expect_exit 0 "$POF" calibrate cal.lcmlog -o cal_lcm.toml
expect_exit 0 "$POF" compensate val.lcmlog --cal cal_lcm.toml --json stats_lcm.json
"$PY" -c 'import json,sys; s=json.load(open("stats_lcm.json")); assert len(s["cycles"]) == 15; assert s["overall"]["rmse_comp_deg"] < s["overall"]["rmse_uncomp_deg"]' ||
  fail "LCM log recording: unexpected statistics"
head -c 50123 val.lcmlog >trunc.lcmlog   # events are 500 bytes: cut inside one
expect_exit 65 "$POF" compensate trunc.lcmlog --cal cal.toml
grep -q "trunc.lcmlog: damaged LCM log: first damage at byte 50000: event truncated" <<<"$err" || fail "truncated LCM log: $err"

# --- potentiometer-only recordings need --pot-cal (78 otherwise)
expect_exit 78 "$POF" calibrate cal_pot.csv -o pot_cal.toml
grep -q "pot-cal" <<<"$err" || fail "no hint about --pot-cal: $err"
printf '[potentiometer]\ndeg_per_volt = 18.0\nzero_v = 0.0\n' >pot.toml
expect_exit 0 "$POF" calibrate cal_pot.csv -o pot_cal.toml --pot-cal pot.toml
grep -q '^\[potentiometer\]' pot_cal.toml || fail "potentiometer calibration not stored"

# --- bad data: 65 with file:line, and a good calibration file is never replaced by a failed run
cp cal.toml cal.keep
awk -F, 'NR==1234 {$2="abc"} {print}' OFS=, val.csv >bad.csv
expect_exit 65 "$POF" compensate bad.csv --cal cal.toml
grep -q "bad.csv:1234: column sensor_v" <<<"$err" || fail "no line number for a corrupt value: $err"
head -c 100000 val.csv >trunc.csv
last=$(wc -l <trunc.csv); last=$((last + 1))
expect_exit 65 "$POF" compensate trunc.csv --cal cal.toml
grep -q "trunc.csv:$last:" <<<"$err" || fail "no line number for a truncated file: $err"
expect_exit 65 "$POF" calibrate trunc.csv -o cal.toml
cmp -s cal.toml cal.keep || fail "a failed calibrate changed cal.toml"
expect_exit 65 "$POF" calibrate val.csv -o cal.toml
grep -q "hold" <<<"$err" || fail "calibrating without holds should say so: $err"
cmp -s cal.toml cal.keep || fail "a failed calibrate changed cal.toml"
printf 'time,volts\n1,2\n' >wrong_header.csv
expect_exit 65 "$POF" compensate wrong_header.csv --cal cal.toml
grep -q "wrong_header.csv:1: header has no column 't_s'" <<<"$err" || fail "header error: $err"

# --- missing files: 66
expect_exit 66 "$POF" compensate no_such.csv --cal cal.toml
grep -q "no_such.csv" <<<"$err" || fail "missing recording not named: $err"
expect_exit 66 "$POF" compensate val.csv --cal no_such.toml

# --- bad calibration files: 78, naming the key; nothing half-loaded
sed '/^c7 = /{x;s/^/x/;/^x$/{x;d};x}' cal.toml >missing_key.toml   # drop model.flexion.c7
expect_exit 78 "$POF" compensate val.csv --cal missing_key.toml
grep -q "key 'model.flexion.c7': missing" <<<"$err" || fail "missing key not named: $err"
sed 's/^c9 = .*/c9 = "fast"/' cal.toml >wrong_type.toml
expect_exit 78 "$POF" compensate val.csv --cal wrong_type.toml
grep -q "key 'model.c9': expected a number, got a string" <<<"$err" || fail "wrong type not named: $err"
sed 's/^c10 = .*/c10 = nan/' cal.toml >nan.toml
expect_exit 78 "$POF" compensate val.csv --cal nan.toml
grep -q "key 'model.c10': expected a finite number" <<<"$err" || fail "NaN not named: $err"
sed 's/^velocity_max_rad_s = .*/velocity_max_rad_s = 0.001/' cal.toml >range.toml
expect_exit 78 "$POF" compensate val.csv --cal range.toml
grep -q "key 'range.velocity_max_rad_s'" <<<"$err" || fail "impossible range not named: $err"
sed 's/^schema_version = 3/schema_version = 7/' cal.toml >schema.toml
expect_exit 78 "$POF" compensate val.csv --cal schema.toml
grep -q "key 'schema_version': expected 1, 2 or 3, got 7" <<<"$err" || fail "schema version: $err"
sed 's/^c9 = \(.*\)/c9 = \1\nc9x = 1.0/' cal.toml >unknown_key.toml
expect_exit 78 "$POF" compensate val.csv --cal unknown_key.toml
grep -q "unknown_key.toml:[0-9]*: unknown key 'c9x' in \[model\] (did you mean 'c9'?)" <<<"$err" || fail "unknown key not refused: $err"
printf 'schema_version = 1\n[model\nc1 = 2\n' >syntax.toml
expect_exit 78 "$POF" compensate val.csv --cal syntax.toml
grep -q "syntax.toml:2:" <<<"$err" || fail "TOML syntax error without line: $err"

# --- usage: 2
expect_exit 2 "$POF" compensate val.csv
expect_exit 2 "$POF" calibrate cal.csv
echo "ok"
