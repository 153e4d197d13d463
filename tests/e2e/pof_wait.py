#!/usr/bin/python3
"""Readiness and conditions for the end-to-end tests: the tests wait on what a process says or does,
never for a fixed time.

  pof_wait.py start (--notify | --listening PORT) --report FIFO [--stderr FILE] [--timeout S] -- CMD...
      Runs CMD in this very process (exec), so it keeps the pid the shell gave it (`wait` returns its
      exit status, `kill` reaches it), after forking a watcher that writes one line to FIFO:
      "READY <pid>" once CMD is ready, or "FAILED <why>" when CMD exits or TIMEOUT passes first (CMD
      is then terminated). Ready is, with --notify, READY=1 on the sd_notify socket named by
      $NOTIFY_SOCKET (pof-daqd, pof-compensatord and pof record send it: pof/service/sd_notify.hpp, the
      protocol of sd_notify(3)); with --listening, a UDP socket of CMD bound on PORT (lcm-logger,
      pof spy, clients: anything that subscribes to LCM without sd_notify).
  pof_wait.py notify-log [--watchdog-usec N] -- CMD...
      Runs CMD under a notify socket and prints its exit code, then every message it sent with the
      time since start (the service tests check READY=1, WATCHDOG=1, STATUS=, STOPPING=1).
  pof_wait.py until [--timeout S] (--drained PORT | --exited PID | --listening PORT PID... | -- CMD...)
      Polls (every 50 ms) until every UDP socket bound on PORT has read all its queued datagrams,
      PID has exited, each PID has a UDP socket bound on PORT, or CMD exits 0; exit 1 naming the
      condition when TIMEOUT passes first.
  pof_wait.py sockets PORT PID
      Prints how many UDP sockets PID has bound on PORT.
  pof_wait.py caught-up --lcm-url URL [--sensor-id ID] [--timeout S] (--blocks N | -- DAQ-CMD...)
      Waits until pof-compensatord's POF_COMPENSATOR_STATUS[_ID] shows that it took N raw blocks,
      or every block the DAQ command published: DAQ-CMD runs here once this process listens, and its
      last POF_DAQ_STATUS[_ID] (blocks published) is read once it exited. Needs the pofkit package
      and lcm-gen's `pof` classes on PYTHONPATH.

The tests use it through tests/e2e/lib.sh (start_ready, wait_until, caught_up); the Python tests
import it (wait_until, udp_sockets).
"""
import argparse
import os
import select
import signal
import socket
import subprocess
import sys
import time

POLL_S = 0.05


def wait_until(condition, timeout_s, poll_s=POLL_S):
    """True once condition() is true, False when timeout_s passed first (the one polling loop)."""
    deadline = time.monotonic() + timeout_s
    while True:
        if condition():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(poll_s)


def _socket_inodes(pid):
    """Socket inodes held by pid (fd -> socket:[inode]); empty when pid is gone."""
    inodes = set()
    fd_dir = f"/proc/{pid}/fd"
    try:
        fds = os.listdir(fd_dir)
    except OSError:
        return inodes
    for fd in fds:
        try:
            target = os.readlink(os.path.join(fd_dir, fd))
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    return inodes


def udp_sockets(port):
    """The IPv4 UDP sockets bound on port: (inode, receive queue [bytes], drops), from /proc/net/udp
    (proc(5): local_address ip:port, tx_queue:rx_queue, ..., inode at column 10, drops at 13)."""
    out = []
    with open("/proc/net/udp") as f:
        next(f)
        for line in f:
            c = line.split()
            if int(c[1].rsplit(":", 1)[1], 16) == port:
                out.append((c[9], int(c[4].split(":")[1], 16), int(c[12])))
    return out


def sockets_of(pid, port):
    """How many UDP sockets bound on port pid holds."""
    mine = _socket_inodes(pid)
    return sum(1 for inode, _, _ in udp_sockets(port) if inode in mine)


def drained(port):
    """Every socket bound on port has read what the kernel queued for it (and there is one)."""
    socks = udp_sockets(port)
    return bool(socks) and all(rx == 0 for _, rx, _ in socks)


def exited(pid):
    """pid has exited (gone, or a zombie its parent has not reaped yet)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] in ("Z", "X")
    except OSError:
        return True


def _bind_notify_socket():
    """An abstract unix datagram socket (no file to clean up; sd_notify(3) takes '@' for it)."""
    s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    name = f"pof-wait-{os.getpid()}-{time.monotonic_ns()}"
    s.bind("\0" + name)
    return s, "@" + name


def cmd_start(a):
    if not a.command:
        sys.exit("pof_wait.py start: no command after --")
    sock = None
    env = dict(os.environ)
    if a.notify:
        sock, env["NOTIFY_SOCKET"] = _bind_notify_socket()
    me = os.getpid()
    pidfd = os.pidfd_open(me)  # readable once this process (soon CMD) exits; close-on-exec
    child = os.fork()
    if child == 0:
        if os.fork() != 0:
            os._exit(0)  # the watcher is a grandchild: nobody has to reap it
        os._exit(_watch(a, me, pidfd, sock))
    os.waitpid(child, 0)
    if sock is not None:
        sock.close()
    if a.stderr:
        fd = os.open(a.stderr, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(fd, 2)
        os.close(fd)
    try:
        os.execvpe(a.command[0], a.command, env)
    except OSError as e:
        print(f"pof_wait.py: cannot run {a.command[0]}: {e}", file=sys.stderr)
        os._exit(127)


def _watch(a, pid, pidfd, sock):
    """The watcher: tell the shell through the FIFO whether pid became ready."""
    def report(line):
        try:  # non-blocking: a shell that gave up reading must not leave us hanging in open()
            fd = os.open(a.report, os.O_WRONLY | os.O_NONBLOCK)
        except OSError:
            return
        os.write(fd, (line + "\n").encode())
        os.close(fd)

    devnull = os.open(os.devnull, os.O_RDWR)
    os.dup2(devnull, 0)
    os.dup2(devnull, 1)  # the shell may read CMD's stdout through a pipe: do not hold it open

    what = "READY=1" if a.notify else f"UDP socket on port {a.listening}"
    gone = lambda: bool(select.select([pidfd], [], [], 0)[0])  # noqa: E731
    if a.notify:
        ready, deadline = False, time.monotonic() + a.timeout
        while not ready and time.monotonic() < deadline:
            readable, _, _ = select.select([sock, pidfd], [], [], max(0.0, deadline - time.monotonic()))
            if sock in readable:
                ready = "READY=1" in sock.recv(4096).decode(errors="replace").split("\n")
            elif readable:
                break
    else:
        wait_until(lambda: sockets_of(pid, a.listening) > 0 or gone(), a.timeout)
        ready = sockets_of(pid, a.listening) > 0
    if ready:
        report(f"READY {pid}")
        return 0
    if gone():
        report(f"FAILED exited before {what}")
    else:
        os.kill(pid, signal.SIGTERM)
        report(f"FAILED no {what} within {a.timeout:g} s (terminated it)")
    return 1


def cmd_notify_log(a):
    sock, name = _bind_notify_socket()
    sock.settimeout(0.2)
    env = dict(os.environ, NOTIFY_SOCKET=name, WATCHDOG_USEC=str(a.watchdog_usec))
    p = subprocess.Popen(a.command, env=env)
    msgs = []
    t0 = time.monotonic()
    while p.poll() is None:
        try:
            msgs.append((time.monotonic() - t0, sock.recv(4096).decode()))
        except socket.timeout:
            pass
    # Drain: the last datagrams (STOPPING=1 right before exit) are still queued when the process is
    # seen gone; the kernel queued them before the exit, so a non-blocking read finds them all.
    sock.setblocking(False)
    while True:
        try:
            msgs.append((time.monotonic() - t0, sock.recv(4096).decode()))
        except BlockingIOError:
            break
    print(p.returncode)
    for t, m in msgs:
        print(f"{t:.2f}", m.replace("\n", " ; "))


def cmd_until(a):
    if a.drained is not None:
        cond, what = (lambda: drained(a.drained)), f"the UDP sockets on port {a.drained} drained"
    elif a.exited is not None:
        cond, what = (lambda: exited(a.exited)), f"process {a.exited} exited"
    elif a.listening:
        port, pids = int(a.listening[0]), a.listening[1:]
        cond = lambda: all(sockets_of(p, port) > 0 for p in pids)  # noqa: E731
        what = f"processes {' '.join(pids)} listening on UDP port {port}"
    elif a.command:
        cond = lambda: subprocess.run(a.command, stdin=subprocess.DEVNULL).returncode == 0  # noqa: E731
        what = " ".join(a.command)
    else:
        sys.exit("pof_wait.py until: no condition")
    if not wait_until(cond, a.timeout):
        print(f"pof_wait.py: not within {a.timeout:g} s: {what}", file=sys.stderr)
        sys.exit(1)


def cmd_caught_up(a):
    import pofkit  # noqa: PLC0415 (only this subcommand needs the package)

    suffix = "_" + a.sensor_id if a.sensor_id else ""
    daq_ch, comp_ch = "POF_DAQ_STATUS" + suffix, "POF_COMPENSATOR_STATUS" + suffix
    seen = {}  # channel -> its latest message

    def read(sub, timeout_s, stop):
        """Reads messages until one makes stop() true or timeout_s passes without any datagram."""
        for channel, _, m in sub.messages(timeout_s=timeout_s):
            seen[channel] = m
            if stop():
                return

    with pofkit.Subscriber([daq_ch, comp_ch], url=a.lcm_url) as sub:
        target = a.blocks
        if a.command:
            p = subprocess.Popen(a.command)
            # Read while it runs: a socket nobody reads overflows and would lose the final status.
            while p.poll() is None:
                read(sub, 0.05, lambda: p.poll() is not None)
            if p.returncode != 0:
                print(f"pof_wait.py caught-up: {' '.join(a.command)} exited {p.returncode}", file=sys.stderr)
                sys.exit(1)
            # Every datagram the DAQ sent is queued on our socket since it exited: the first pause
            # in the traffic comes after its final status (the final counters, last on its channel).
            read(sub, 0.001, lambda: False)
            if daq_ch not in seen:
                print(f"pof_wait.py caught-up: no {daq_ch} heard", file=sys.stderr)
                sys.exit(1)
            target = seen[daq_ch].blocks
        deadline = time.monotonic() + a.timeout
        took = lambda: seen[comp_ch].blocks if comp_ch in seen else -1  # noqa: E731
        while took() < target and time.monotonic() < deadline:
            read(sub, min(0.2, max(0.0, deadline - time.monotonic())) or 0.001,
                 lambda: took() >= target or time.monotonic() >= deadline)
    if took() < target:
        print(f"pof_wait.py caught-up: {comp_ch} shows {max(took(), 0)} raw blocks taken of {target} "
              f"after {a.timeout:g} s" + ("" if comp_ch in seen else " (no status heard)"), file=sys.stderr)
        sys.exit(1)
    print(f"{comp_ch}: took {took()} of {target} raw blocks")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("start")
    how = p.add_mutually_exclusive_group(required=True)
    how.add_argument("--notify", action="store_true")
    how.add_argument("--listening", type=int, metavar="PORT")
    p.add_argument("--report", required=True, metavar="FIFO")
    p.add_argument("--stderr", metavar="FILE")
    p.add_argument("--timeout", type=float, default=20)
    p.add_argument("command", nargs=argparse.REMAINDER)
    p = sub.add_parser("notify-log")
    p.add_argument("--watchdog-usec", type=int, default=1000000)
    p.add_argument("command", nargs=argparse.REMAINDER)
    p = sub.add_parser("until")
    p.add_argument("--timeout", type=float, default=20)
    p.add_argument("--drained", type=int, metavar="PORT")
    p.add_argument("--exited", type=int, metavar="PID")
    p.add_argument("--listening", nargs="+", metavar="PORT PID")
    p.add_argument("command", nargs=argparse.REMAINDER)
    p = sub.add_parser("sockets")
    p.add_argument("port", type=int)
    p.add_argument("pid", type=int)
    p = sub.add_parser("caught-up")
    p.add_argument("--lcm-url", required=True)
    p.add_argument("--sensor-id", default="")
    p.add_argument("--blocks", type=int)
    p.add_argument("--timeout", type=float, default=10)
    p.add_argument("command", nargs=argparse.REMAINDER)
    a = ap.parse_args()
    if getattr(a, "command", None) and a.command[0] == "--":
        a.command = a.command[1:]
    if a.cmd == "start":
        cmd_start(a)
    elif a.cmd == "notify-log":
        cmd_notify_log(a)
    elif a.cmd == "until":
        cmd_until(a)
    elif a.cmd == "sockets":
        print(sockets_of(a.pid, a.port))
    else:
        if (a.blocks is None) == (not a.command):
            sys.exit("pof_wait.py caught-up: give --blocks N or a DAQ command after --")
        cmd_caught_up(a)


if __name__ == "__main__":
    main()
