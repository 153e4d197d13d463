#!/usr/bin/python3
"""Reads pof-vdaq's JSON report (tests/virtual_usb/vdaq.cpp) for the daq_*.sh tests.

  daq_report.py get REPORT KEY[.KEY...]   one value: a number, true/false, a string, or JSON
  daq_report.py summary REPORT            one line with the figures of the run, for the test log
  daq_report.py stream-intact REPORT      exit 0 when blocks arrived with continuous scan indices and
                                          pof-daqd stopped with 0 (replays of real captures, whose
                                          values are unknown)
"""
import json
import sys


def get(r, path):
    for key in path.split("."):
        if not isinstance(r, dict) or key not in r:
            sys.exit(f"daq_report.py: the report has no '{path}'")
        r = r[key]
    return r


def show(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (dict, list)):
        return json.dumps(v, ensure_ascii=False)
    return str(v)


def summary(r):
    s = r["status"]
    return (f"blocks={r['blocks']} scans={r['scans_published']} "
            f"rate={r['measured_rate_hz'] or 0:.3f}/{r['published_rate_hz']:.3f} Hz "
            f"dropped={s['dropped_scans']} usb_errors={s['usb_errors']} reconnects={s['reconnects']} "
            f"ts_err_p99={r['timestamp_abs_error_us']['p99']} us "
            f"publish_age p50/p99={r['scan_to_publish_us']['p50']}/{r['scan_to_publish_us']['p99']} us "
            f"seam p50/max={r.get('seam_us', {}).get('p50')}/{r.get('seam_us', {}).get('max')} us "
            f"cpu={r.get('daemon_cpu_percent')}%")


def main():
    if len(sys.argv) < 3 or sys.argv[1] not in ("get", "summary", "stream-intact"):
        sys.exit(__doc__)
    r = json.load(open(sys.argv[2]))
    if sys.argv[1] == "get":
        print(show(get(r, sys.argv[3])))
    elif sys.argv[1] == "summary":
        print(summary(r))
    else:
        ok = r["blocks"] > 0 and r["index_jumps_without_gap_flag"] == 0 and r["daemon_exit_code"] == 0
        sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
