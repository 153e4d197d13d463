#!/usr/bin/python3
"""Checks of a `pof record` manifest (<log>.manifest.json, tools/recorder/src/session.cpp) for
tests/e2e/record_lossless.sh and record_crash.sh.

  record_manifest_check.py lossless MANIFEST N   every one of N messages received and written,
                                                 none dropped (hand-off or kernel)
  record_manifest_check.py killed MANIFEST       after SIGKILL: still `recording`, the attached
                                                 calibration listed, the rotated files named
  record_manifest_check.py rotated MANIFEST      a time-rotated session stopped cleanly: >= 3
                                                 files, every event written, POF_ANGLE_RIGHT_KNEE
                                                 without sequence gaps
  record_manifest_check.py hostile MANIFEST M    after compensatord_hostile.sh's traffic: stopped
                                                 cleanly, at least M malformed datagrams and one
                                                 abandoned fragmented message counted
  record_manifest_check.py failed MANIFEST LOG   the first event could not be written: `failed`,
                                                 the reason naming LOG, no file listed, nothing
                                                 written
  record_manifest_check.py full MANIFEST         writing stopped on a full disk: every message
                                                 received is written or counted as not written,
                                                 with the reason; the files hold what is counted
"""
import json
import sys


def check(ok, what):
    if not ok:
        sys.exit(f"{sys.argv[2]}: {what}")


def lossless(m, n):
    c = m["counters"]
    print("manifest counters:", c)
    check(c["received"] == n and c["written"] == n, f"received/written {c['received']}/{c['written']}, sent {n}")
    check(c["dropped_handoff"] == 0 and c["udp_kernel_drops"] == 0, f"drops: {c}")


def killed(m):
    check(m["status"] == "recording", f"status {m['status']} (killed: it never reached 'stopped')")
    check(m["attachments"][0]["copy"] == "run.files/cal.toml", f"attachments {m['attachments']}")
    check(m["versions"]["lcm"] == "1.3.1", f"versions {m['versions']}")
    check(len(m["files"]) >= 2 and m["files"][0]["name"] == "run.0000.lcmlog", f"files {m['files']}")


def rotated(m):
    check(m["status"] == "stopped", f"status {m['status']}")
    check(len(m["files"]) >= 3, f"{len(m['files'])} files")
    events = sum(f["events"] for f in m["files"])
    ch = m["channels"]["POF_ANGLE_RIGHT_KNEE"]
    check(ch["type"] == "angle_t" and ch["seq"]["gaps"] == 0, f"POF_ANGLE_RIGHT_KNEE {ch}")
    c = m["counters"]
    check(c["written"] == events == c["received"], f"counters {c}, {events} events in the files")


def hostile(m, min_malformed):
    print("manifest counters:", m["counters"])
    check(m["status"] == "stopped", f"status {m['status']}")
    c = m["counters"]
    check(c["malformed_datagrams"] >= min_malformed, f"malformed_datagrams {c['malformed_datagrams']} < {min_malformed}")
    check(c["incomplete_messages"] >= 1, f"incomplete_messages {c['incomplete_messages']}: the evicted 16 MiB messages")
    check(c["written"] == c["received"] > 0, f"counters {c}")


def failed(m, log):
    print("manifest status:", m["status"], "error:", m.get("error"))
    check(m["status"] == "failed", f"status {m['status']} (the first event was never written)")
    check(log in m.get("error", ""), f"error {m.get('error')!r} does not name {log}")
    check(m["files"] == [], f"files {m['files']}: the empty log is listed")
    check(m["counters"]["written"] == 0, f"counters {m['counters']}")


def full(m):
    c = m["counters"]
    silent = c["received"] - c["written"] - c["dropped_handoff"] - c.get("not_written", 0)
    print(f"manifest counters: received {c['received']}, written {c['written']}, dropped {c['dropped_handoff']}, "
          f"not written {c.get('not_written')} ({c.get('not_written_reason')}), in no counter {silent}")
    check(m["status"] == "disk_full", f"status {m['status']}")
    check(silent == 0, f"{silent} messages in no counter: {c}")
    check(c.get("not_written", 0) > 0 and "No space left" in c.get("not_written_reason", ""), f"counters {c}")
    events = sum(f["events"] for f in m["files"])
    check(events == c["written"], f"{events} events listed in the files, {c['written']} written")


def main():
    if len(sys.argv) < 3 or sys.argv[1] not in ("lossless", "killed", "rotated", "hostile", "failed", "full"):
        sys.exit(__doc__)
    m = json.load(open(sys.argv[2]))
    if sys.argv[1] == "lossless":
        lossless(m, int(sys.argv[3]))
    elif sys.argv[1] == "killed":
        killed(m)
    elif sys.argv[1] == "hostile":
        hostile(m, int(sys.argv[3]))
    elif sys.argv[1] == "failed":
        failed(m, sys.argv[3])
    elif sys.argv[1] == "full":
        full(m)
    else:
        rotated(m)


if __name__ == "__main__":
    main()
