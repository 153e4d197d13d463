# A hung acquisition thread is neither reported as streaming nor kept alive for systemd: WATCHDOG=1
# stops, the status turns to `fault` "acquisition stalled" within the stall bound, and the scans
# handed over after it carry FLAG_LATE. The thread is stalled for 3 s twice: by the sim backend's
# POF_SIM_STALL hook, and from outside by stopping that one thread with ptrace (as a debugger, or a
# read that never returns, would), which needs no hook in the daemon.
# 1000 scans/s, decimate 10, 5 scans per block: 50-ms blocks, stall bound max(10 x 50 ms, 500 ms)
# = 500 ms; with data_timeout_ms and command_timeout_ms 500 the watchdog grace is 1000 ms
# (docs/daq.md, "Watchdog and stalls").
source "$(dirname "$0")/lib.sh"
private_bus
stall_check() {  # stall_check <hook|ptrace>: exit status of the checker (77: ptrace not permitted)
  PYTHONPATH="$BIN_DIR/../python:$SOURCE_DIR/lcmtypes/python" "$PY" "$SOURCE_DIR/tests/e2e/daq_sim_stall_check.py" \
    --daqd "$BIN_DIR/pof-daqd" --url "$URL" --how "$1" --stall 2:3 --stall-ms 500 --grace-ms 1000 -- \
    --device sim:synthetic --rate 1000 --decimate 10 --block-scans 5 -s acquisition.data_timeout_ms=500 \
    -s acquisition.command_timeout_ms=500 --duration 7 2>"$WORK_DIR/daqd-$1.err"
}
stall_check hook || { tail -n 20 "$WORK_DIR/daqd-hook.err" >&2; fail "stall check (POF_SIM_STALL)"; }
grep -q "acquisition stalled" "$WORK_DIR/daqd-hook.err" || fail "the log does not name the stall"
grep -q "no longer feeding the watchdog" "$WORK_DIR/daqd-hook.err" || fail "the log does not say the watchdog is starved"
set +e
stall_check ptrace
rc=$?
set -e
if [ $rc -eq 77 ]; then
  echo "note: ptrace not permitted here; the stall from outside was not run"
elif [ $rc -ne 0 ]; then
  tail -n 20 "$WORK_DIR/daqd-ptrace.err" >&2
  fail "stall check (ptrace)"
fi
# A malformed hook is a configuration error, never a run without the stall asked for.
POF_SIM_STALL=soon expect_exit 78 "$BIN_DIR/pof-daqd" --device sim:synthetic --lcm-url "$URL" --duration 1
grep -q "POF_SIM_STALL" <<<"$err" || fail "POF_SIM_STALL error: $err"
echo ok
