#!/usr/bin/python3
"""LCM log events by their headers alone (lcm/eventlog.c: u32 sync 0xEDA1DA01, i64 event number,
i64 timestamp, u32 channel length, u32 data length, channel, data), independent of pofkit's readers.

  lcmlog_events.py offset LOG N        the byte offset of event N (0-based): damaged_inputs.sh
                                       damages a log at an event it names this way
  lcmlog_events.py count LOG CHANNEL   the number of events; exit 1 when one has a bad sync word or
                                       another channel (sim_cli.sh: what lcm-logplayer replayed)
"""
import struct
import sys

SYNC = 0xEDA1DA01
HEADER = struct.Struct(">IqqII")


def offset(d, n):
    off = 0
    for _ in range(n):
        _, _, _, cl, dl = HEADER.unpack_from(d, off)
        off += HEADER.size + cl + dl
    return off


def count(d, channel):
    off = n = 0
    while off < len(d):
        sync, _, _, cl, dl = HEADER.unpack_from(d, off)
        got = d[off + HEADER.size:off + HEADER.size + cl]
        if sync != SYNC or got != channel:
            sys.exit(f"event {n} at byte {off}: sync {sync:#x}, channel {got!r}")
        off += HEADER.size + cl + dl
        n += 1
    return n


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in ("offset", "count"):
        sys.exit(__doc__)
    d = open(sys.argv[2], "rb").read()
    print(offset(d, int(sys.argv[3])) if sys.argv[1] == "offset" else count(d, sys.argv[3].encode()))


if __name__ == "__main__":
    main()
