# `pof export --format sto|mot`: an OpenSim Storage file of an angle and a statistics channel,
# checked by tests/e2e/export_opensim_check.py (header nRows/nColumns against the body, `time`
# first and increasing from 0 s, every angle and the velocity in degrees, the columns named by the
# sensor id); status channels and a time that goes back are refused, and CSV stays the default.
source "$(dirname "$0")/lib.sh"
POF="$BIN_DIR/pof"
CHECK=(env PYTHONPATH="$BIN_DIR/../python" "$PY" "$SOURCE_DIR/tests/e2e/export_opensim_check.py")

"${CHECK[@]}" write session.lcmlog || fail "could not write the test log"

expect_exit 0 "$POF" export session.lcmlog -c POF_ANGLE_LEFT_KNEE -o knee.sto
grep -q "50 events -> 50 rows in knee.sto" <<<"$err" || fail "summary: $err"
"${CHECK[@]}" angles knee.sto || fail "knee.sto: see above"
# .mot: the same table (OpenSim reads both; docs/export.md says when each suits), by extension or --format.
expect_exit 0 "$POF" export session.lcmlog -c POF_ANGLE_LEFT_KNEE -o knee.mot
cmp -s knee.sto knee.mot || fail "knee.mot differs from knee.sto"
expect_exit 0 "$POF" export session.lcmlog -c POF_ANGLE_LEFT_KNEE -o knee.txt --format mot
cmp -s knee.sto knee.txt || fail "--format mot differs from knee.sto"
expect_exit 0 "$POF" export session.lcmlog -c POF_STATS_LEFT_KNEE -o stats.sto
"${CHECK[@]}" stats stats.sto || fail "stats.sto: see above"

# CSV is still the default, and --format csv wins over a .sto name.
expect_exit 0 "$POF" export session.lcmlog -c POF_ANGLE_LEFT_KNEE -o knee.csv
[ "$(head -c 11 knee.csv)" = "utime,seq,s" ] || fail "knee.csv: $(head -1 knee.csv)"
expect_exit 0 "$POF" export session.lcmlog -c POF_ANGLE_LEFT_KNEE -o csv.sto --format csv
cmp -s knee.csv csv.sto || fail "--format csv did not write the CSV"

# Refused, nothing written: a status channel (text has no place in a Storage file: usage, 2) and a
# time that goes back (OpenSim refuses such a table: bad input, 65).
expect_exit 2 "$POF" export session.lcmlog -c POF_DAQ_STATUS_LEFT_KNEE -o status.sto
[[ "$err" == *"POF_DAQ_STATUS_LEFT_KNEE holds daq_status_t messages"*"--format csv"* ]] || fail "status: $err"
[ ! -e status.sto ] || fail "status.sto written"
expect_exit 65 "$POF" export session.lcmlog -c POF_ANGLE_BACK -o back.sto
[[ "$err" == *"POF_ANGLE_BACK: row 3: utime 1764000000002000 does not follow utime 1764000000005000"* ]] ||
  fail "time going back: $err"
[ ! -e back.sto ] || fail "back.sto written"
expect_exit 0 "$POF" export session.lcmlog -c POF_ANGLE_BACK -o back.csv
expect_exit 2 "$POF" export session.lcmlog -c POF_ANGLE_LEFT_KNEE -o x.sto --format xls
echo ok
