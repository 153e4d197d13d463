#!/usr/bin/python3
"""Checks of tests/e2e/compensatord_hostile.sh on what pof-compensatord published during the
hostile traffic (SEEN: `lcm_hostile.py listen`'s JSON) and its peak RSS.

  compensatord_hostile_check.py SEEN.json PEAK_RSS_KB [MAX_PEAK_KB]   (bound: 64 MiB unless given)
"""
import json
import sys


def check(ok, what):
    """Fails the test, saying what was wrong (asserts would vanish under python3 -O)."""
    if not ok:
        sys.exit(f"FAIL: {what}")


seen = json.load(open(sys.argv[1]))
st, idx = seen["status"], seen["indices"]
check(st is not None, f"no POF_COMPENSATOR_STATUS received ({seen['statuses']} statuses)")
print("status:", st)
print(f"{len(idx)} angles")
missing = set(range(1050)) - set(idx)
check(not missing, f"{len(missing)} good scans without an angle, e.g. {sorted(missing)[:5]}")
check(not [i for i in idx if 500_000_000 <= i < 500_000_010], "the unicast block was received")
check(len(idx) == 1080, f"{len(idx)} angles for 1080 good scans (a block published twice?)")
check(st["scans"] == 1080 and st["angles"] == 1080, st)
check(st["blocks"] == 110, st)  # 3 + 100 + 2 duplicates + 5
check(st["decode_errors"] == 8, st)
check(st["duplicate_blocks"] == 2, st)
check(st["malformed_datagrams"] >= 1002 + 96, st)  # garbage + 2 fragments + the horde evicted
check(st["lost_blocks"] >= 0 and st["lost_scans"] >= 0, st)
check(st["rejected_blocks"] == 0, st)
check(st["publish_failures"] == 0, st)  # hostile input costs nothing on the way out
peak_kb = int(sys.argv[2])
max_kb = int(sys.argv[3]) if len(sys.argv) > 3 else 64 * 1024
check(peak_kb < max_kb, f"peak RSS {peak_kb} kB (bound {max_kb} kB)")  # was 1.18 GB on one decode bomb
