# Shared helpers for the e2e scripts. Each script: `source "$(dirname "$0")/lib.sh"`.
set -euo pipefail
: "${BIN_DIR:?BIN_DIR is set by ctest}" "${SOURCE_DIR:?}" "${WORK_DIR:?}"
rm -rf "$WORK_DIR" && mkdir -p "$WORK_DIR"
cd "$WORK_DIR"

fail() { echo "FAIL: $*" >&2; exit 1; }

# expect_exit <code> <command...>: run, capture stdout/stderr in $out/$err, and check the exit code.
expect_exit() {
  local want=$1; shift
  set +e
  "$@" >"$WORK_DIR/.out" 2>"$WORK_DIR/.err"
  local got=$?
  set -e
  out=$(cat "$WORK_DIR/.out"); err=$(cat "$WORK_DIR/.err")
  [ "$got" -eq "$want" ] || fail "'$*' exited $got, expected $want; stderr: $err"
}

# --- A bus of its own, and the processes a script starts ------------------------------------------
# private_bus [GROUP]: PORT, a random port, and URL, a host-local udpm URL on it (ttl=0 multicast is
# host-wide: a port of its own keeps other runs off this test's bus).
private_bus() { PORT=$((20000 + RANDOM % 30000)); URL="udpm://${1:-239.255.76.67}:$PORT?ttl=0"; }
# Background processes a script starts go into pids; they are killed when the script exits.
pids=()
kill_started() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap kill_started EXIT

# --- Waiting on readiness and conditions (tests/e2e/pof_wait.py), never on a fixed time ----------
PY=/usr/bin/python3
POF_WAIT="$SOURCE_DIR/tests/e2e/pof_wait.py"

# start_ready <notify|PORT> <stderr file> <command...>: starts the command in the background (its
# stderr into the file) and returns once it is ready: READY=1 over sd_notify (`notify`: pof-daqd,
# pof-compensatord, pof record), or a UDP socket of its own bound on the LCM port PORT (lcm-logger,
# pof spy, clients). $! is its pid, a child of this shell: `wait $!` gives its exit status. Fails,
# with the end of its stderr, when it exits or is not ready within 20 s.
start_ready() {
  local how=$1 log=$2 fifo="$WORK_DIR/.ready.fifo" fd line
  shift 2
  rm -f "$fifo" && mkfifo "$fifo"
  exec {fd}<>"$fifo"   # read-write: opening does not wait for the writer
  if [ "$how" = notify ]; then how=(--notify); else how=(--listening "$how"); fi
  "$PY" "$POF_WAIT" start "${how[@]}" --report "$fifo" --stderr "$log" -- "$@" &
  read -r -t 30 -u "$fd" line || line="FAILED no word from pof_wait.py within 30 s"
  exec {fd}<&-
  rm -f "$fifo"
  [ "$line" = "READY $!" ] || fail "$(basename "$1"): ${line#FAILED }; its stderr: $(tail -n 20 "$log")"
}

# wait_until [--timeout S] <condition>: polls until the condition holds (pof_wait.py until:
# --drained PORT, --exited PID, --listening PORT PID..., or -- a command that exits 0).
wait_until() { "$PY" "$POF_WAIT" until "$@"; }

# caught_up --lcm-url URL [--sensor-id ID] (--blocks N | -- DAQ command...): returns once
# pof-compensatord's status shows it took N raw blocks (or every block the DAQ command published).
caught_up() {
  PYTHONPATH="$BIN_DIR/../python:$SOURCE_DIR/lcmtypes/python" "$PY" "$POF_WAIT" caught-up "$@"
}

# gap_protocol: the DAQ noise and calibration protocol (quasi-static steps up and down, four of
# table 1's velocities) of the `pof gap` sessions the e2e scripts simulate, as scenario TOML.
gap_protocol() {
  cat <<'TOML'
[daq.noise]
enabled = true
sensor_v = 0.001
reference_v = 0.001
pot_v = 0.001
[[trajectory]]
kind = "quasi_static"
step_deg = 15.0
descending = true
[[trajectory]]
kind = "cycles"
velocities_rad_s = [0.0898, 0.1726, 0.3415, 0.4304]
pause_s = 2.0
TOML
}
