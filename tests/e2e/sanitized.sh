# Runs one e2e script against the sanitizer build (tests/e2e/CMakeLists.txt uses it when POF_SANITIZE
# is set; `./pofkit sanitize-e2e` runs them all). Every process the script starts inherits
# ASAN_OPTIONS / UBSAN_OPTIONS that write each report into a directory of this test's own, and the
# test fails when any report appears: also from a process whose exit status the script does not look
# at (a listener stopped with SIGINT, a daemon in the background), and from leaks found at exit.
#   sanitized.sh SCRIPT        (environment as for the script: BIN_DIR, SOURCE_DIR, WORK_DIR)
# POF_SANITIZE_SKIP="reason" (pof_e2e_not_sanitized in CMakeLists.txt): skipped (77), saying why.
set -uo pipefail
script=$1
if [ -n "${POF_SANITIZE_SKIP:-}" ]; then
  echo "SKIP under the sanitizers: $POF_SANITIZE_SKIP"
  exit 77
fi
: "${WORK_DIR:?WORK_DIR is set by ctest}" "${SOURCE_DIR:?}"
reports="$WORK_DIR.sanitizer"  # beside WORK_DIR: lib.sh empties WORK_DIR itself
rm -rf "$reports" && mkdir -p "$reports"
# halt_on_error: the first finding ends the process (the build has -fno-sanitize-recover=all, so
# UBSan stops too). Options already in the environment come last and win.
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:log_path=$reports/asan:log_exe_name=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:log_path=$reports/ubsan:log_exe_name=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
# For the scripts: POF_SANITIZED says the binaries are sanitized (what ASan's costs change: a memory
# bound, an address-space limit); POF_ASAN_RUNTIME is the runtime they link, for a script that must
# preload it itself (daq_lib.sh, under umockdev).
export POF_SANITIZED=1
POF_ASAN_RUNTIME=$(ldd "${BIN_DIR:?}/pof" | awk '$1 ~ /^libasan/ { print $3 }')
export POF_ASAN_RUNTIME
bash "$script"
rc=$?
found=0
for f in "$reports"/*; do
  [ -e "$f" ] || continue
  found=1
  echo "=== sanitizer report: $f"
  cat "$f"
done
# Reports that went to a stderr the script kept in WORK_DIR (daq_lib.sh's umockdev runs).
while IFS= read -r f; do
  found=1
  echo "=== sanitizer report in $f"
  grep -E -A 30 "ERROR: (Address|Leak)Sanitizer|runtime error:" "$f" | head -n 80
done < <(grep -rlE "ERROR: (Address|Leak)Sanitizer|SUMMARY: UndefinedBehaviorSanitizer|: runtime error: " "$WORK_DIR" 2>/dev/null)
if [ "$found" -eq 1 ]; then
  echo "FAIL: sanitizer report(s) above (the script itself exited $rc)" >&2
  exit 1
fi
exit "$rc"
