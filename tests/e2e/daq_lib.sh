# Helpers for the pof-daqd end-to-end tests against the virtual USB DAQs (tests/virtual_usb).
# Each script: `source "$(dirname "$0")/daq_lib.sh"`.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

# Skip (77) only when umockdev is genuinely absent (docs/virtual-usb.md).
command -v umockdev-wrapper >/dev/null 2>&1 || { echo "SKIP: umockdev-wrapper not installed"; exit 77; }
[ -x "$BIN_DIR/pof-vdaq" ] || { echo "SKIP: pof-vdaq not built (libumockdev-dev absent)"; exit 77; }

# vdaq <pof-vdaq args...>: runs pof-daqd against the virtual device; fails the test when the
# checker fails. The JSON report is in $WORK_DIR/report.json.
vdaq() {
  if ! umockdev-wrapper "$BIN_DIR/pof-vdaq" --daemon "$BIN_DIR/pof-daqd" \
      --report "$WORK_DIR/report.json" "$@" >"$WORK_DIR/vdaq.out" 2>"$WORK_DIR/vdaq.err"; then
    cat "$WORK_DIR/vdaq.out" >&2
    tail -n 40 "$WORK_DIR/vdaq.err" >&2
    fail "pof-vdaq $*"
  fi
}

# report <python expression over r>: a value from the JSON report.
report() {
  /usr/bin/python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' \
    "$WORK_DIR/report.json" "$1"
}

# summary: one line with the figures of the run, for the test log.
summary() {
  report '"blocks=%d scans=%d rate=%.3f/%.3f Hz dropped=%d usb_errors=%d reconnects=%d ts_err_p99=%s us publish_age p50/p99=%s/%s us seam p50/max=%s/%s us cpu=%s%%" % (r["blocks"], r["scans_published"], r["measured_rate_hz"] or 0, r["published_rate_hz"], r["status"]["dropped_scans"], r["status"]["usb_errors"], r["status"]["reconnects"], r["timestamp_abs_error_us"]["p99"], r["scan_to_publish_us"]["p50"], r["scan_to_publish_us"]["p99"], r.get("seam_us",{}).get("p50"), r.get("seam_us",{}).get("max"), r.get("daemon_cpu_percent"))'
}
