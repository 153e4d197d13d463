#!/usr/bin/python3
"""The fault soak's bus listener (tools/soak/soak.sh): one CSV line per POF_RAW or POF_ANGLE message
heard, and a progress file the soak waits on.

  soak_listen.py --lcm-url URL --channel CH --out CSV --progress FILE

CSV columns: receive time [us], seq, index (raw_block_t.first_scan or angle_t.scan_index), scans in
the message (n_scans, or 1 for an angle), flags (raw_block_t.flags or angle_t.quality), utime [us].
The progress file holds "<instance> <messages>": instance counts the publishers heard so far (a new
one each time seq restarts, i.e. does not exceed the previous seq: a restarted daemon counts from 0),
messages how many the current one published that we heard. It is replaced atomically (at most every
20 ms), so a reader never sees half a line. SIGTERM/SIGINT end the listener after a final flush.
"""
import argparse
import os
import signal
import sys
import time

import pofkit


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lcm-url", required=True)
    ap.add_argument("--channel", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--progress", required=True)
    a = ap.parse_args()
    # Raised from the handler: messages() does not return while other channels' traffic keeps its
    # socket busy, so a flag checked between messages could wait forever.
    class Stop(Exception):
        pass

    def on_signal(*_):
        raise Stop

    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, on_signal)

    instance, count, prev_seq, written = 0, 0, None, 0.0

    def progress():
        tmp = a.progress + ".tmp"
        with open(tmp, "w") as f:
            f.write(f"{instance} {count}\n")
        os.replace(tmp, a.progress)

    with pofkit.Subscriber([a.channel], url=a.lcm_url) as sub, open(a.out, "w") as out:
        out.write("recv_us,seq,index,n,flags,utime\n")
        try:
            while True:
                for _ch, recv, m in sub.messages(timeout_s=0.1):
                    if hasattr(m, "first_scan"):
                        index, n, flags = m.first_scan, m.n_scans, m.flags
                    else:
                        index, n, flags = m.scan_index, 1, m.quality
                    if prev_seq is None or m.seq <= prev_seq:
                        instance, count = instance + 1, 0
                    prev_seq = m.seq
                    count += 1
                    out.write(f"{recv},{m.seq},{index},{n},{flags},{m.utime}\n")
                    if time.monotonic() - written > 0.02:
                        out.flush()
                        progress()
                        written = time.monotonic()
                progress()
        except Stop:
            pass
        out.flush()
        progress()
    print(f"soak_listen.py: {a.channel}: {instance} publisher instance(s) heard; bus stats {sub.stats}",
          file=sys.stderr)


if __name__ == "__main__":
    main()
