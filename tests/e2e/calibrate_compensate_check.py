#!/usr/bin/python3
"""Checks of tests/e2e/calibrate_compensate.sh on the JSON that `pof calibrate --report` and
`pof compensate --json` write.

  calibrate_compensate_check.py calibration REPORT/calibration.json   the figures of the report
  calibrate_compensate_check.py stats STATS.json                      table 3 per cycle and overall
  calibrate_compensate_check.py has-overall FILE                      FILE is JSON with "overall"
  calibrate_compensate_check.py lower A.json B.json                   A's overall RMSE below B's
"""
import json
import sys


def check(ok, what):
    """Fails the test, saying what was wrong (asserts would vanish under python3 -O)."""
    if not ok:
        sys.exit(f"FAIL: {what}")


def calibration(path):
    r = json.load(open(path))
    check(len(r["velocity_tests"]) == 9, len(r["velocity_tests"]))
    for k in ("quasi_static", "f1", "f2", "f4", "combined", "range", "segments", "self_check", "active_model", "dynamic"):
        check(k in r, k)
    h = r["dynamic"]["held_out"]
    check(h["paper"]["rmse_deg"] > 0 and h["dynamic"]["rmse_deg"] > 0 and h["folds_used"] >= 3, h)
    check(r["f1"]["c1_se"] > 0 and len(r["f1"]["residuals_pct"]) == 9, 'r["f1"]["c1_se"] > 0 and len(r["f1"]["residuals_pct"]) == 9')
    check(abs(r["quasi_static"]["sensitivity_v_per_deg"] - 0.022) < 0.001, 'abs(r["quasi_static"]["sensitivity_v_per_deg"] - 0.022) < 0.001')


def stats(path):
    s = json.load(open(path))
    keys = ["velocity_rad_s", "rmse_comp_deg", "rmse_uncomp_deg", "hysteresis_comp_pct", "hysteresis_uncomp_pct", "max_error_deg"]
    check(len(s["cycles"]) == 15, len(s["cycles"]))
    for c in s["cycles"]:
        for k in ["cycle"] + keys:
            check(k in c, k)
    for k in keys:
        check(k in s["overall"], k)
    o = s["overall"]
    check(o["rmse_comp_deg"] < o["rmse_uncomp_deg"], o)
    check(o["hysteresis_comp_pct"] < 0.5 * o["hysteresis_uncomp_pct"], o)


def has_overall(path):
    json.load(open(path))["overall"]


def lower(path_a, path_b):
    a, b = (json.load(open(p))["overall"]["rmse_comp_deg"] for p in (path_a, path_b))
    print(f"overall RMSE {a:.3f} deg ({path_a}) vs {b:.3f} deg ({path_b})")
    check(a < b, f"{a} !< {b}")


def main():
    checks = {"calibration": (calibration, 1), "stats": (stats, 1), "has-overall": (has_overall, 1), "lower": (lower, 2)}
    if len(sys.argv) < 2 or sys.argv[1] not in checks or len(sys.argv) != 2 + checks[sys.argv[1]][1]:
        sys.exit(__doc__)
    checks[sys.argv[1]][0](*sys.argv[2:])


if __name__ == "__main__":
    main()
