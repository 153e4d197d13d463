#!/usr/bin/python3
"""`pof dash` under the full rate (BENCHMARKS.md, "The browser view under load").

  tools/bench/dash_load.py [build-dir] [seconds]

The live pipeline at 3,333 scans/s (pof-daqd sim:session -> pof-compensatord, every scan an
angle -> pof record), run twice for the same time: without a dashboard, then with `pof dash` and
its page open in headless Chromium. Per run: what the compensator lost (its last status, as
recorded), what the recorder dropped (its manifest), and with the dashboard, the angles it
counted against the compensator's, its CPU, and the page's draw and animation-frame times.
"""
import csv
import json
import os
import re
import subprocess
import sys
import tempfile
import time

BUILD = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build")
SECONDS = float(sys.argv[2]) if len(sys.argv) > 2 else 20
RATE = 3333
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "e2e"))
from webdriver import Browser, procs, request, wait_for  # noqa: E402

BIN = os.path.join(BUILD, "bin")


def run(*args, **kw):
    return subprocess.run(list(args), check=True, capture_output=True, text=True, **kw)


def cpu_s(pid):
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def pct(xs, p):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(p / 100 * len(xs)))] if xs else float("nan")


def session(work, with_dash):
    url = "udpm://239.255.76.67:%d?ttl=0" % (20000 + int.from_bytes(os.urandom(2), "big") % 30000)
    tag = "with" if with_dash else "without"
    log = os.path.join(work, tag + ".lcmlog")
    started = []

    def start(args, out):
        p = subprocess.Popen(args, stdout=open(os.path.join(work, out), "w"), stderr=subprocess.STDOUT)
        started.append(p)
        return p

    rec = start([os.path.join(BIN, "pof"), "record", "-o", log, "--lcm-url", url, "-q"], tag + "-record.out")
    start([os.path.join(BIN, "pof-compensatord"), "--cal", "cal.toml", "--pot-cal", "pot.toml", "--lcm-url", url],
          tag + "-comp.out")
    browser = dash = None
    if with_dash:
        dash = start([os.path.join(BIN, "pof"), "dash", "--lcm-url", url, "--port", "0"], "dash.out")
        port = wait_for("pof dash", lambda: re.findall(r"http://127\.0\.0\.1:(\d+)/", open(os.path.join(work, "dash.out")).read()))[0]
        browser = Browser(work)
        browser.get("http://127.0.0.1:%s/" % port)
        wait_for("the page", lambda: browser.js("return window.pofDash && window.pofDash.connected"))
        browser.js("window.__raf = []; (function f(t) { window.__raf.push(t); requestAnimationFrame(f); })(performance.now());")
    time.sleep(1)
    cpu0 = cpu_s(dash.pid) if dash else 0
    run(os.path.join(BIN, "pof-daqd"), "--device", "sim:session", "--rate", str(RATE), "--decimate", "1", "--lcm-url", url,
        "--duration", str(SECONDS))
    time.sleep(2)  # the compensator's last status and the dashboard's last frame
    out = {}
    if with_dash:
        out["dash_cpu_pct"] = 100 * (cpu_s(dash.pid) - cpu0) / (SECONDS + 2)
        st = request("GET", "http://127.0.0.1:%s/api/state" % port)
        out["dash_angles"] = sum(s["angles"] for s in st["sensors"])
        out["dash_missing"] = sum(s["angles_missing"] for s in st["sensors"])
        out["frames_skipped"] = st["bus"]["frames_skipped"]
        raf = browser.js("return window.__raf;")
        dt = [b - a for a, b in zip(raf, raf[1:])]
        render = browser.js("return window.pofDash.renderMs;")
        out.update(render_p50=pct(render, 50), render_p95=pct(render, 95), raf_p50=pct(dt, 50), raf_p95=pct(dt, 95),
                   page_frames=browser.js("return window.pofDash.frames;"))
        browser.quit()
    for p in reversed(started):
        p.terminate()
        p.wait(timeout=20)
    m = json.load(open(log[:-len(".lcmlog")] + ".manifest.json"))
    c = m["counters"]
    out["recorder_received"], out["recorder_written"] = c["received"], c["written"]
    out["recorder_dropped"] = c["dropped_handoff"] + c["udp_kernel_drops"]
    out["recorded_angles"] = m["channels"]["POF_ANGLE"]["events"]
    out["angle_seq_missing"] = m["channels"]["POF_ANGLE"]["seq"]["missing"]
    status = os.path.join(work, tag + "-status.csv")
    run(os.path.join(BIN, "pof"), "export", log, "-c", "POF_COMPENSATOR_STATUS", "-o", status)
    last = list(csv.DictReader(open(status)))[-1]
    out["comp_scans"], out["comp_lost_scans"] = int(last["scans"]), int(last["lost_scans"])
    out["comp_angles"] = int(last["angles"])
    return out


def main():
    work = tempfile.mkdtemp(prefix="pof-dash-load.")
    os.chdir(work)
    run(os.path.join(BIN, "pof"), "sim", "paper", "-o", "cal.csv", "--seed", "11")
    run(os.path.join(BIN, "pof"), "calibrate", "cal.csv", "-o", "cal.toml")
    with open("pot.toml", "w") as f:
        f.write("schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n")
    try:
        for with_dash in (False, True):
            r = session(work, with_dash)
            print(("with pof dash + page:" if with_dash else "without a dashboard:"), json.dumps(r))
    finally:
        for p in procs:
            p.terminate()
    print("work directory:", work)


main()
