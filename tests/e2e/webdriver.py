"""A headless Chromium for tests and benchmarks, driven over W3C WebDriver with the standard
library (Debian's chromium and chromium-driver; no Selenium, no download of a browser).
Chromium runs with the flags this sandbox needs: no sandbox as root, no GPU, no background
networking (its connections out are refused here, many at a time), and /tmp instead of a /dev/shm
that a container may keep small."""
import base64
import json
import os
import socket
import subprocess
import sys
import time
import urllib.request

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
http = urllib.request.build_opener(urllib.request.ProxyHandler({}))  # loopback only, never a proxy
procs = []  # what the caller must stop: chromedriver, and whatever it adds


def fail(msg):
    print("FAIL:", msg, file=sys.stderr)
    sys.exit(1)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def request(method, url, body=None, timeout=30):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(url, data=data, method=method, headers={"Content-Type": "application/json"})
    with http.open(req, timeout=timeout) as r:
        return json.loads(r.read() or b"null")


def wait_for(what, fn, timeout=15):
    deadline = time.time() + timeout
    while time.time() < deadline:
        v = fn()
        if v:
            return v
        time.sleep(0.1)
    fail("timed out waiting for " + what)


class Browser:
    """The W3C WebDriver commands this test needs."""

    def __init__(self, work_dir):
        port = free_port()
        procs.append(subprocess.Popen([CHROMEDRIVER, "--port=%d" % port], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        self.base = "http://127.0.0.1:%d" % port
        wait_for("chromedriver", lambda: self._up())
        args = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage",
                "--user-data-dir=" + os.path.join(work_dir, "chromium-profile"), "--window-size=1280,1100"]
        caps = {"capabilities": {"alwaysMatch": {"browserName": "chrome",
                                                 "goog:chromeOptions": {"binary": CHROMIUM, "args": args}}}}
        self.session = self.base + "/session/" + request("POST", self.base + "/session", caps, timeout=60)["value"]["sessionId"]

    def _up(self):
        try:
            return request("GET", self.base + "/status", timeout=2)["value"]["ready"]
        except OSError:
            return False

    def get(self, url):
        request("POST", self.session + "/url", {"url": url})

    def js(self, script, *args):
        return request("POST", self.session + "/execute/sync", {"script": script, "args": list(args)})["value"]

    def screenshot(self, path):
        with open(path, "wb") as f:
            f.write(base64.b64decode(request("GET", self.session + "/screenshot")["value"]))

    def quit(self):
        try:
            request("DELETE", self.session, timeout=10)
        except OSError:
            pass


