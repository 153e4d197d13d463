#!/usr/bin/python3
"""A stalled acquisition thread, seen from outside pof-daqd (docs/daq.md, "Watchdog and stalls").

Runs pof-daqd on sim:synthetic and stalls its acquisition thread once, either with POF_SIM_STALL
(--how hook: the sim backend's hook blocks the thread, then hands over the scans of that time at
once) or from outside (--how ptrace: this script stops that one thread with PTRACE_INTERRUPT and
lets it go after the stall, the others running on, as a debugger or a blocked read would), under
a notify socket of its own
(sd_notify(3): WATCHDOG_USEC set, as systemd's WatchdogSec= does), reads POF_RAW and
POF_DAQ_STATUS, and checks that
  - WATCHDOG=1 stops during the stall (none from the watchdog grace on until the scans come back),
    and comes again after it;
  - the published state leaves `streaming` within the stall bound (a `fault` "acquisition stalled")
    and no `streaming` status is published while the stall lasts; `streaming` again after it;
  - the blocks handed over after the stall carry FLAG_LATE, none before it does, and the scan
    indices stay continuous (no FLAG_GAP: nothing was lost, it is old).
Prints one summary line; exits 1 naming every failed check.

  daq_sim_stall_check.py --daqd BIN --url URL [--how hook|ptrace] --stall AT:FOR --stall-ms MS --grace-ms MS -- ARGS...
Exit 77 when --how ptrace is not permitted here.
"""
import argparse
import ctypes
import os
import socket
import subprocess
import sys
import threading
import time

import pofkit

FLAG_GAP, FLAG_LATE = 2, 32
STATE_STREAMING, STATE_FAULT, STATE_STOPPING = 1, 3, 4


def ptrace_stall(pid, at_s, for_s, result):
    """Stops the acquisition thread of pid (the sim backend's one sleeps in clock_nanosleep between
    chunks; the publisher waits on a futex, main in rt_sigtimedwait) for for_s seconds, at_s seconds
    from now. PTRACE_SEIZE + PTRACE_INTERRUPT stop that thread only; PTRACE_DETACH lets it go."""
    libc = ctypes.CDLL(None, use_errno=True)
    libc.ptrace.argtypes = [ctypes.c_long, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]
    libc.ptrace.restype = ctypes.c_long
    seize, interrupt, detach, wall = 0x4206, 0x4207, 17, 0x40000000
    time.sleep(at_s)
    target, deadline = None, time.monotonic() + 2
    while target is None and time.monotonic() < deadline:
        for tid in os.listdir(f"/proc/{pid}/task"):
            try:
                with open(f"/proc/{pid}/task/{tid}/syscall") as f:
                    if f.read().split()[0] == "230":  # clock_nanosleep (x86-64)
                        target = int(tid)
            except (OSError, IndexError):
                pass
        time.sleep(0.005)
    if target is None or libc.ptrace(seize, target, None, None) != 0:
        result["error"] = f"cannot seize the acquisition thread ({target}): errno {ctypes.get_errno()}"
        return
    libc.ptrace(interrupt, target, None, None)
    os.waitpid(target, wall)
    time.sleep(for_s)
    libc.ptrace(detach, target, None, None)
    result["stalled"] = target


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--daqd", required=True)
    ap.add_argument("--url", required=True)
    ap.add_argument("--how", choices=["hook", "ptrace"], default="hook")
    ap.add_argument("--stall", required=True, help="at_s:for_s")
    ap.add_argument("--stall-ms", type=float, required=True, help="the stall bound the daemon uses")
    ap.add_argument("--grace-ms", type=float, required=True, help="the watchdog grace the daemon uses")
    ap.add_argument("--watchdog-usec", type=int, default=1000000)
    ap.add_argument("args", nargs=argparse.REMAINDER)
    a = ap.parse_args()
    args = a.args[1:] if a.args and a.args[0] == "--" else a.args
    stall_at, stall_for = (float(x) for x in a.stall.split(":"))

    notify = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    name = f"pof-stall-{os.getpid()}-{time.monotonic_ns()}"
    notify.bind("\0" + name)
    notify.settimeout(0.1)
    watchdogs = []  # receive times [s, CLOCK_REALTIME] of WATCHDOG=1
    done = threading.Event()

    def read_notify():
        while not done.is_set():
            try:
                m = notify.recv(4096).decode(errors="replace")
            except socket.timeout:
                continue
            if "WATCHDOG=1" in m.split("\n"):
                watchdogs.append(time.time())

    reader = threading.Thread(target=read_notify, daemon=True)
    reader.start()
    env = dict(os.environ, NOTIFY_SOCKET="@" + name, WATCHDOG_USEC=str(a.watchdog_usec))
    env.pop("WATCHDOG_PID", None)
    env.pop("POF_SIM_STALL", None)
    if a.how == "hook":
        env["POF_SIM_STALL"] = a.stall
    traced = {}
    blocks, statuses = [], []  # (receive time [s], message)
    with pofkit.Subscriber(["POF_RAW", "POF_DAQ_STATUS"], url=a.url) as sub:
        p = subprocess.Popen([a.daqd, "--lcm-url", a.url, *args], env=env)
        if a.how == "ptrace":
            tracer = threading.Thread(target=ptrace_stall, args=(p.pid, stall_at, stall_for, traced), daemon=True)
            tracer.start()
        while p.poll() is None:
            for channel, recv_us, m in sub.messages(timeout_s=0.2):
                (blocks if channel == "POF_RAW" else statuses).append((recv_us / 1e6, m))
                if p.poll() is not None:
                    break
        for channel, recv_us, m in sub.messages(timeout_s=0.3):
            (blocks if channel == "POF_RAW" else statuses).append((recv_us / 1e6, m))
    time.sleep(0.2)
    done.set()
    reader.join()

    if a.how == "ptrace" and "stalled" not in traced:
        print(f"SKIP: {traced.get('error', 'the ptrace stall did not happen')}")
        sys.exit(77)
    failures = []
    if p.returncode != 0:
        failures.append(f"pof-daqd exited {p.returncode}")
    if len(blocks) < 20:
        sys.exit(f"FAIL: only {len(blocks)} raw blocks heard")
    # The stall as the bus saw it: the longest silence between two raw blocks.
    i = max(range(1, len(blocks)), key=lambda k: blocks[k][0] - blocks[k - 1][0])
    gap_start, gap_end = blocks[i - 1][0], blocks[i][0]
    silence = gap_end - gap_start
    if silence < 0.8 * stall_for:
        failures.append(f"no stall seen: the longest silence between raw blocks is {silence:.2f} s")
    stall_s, grace_s = a.stall_ms / 1e3, a.grace_ms / 1e3

    # Raw blocks: late after the stall, never before it; continuous either way.
    late_before = sum(1 for _, b in blocks[:i] if b.flags & FLAG_LATE)
    late_after = [b for _, b in blocks[i:] if b.flags & FLAG_LATE]
    if late_before:
        failures.append(f"{late_before} blocks flagged FLAG_LATE before the stall")
    if not blocks[i][1].flags & FLAG_LATE:
        failures.append(f"the first block after the stall is not flagged FLAG_LATE (flags {blocks[i][1].flags})")
    # The scans taken during the stall, less those within the bound: ~ (stall - bound) x block rate.
    block_s = blocks[1][1].n_scans / blocks[1][1].scan_rate_hz
    want_late = int(0.8 * (stall_for - stall_s) / block_s)
    if len(late_after) < want_late:
        failures.append(f"{len(late_after)} blocks flagged FLAG_LATE after the stall, expected >= {want_late}")
    for _, b in blocks[i:]:
        if b.flags & FLAG_LATE and b.publish_utime - b.utime <= a.stall_ms * 1000:
            failures.append(f"block {b.seq} flagged late though {(b.publish_utime - b.utime) / 1e3:.0f} ms old")
            break
    gaps = sum(1 for _, b in blocks if b.flags & FLAG_GAP)
    jumps = sum(1 for k in range(1, len(blocks))
                if blocks[k][1].first_scan != blocks[k - 1][1].first_scan + blocks[k - 1][1].n_scans)
    if gaps or jumps:
        failures.append(f"{gaps} FLAG_GAP blocks, {jumps} index jumps: the stall lost no scan")

    # Status: leaves streaming within the bound, never streaming during the stall, back after.
    stalled = [(t, s) for t, s in statuses if s.state == STATE_FAULT and "acquisition stalled" in s.state_text]
    if not stalled:
        failures.append("no 'acquisition stalled' fault published: " +
                        "; ".join(sorted({f"{s.state}: {s.state_text}" for _, s in statuses})))
    else:
        t0 = stalled[0][0] - gap_start
        if t0 > stall_s + 1.0:
            failures.append(f"'acquisition stalled' published {t0:.2f} s after the last block (bound {stall_s:.2f} s)")
    streaming_during = [t for t, s in statuses if s.state == STATE_STREAMING and gap_start + stall_s + 0.3 < t < gap_end]
    if streaming_during:
        failures.append(f"{len(streaming_during)} 'streaming' statuses published during the stall")
    if not any(s.state == STATE_STREAMING and t > gap_end for t, s in statuses):
        failures.append("no 'streaming' status after the stall")

    # The watchdog: fed before, not from the grace on during the stall, fed again after.
    before = [t for t in watchdogs if t < gap_start]
    during = [t for t in watchdogs if gap_start + grace_s + 0.3 < t < gap_end - 0.05]
    after = [t for t in watchdogs if t > gap_end]
    if len(before) < 2:
        failures.append(f"{len(before)} WATCHDOG=1 before the stall, expected several")
    if during:
        failures.append(f"{len(during)} WATCHDOG=1 during the stall (from {grace_s + 0.3:.1f} s after the last "
                        f"block to the first after it, {silence:.2f} s later)")
    if not after:
        failures.append("no WATCHDOG=1 after the stall")
    ws = sorted(watchdogs)
    longest = max((b - a_ for a_, b in zip(ws, ws[1:])), default=0.0)

    print(f"blocks {len(blocks)}, silence {silence:.2f} s, late after it {len(late_after)} (before {late_before}), "
          f"stalled status after {(stalled[0][0] - gap_start) if stalled else float('nan'):.2f} s, "
          f"WATCHDOG=1 before/during/after {len(before)}/{len(during)}/{len(after)}, longest pause {longest:.2f} s, "
          f"exit {p.returncode}")
    if failures:
        for f in failures:
            print("FAIL:", f, file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
