# `pof sim` end to end: CSV and LCM log output, determinism, lcm-logplayer replay, error exits.
source "$(dirname "$0")/lib.sh"
POF="$BIN_DIR/pof"

# CSV: header, one row per scan, ground truth column.
expect_exit 0 "$POF" sim paper -o paper.csv --seconds 10 --seed 3
[ "$(head -1 paper.csv)" = "t_s,sensor_v,reference_v,angle_ref_deg,angle_true_deg" ] || fail "CSV header: $(head -1 paper.csv)"
[ "$(wc -l < paper.csv)" -eq 2001 ] || fail "expected 2000 scans at 200 Hz for 10 s, got $(($(wc -l < paper.csv) - 1))"
[ "$(sed -n 2p paper.csv | cut -d, -f5)" = "0" ] || fail "the session starts at 0 deg"
expect_exit 0 "$POF" sim paper -o paper2.csv --seconds 10 --seed 3
cmp -s paper.csv paper2.csv || fail "same scenario and seed gave different bytes"
expect_exit 0 "$POF" sim paper -o paper3.csv --seconds 10 --seed 4
cmp -s paper.csv paper3.csv && fail "different seeds gave the same bytes"

# A scenario file and --rate; --pot-column adds pot_v.
cp "$SOURCE_DIR/daq/sim/scenarios/realistic.toml" my.toml
expect_exit 0 "$POF" sim my.toml -o r.csv --seconds 2 --rate 1000 --pot-column
[ "$(head -1 r.csv)" = "t_s,sensor_v,reference_v,angle_ref_deg,pot_v,angle_true_deg" ] || fail "pot column: $(head -1 r.csv)"
[ "$(wc -l < r.csv)" -eq 2001 ] || fail "2 s at 1 kHz"

# LCM log: 20 scans a block; lcm-logplayer replays every event into a file:// log.
expect_exit 0 "$POF" sim realistic -o r.lcmlog --seconds 10
grep -q "100 POF_RAW blocks" <<<"$out$err" || fail "expected 100 blocks: $out$err"
expect_exit 0 "$POF" sim realistic -o r2.lcmlog --seconds 10
cmp -s r.lcmlog r2.lcmlog || fail "LCM log not byte-deterministic"
if command -v lcm-logplayer >/dev/null; then
  expect_exit 0 timeout 60 lcm-logplayer -s 100 -l "file://$WORK_DIR/replay.lcmlog?mode=w" r.lcmlog
  count_events() { "$PY" "$SOURCE_DIR/tests/e2e/lcmlog_events.py" count "$1" POF_RAW; }
  [ "$(count_events r.lcmlog)" = 100 ] || fail "r.lcmlog: $(count_events r.lcmlog) events"
  [ "$(count_events replay.lcmlog)" = 100 ] || fail "lcm-logplayer replayed $(count_events replay.lcmlog) of 100 events"
fi

# --plot draws a PNG and --trace keeps the effect traces.
expect_exit 0 "$POF" sim realistic -o p.csv --seconds 30 --plot p.png --trace p_trace.csv
[ -s p.png ] && head -c 8 p.png | grep -q PNG || fail "no PNG"
head -1 p_trace.csv | grep -q "creep_v" || fail "trace columns"
[ ! -e p.trace.csv.tmp ] || fail "temporary plot data left behind"
# The fibre's own fields are columns too: on the memory-hysteresis fibre its contribution moves.
expect_exit 0 "$POF" sim fibre_calibration -o f.csv --seconds 20 --trace f_trace.csv
head -1 f_trace.csv | grep -q "memory_hysteresis_v,viscoelastic_lag_v,lag_deg,memory_state,power_law_relaxation_v,cyclic_softening_v,travel_deg$" || fail "fibre trace columns"
awk -F, 'NR > 1 && ($20 > 0.001 || $20 < -0.001) { moved = 1 } END { exit !moved }' f_trace.csv || fail "memory_hysteresis_v is flat"

# Bad scenario: exit 78 naming the key; the existing output is kept.
printf 'schema_version = 1\n[sensor.creep]\nenabled = true\n[[sensor.creep.terms]]\ntau_s = -3\ngain_v_per_deg = 0.001\n[[trajectory]]\nkind = "hold"\n' > bad.toml
cp paper.csv before.csv
expect_exit 78 "$POF" sim bad.toml -o paper.csv
grep -q "bad.toml:5: key 'sensor.creep.terms\[0\].tau_s'" <<<"$out$err" || fail "message does not name file:line and key: $out$err"
cmp -s paper.csv before.csv || fail "a failed run changed the existing output"
printf 'schema_version = 1\n[daq]\nscan_rate = 200\n[[trajectory]]\nkind = "hold"\n' > typo.toml
expect_exit 78 "$POF" sim typo.toml -o x.csv
grep -q "typo.toml:3: unknown key 'scan_rate' in \[daq\] (did you mean 'scan_rate_hz'?)" <<<"$out$err" || fail "typo not named: $out$err"
[ ! -e x.csv ] || fail "output written for a bad scenario"

# Missing scenario: 66; bad output name or options: 2.
expect_exit 66 "$POF" sim no-such-scenario -o x.csv
grep -q "paper, validation, session, realistic" <<<"$out$err" || fail "missing scenario message should list the builtins: $out$err"
expect_exit 2 "$POF" sim paper -o x.txt
expect_exit 2 "$POF" sim paper -o x.csv --seconds -1
expect_exit 2 "$POF" sim
expect_exit 74 "$POF" sim paper -o /nonexistent-dir/x.csv --seconds 1
echo ok
