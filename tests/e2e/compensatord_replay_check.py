#!/usr/bin/python3
"""Checks of tests/e2e/compensatord_replay.sh on the files it leaves in its work directory (the
current directory): live.csv and stats.csv (what the daemon published, recorded), raw.csv (the
played session with its ground truth) and offline.csv (`pof compensate` of the same log).
"""
import csv
import math
import sys

import numpy as np


def check(ok, what):
    """Fails the test, saying what was wrong (asserts would vanish under python3 -O)."""
    if not ok:
        sys.exit(f"FAIL: {what}")


live = list(csv.DictReader(open("live.csv")))
raw = list(csv.DictReader(open("raw.csv")))
off = list(csv.DictReader(open("offline.csv")))
stats = list(csv.DictReader(open("stats.csv")))
n = len(raw)
check(len(live) == n, f"{len(live)} angles for {n} scans")
seqs = [int(r["seq"]) for r in live]
check(seqs == list(range(n)), "angle sequence numbers not continuous")
check([int(r["scan_index"]) for r in live] == [int(r["scan_index"]) for r in raw], "scan indices differ")
check(len(off) == n, f"pof compensate gave {len(off)} angles for {n} scans")
same = sum(1 for a, b in zip(live, off)
           if (math.isnan(float(a["angle_deg"])) and math.isnan(float(b["angle_deg"])))
           or np.float32(a["angle_deg"]) == np.float32(float(b["angle_deg"])))
check(same == n, f"live and offline differ on {n - same} of {n} scans")
err = np.array([float(a["angle_deg"]) - float(r["angle_true"]) for a, r in zip(live, raw)
                if int(a["quality"]) == 0])
rmse = float(np.sqrt(np.mean(err ** 2)))
print(f"{n} scans, {len(stats)} cycles, RMSE vs ground truth {rmse:.3f} deg over {err.size} clean scans")
check(len(stats) >= 1, "no cycle statistics")
check(rmse < 1.0, f"RMSE {rmse:.3f} deg")
