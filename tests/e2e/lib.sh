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
