#!/usr/bin/python3
"""Checks of tests/e2e/two_pipelines.sh on the files it leaves in its work directory (the current
directory): raw-<ID>.csv and angle-<ID>.csv, `pof export` of each sensor's POF_RAW and POF_ANGLE.
Each angle stream has one angle per scan of its own sensor, with that sensor's own reference.
"""
import csv
import sys


def check(ok, what):
    """Fails the test, saying what was wrong (asserts would vanish under python3 -O)."""
    if not ok:
        sys.exit(f"FAIL: {what}")


for sid in ("LEFT_KNEE", "RIGHT_KNEE"):
    raw = list(csv.DictReader(open(f"raw-{sid}.csv")))
    ang = list(csv.DictReader(open(f"angle-{sid}.csv")))
    check(len(raw) > 1000, f"{sid}: only {len(raw)} scans")
    check(len(ang) == len(raw), f"{sid}: {len(ang)} angles for {len(raw)} scans")
    check([a["scan_index"] for a in ang] == [r["scan_index"] for r in raw], f"{sid}: scan indices differ")
    # The reference angle in each angle stream is that sensor's own potentiometer.
    worst = max(abs(float(a["angle_ref_deg"]) - 22.5 * (float(r["pot"]) - 0.5)) for a, r in zip(ang, raw))
    check(worst < 1e-3, f"{sid}: reference differs from its own pot by {worst} deg")
    print(f"{sid}: {len(ang)} angles for {len(raw)} scans, own reference (max diff {worst:.2e} deg)")
