# Helpers for the pof-daqd end-to-end tests against the virtual USB DAQs (tests/virtual_usb).
# Each script: `source "$(dirname "$0")/daq_lib.sh"`.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

# Skip (77) only when umockdev is genuinely absent (docs/virtual-usb.md).
command -v umockdev-wrapper >/dev/null 2>&1 || { echo "SKIP: umockdev-wrapper not installed"; exit 77; }
[ -x "$BIN_DIR/pof-vdaq" ] || { echo "SKIP: pof-vdaq not built (libumockdev-dev absent)"; exit 77; }

# umockdev_wrapper <command...>: umockdev-wrapper, which preloads libumockdev-preload. Against the
# sanitizer build (sanitized.sh sets POF_ASAN_RUNTIME) ASan refuses to start unless its runtime is
# first in the initial library list, so both are preloaded here, ASan first; reports go to stderr
# (an ASan log_path file cannot be opened under libumockdev-preload: SIGSEGV at start), where
# sanitized.sh looks for them in WORK_DIR.
umockdev_wrapper() {
  if [ -n "${POF_ASAN_RUNTIME:-}" ]; then
    ASAN_OPTIONS="$ASAN_OPTIONS:log_path=stderr" UBSAN_OPTIONS="$UBSAN_OPTIONS:log_path=stderr" \
      LD_PRELOAD="$POF_ASAN_RUNTIME:libumockdev-preload.so.0${LD_PRELOAD:+:$LD_PRELOAD}" "$@"
  else
    umockdev-wrapper "$@"
  fi
}

# vdaq <pof-vdaq args...>: runs pof-daqd against the virtual device; fails the test when the
# checker fails. The JSON report is in $WORK_DIR/report.json.
vdaq() {
  if ! umockdev_wrapper "$BIN_DIR/pof-vdaq" --daemon "$BIN_DIR/pof-daqd" \
      --report "$WORK_DIR/report.json" "$@" >"$WORK_DIR/vdaq.out" 2>"$WORK_DIR/vdaq.err"; then
    cat "$WORK_DIR/vdaq.out" >&2
    tail -n 40 "$WORK_DIR/vdaq.err" >&2
    fail "pof-vdaq $*"
  fi
}

# report <key[.key...]> [file]: a value from the JSON report (default $WORK_DIR/report.json), e.g.
# `report status.dropped_scans`; true/false for booleans, JSON for lists and objects.
report() { "$PY" "$SOURCE_DIR/tests/e2e/daq_report.py" get "${2:-$WORK_DIR/report.json}" "$1"; }

# summary [file]: one line with the figures of the run, for the test log.
summary() { "$PY" "$SOURCE_DIR/tests/e2e/daq_report.py" summary "${1:-$WORK_DIR/report.json}"; }

# at_most <number> <bound>: exit 0 when number <= bound (floating point).
at_most() { awk -v x="$1" -v b="$2" 'BEGIN { exit !(x + 0 <= b + 0) }'; }
