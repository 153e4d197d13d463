#!/usr/bin/python3
"""Checks of tests/e2e/gap_cli.sh on `pof gap`'s gap.json for a session with hidden creep (tau 4 s):
the keys, creep found first with its time constant, and the gap at least halved by the model.

  gap_cli_check.py REPORT/gap.json
"""
import json
import sys


def check(ok, what):
    """Fails the test, saying what was wrong (asserts would vanish under python3 -O)."""
    if not ok:
        sys.exit(f"FAIL: {what}")


def main():
    j = json.load(open(sys.argv[1]))
    for k in ("baseline_gap_deg", "steps", "final_gap_deg", "unexplained"):
        check(k in j, f"no '{k}'")
    s = j["steps"][0]
    check(s["effect"] == "creep", f"first step: {s['effect']}")
    for k in ("effect", "gap_deg", "where", "parameters", "evidence"):
        check(k in s, f"first step has no '{k}'")
    check(abs(s["parameters"]["tau_s"] - 4.0) < 1.5, f"creep parameters {s['parameters']}")
    check(j["final_gap_deg"] <= 0.5 * j["baseline_gap_deg"],
          f"gap {j['baseline_gap_deg']} -> {j['final_gap_deg']} deg, not halved")


if __name__ == "__main__":
    main()
