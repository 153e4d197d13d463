"""`pof dash` in a real browser: headless Chromium driven over W3C WebDriver (Debian's chromedriver,
spoken to with the standard library), the page's values checked against the messages sent.

  dash_browser.py <pof> <pof-testpub> <lcm url> <work dir>

1. pof dash serves; Chromium opens the page; pof-testpub publishes 3,333 angles/s for 8 s plus a
   cycle's statistics each second. While it runs the page's animation frames are timed.
2. The bus side lost nothing (the dashboard's own count against what was sent, no seq gaps).
3. The page shows what was sent: the last angle (its data and the readout's text), every cycle in
   the table, the flagged angles' count, the whole loop, and then says the stream stopped.
4. A screenshot (dash.png in the work dir) and the frame times are printed.
"""
import json
import os
import re
import subprocess
import sys
import time

from webdriver import Browser, fail, procs, request, wait_for  # noqa: E402

POF, PUB, URL, WORK = sys.argv[1:5]
RATE, SECONDS, SENSOR = 3333, 8.0, "LEFT_KNEE"


def pct(xs, p):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(p / 100 * len(xs)))] if xs else float("nan")


def main():
    out = open(os.path.join(WORK, "dash.out"), "w+")
    procs.append(subprocess.Popen([POF, "dash", "--lcm-url", URL, "--port", "0"], stdout=out, stderr=subprocess.STDOUT))
    port = wait_for("pof dash's address", lambda: re.findall(r"http://127\.0\.0\.1:(\d+)/", open(out.name).read()))[0]
    page = "http://127.0.0.1:%s/" % port
    state = lambda: request("GET", page + "api/state")

    b = Browser(WORK)
    try:
        b.get(page)
        wait_for("the page's WebSocket", lambda: b.js("return window.pofDash && window.pofDash.connected"))
        # Animation frames as the browser paces them, while the bus runs at full rate.
        b.js("window.__raf = []; (function f(t) { window.__raf.push(t); requestAnimationFrame(f); })(performance.now());")
        pub = subprocess.run([PUB, "--lcm-url", URL, "angles", "--rate", str(RATE), "--duration", str(SECONDS),
                              "--suffix", "_" + SENSOR], capture_output=True, text=True, timeout=120)
        if pub.returncode != 0:
            fail("pof-testpub: " + pub.stderr)
        sent = json.loads(pub.stdout)
        raf = b.js("const r = window.__raf; window.__raf = []; return r;")

        # 2. The bus side: every angle counted, no seq gap.
        s = wait_for("the dashboard to count every angle",
                     lambda: next((x for x in state()["sensors"] if x["id"] == SENSOR and x["angles"] >= sent["sent"]), None), 5)
        if s["angles"] != sent["sent"] or s["angles_missing"] != 0:
            fail("the dashboard counted %d angles (%d missing), %d were sent" % (s["angles"], s["angles_missing"], sent["sent"]))
        if s["cycles_total"] != len(sent["cycles"]):
            fail("cycles: %d counted, %d sent" % (s["cycles_total"], len(sent["cycles"])))

        # 3. The page: its data, its readout, its tables.
        last = sent["last"]
        # The last display bucket closes a bucket's time after the last angle; the next frame brings it.
        def last_on_page():
            v = b.js("const s = window.pofDash.sensors.get(arguments[0]); return s.angle[s.angle.length - 1];", SENSOR)
            return v is not None and abs(v - last["angle_deg"]) <= 1e-6
        wait_for("the last angle on the page", last_on_page, 5)
        got = b.js("const s = window.pofDash.sensors.get(arguments[0]);"
                   "return {angle: s.angle[s.angle.length - 1], ref: s.ref[s.ref.length - 1], uncomp: s.uncomp[s.uncomp.length - 1],"
                   " n: s.t.length, span: s.t[s.t.length - 1] - s.t[0], flagged: s.info.angles_flagged};", SENSOR)
        for k, want in (("angle", last["angle_deg"]), ("ref", last["angle_ref_deg"]), ("uncomp", last["angle_uncomp_deg"])):
            if abs(got[k] - want) > 1e-6:
                fail("the page's last %s is %r, the last message sent had %r" % (k, got[k], want))
        if got["flagged"] != sent["sent"] // 500:
            fail("the page counts %d flagged angles, %d were sent" % (got["flagged"], sent["sent"] // 500))
        # Every point the dashboard made is on the page, and there are at most 100 a second (the
        # display rate) however many angles came: on a loaded host the publisher sends in bursts,
        # so fewer 10 ms buckets than 800 may hold angles.
        served = len(request("GET", page + "api/state")["sensors"][0]["points"]["t"])
        if got["n"] != served or not 100 <= got["n"] <= 100 * (SECONDS + 0.5):
            fail("the page holds %d chart points, the dashboard made %d for %.0f s of angles (at most 100/s)"
                 % (got["n"], served, SECONDS))
        text = b.js("return {angle: document.getElementById('angle').textContent, ref: document.getElementById('ref').textContent,"
                    " rows: [...document.querySelectorAll('#cycles tbody tr')].map(r => [...r.cells].map(c => c.textContent)),"
                    " health: document.querySelector('#health tbody').textContent};")
        if text["angle"] != "%.2f°" % last["angle_deg"] or text["ref"] != "%.2f°" % last["angle_ref_deg"]:
            fail("readout shows angle %r ref %r; last sent %.4f %.4f" % (text["angle"], text["ref"], last["angle_deg"], last["angle_ref_deg"]))
        rows = text["rows"]
        if len(rows) != len(sent["cycles"]):
            fail("the cycle table has %d rows, %d cycles were sent" % (len(rows), len(sent["cycles"])))
        for row, c in zip(rows, reversed(sent["cycles"])):  # newest first
            if row[0] != str(c["cycle"]) or row[2] != "%.3f" % c["rmse_comp_deg"] or row[6] != "%.3f" % c["max_error_deg"]:
                fail("cycle row %r does not show %r" % (row, c))
        if SENSOR not in text["health"]:
            fail("the health table lacks " + SENSOR)
        loop = b.js("const x = window.pofDash.charts.loop.scales.x; return [x.min, x.max];")
        if loop[1] - loop[0] < 80:  # the reference sweeps 0..90 deg
            fail("the loop chart's reference axis spans %r, expected 0..90 deg" % loop)
        stale = wait_for("the readout to say the stream stopped",
                         lambda: b.js("const e = document.getElementById('age'); return e.className.includes('bad') && e.textContent;"), 5)
        if not stale.startswith("no angle for"):
            fail("stale readout says %r" % stale)

        # 4. Figures and a picture.
        dt = [b2 - a2 for a2, b2 in zip(raf, raf[1:])]
        render = b.js("return window.pofDash.renderMs;")
        frames = b.js("return {frames: window.pofDash.frames, renders: window.pofDash.renders, bytes: window.pofDash.bytes};")
        bus = state()["bus"]
        b.screenshot(os.path.join(WORK, "dash.png"))
        print("dash_browser: %d angles in %.2f s (%.0f/s), all counted, 0 missing; page: %d frames (%.0f kB), %d renders, "
              "render p50 %.1f ms p95 %.1f ms; animation frame interval p50 %.1f ms p95 %.1f ms max %.1f ms over %d frames; "
              "frames skipped %d; screenshot %s" % (
                  sent["sent"], sent["seconds"], sent["sent"] / sent["seconds"], frames["frames"], frames["bytes"] / 1e3,
                  frames["renders"], pct(render, 50), pct(render, 95), pct(dt, 50), pct(dt, 95), max(dt) if dt else float("nan"),
                  len(raf), bus["frames_skipped"], os.path.join(WORK, "dash.png")))
        if len(raf) < 5 * SECONDS:  # 5 frames/s: still usable; a shared CI host is no tablet
            fail("the page drew %d animation frames in %.0f s of full-rate bus: it was not responsive" % (len(raf), SECONDS))
    finally:
        b.quit()


try:
    main()
finally:
    for p in procs:
        p.terminate()
    for p in procs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()
