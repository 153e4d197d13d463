#!/usr/bin/python3
"""pof-angle-client in Python: what a controller does with pofkit's output (see
examples/cpp_client/angle_client.cpp for the same in C++).

Subscribes to POF_ANGLE[_<SENSOR_ID>], checks sequence gaps (angles lost on the bus), reads the
quality flags (QUALITY_INVALID_INPUT: the angle is NaN, do not use it) and measures the sample age
(receive time minus angle_t.utime, the host time of the scan). Exits 0 once --count angles arrived.

Needs the pofkit Python package and lcm-gen's `pof` classes on the path: installed, they are in
<prefix>/lib/python3/dist-packages (on a .deb install that is already on Python's path).
"""
import argparse
import math
import sys

import numpy as np

import pofkit


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lcm-url", default=None, help="LCM URL (default: $LCM_DEFAULT_URL, else udpm on this host)")
    ap.add_argument("--sensor-id", default="", help="sensor id suffixing the channel, e.g. LEFT_KNEE")
    ap.add_argument("--count", type=int, default=200, help="angles to receive before exiting")
    ap.add_argument("--timeout", type=float, default=30, help="give up after this many seconds of silence")
    a = ap.parse_args()

    channel = "POF_ANGLE" + ("_" + a.sensor_id if a.sensor_id else "")
    n = lost = unusable = flagged = 0
    last_seq, ages_ms = -1, []
    with pofkit.Subscriber([channel], url=a.lcm_url) as sub:
        print(f"listening on {channel} ({sub.url})", flush=True)
        for _, recv_utime, m in sub.messages(timeout_s=a.timeout):
            if last_seq >= 0 and m.seq > last_seq + 1:
                lost += m.seq - last_seq - 1
            last_seq = m.seq
            n += 1
            if m.quality & m.QUALITY_INVALID_INPUT or not math.isfinite(m.angle_deg):
                unusable += 1
            elif m.quality:
                flagged += 1
            ages_ms.append((recv_utime - m.utime) / 1000.0)
            if n >= a.count:
                break
        undecodable = sub.stats["undecodable"] + sub.stats["malformed"]
    age = np.array(ages_ms) if ages_ms else np.array([math.nan])
    print(f"summary: angles={n} lost={lost} undecodable={undecodable} unusable={unusable} flagged={flagged} "
          f"age_p50_ms={np.percentile(age, 50):.3f} age_p99_ms={np.percentile(age, 99):.3f} age_max_ms={age.max():.3f}")
    return 0 if n >= a.count else 1


if __name__ == "__main__":
    sys.exit(main())
