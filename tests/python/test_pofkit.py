"""The pofkit Python package against real LCM peers: liblcm publishing (pof-testpub) on udpm
loopback, logs written by stock lcm-logger, damaged logs and hostile datagrams, and its LCM URL
rule against the C++ one.

Run by ctest with PYTHONPATH = build/python (lcm-gen's `pof` classes) : lcmtypes/python/ (pofkit),
POF_TESTPUB = build/tests/pof-testpub and POF_URL_PROBE = build/tests/url_probe.
"""
import os
import random
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np

import pofkit

# The e2e tests' readiness helper: wait for conditions, never for a fixed time.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "e2e"))
import pof_wait  # noqa: E402

TESTPUB = os.environ["POF_TESTPUB"]
URL_PROBE = os.environ["POF_URL_PROBE"]


def private_url():
    return f"udpm://239.255.76.67:{random.randint(20000, 50000)}?ttl=0"


class Collector(threading.Thread):
    """Subscribes in the background until `quiet_s` passes without a message."""

    def __init__(self, url, channels, quiet_s=1.5, key=None):
        super().__init__(daemon=True)
        self.sub = pofkit.Subscriber(channels, url=url, key=key)
        self.quiet_s, self.got = quiet_s, []

    def run(self):
        with self.sub:
            for channel, utime, msg in self.sub.messages(timeout_s=self.quiet_s):
                self.got.append((channel, utime, msg))


class LiveStream(unittest.TestCase):
    def test_short_and_fragmented_messages_from_liblcm(self):
        url = private_url()
        c = Collector(url, ["POF_RAW", "POF_ANGLE"])
        c.start()
        # 8000 scans x 3 channels x 4 B = 96 kB per block: liblcm sends it as 2 fragments.
        subprocess.run([TESTPUB, "--lcm-url", url, "burst", "--channel", "POF_RAW", "--count", "20",
                        "--rate", "50", "--scans", "8000"], check=True, capture_output=True)
        subprocess.run([TESTPUB, "--lcm-url", url, "session", "--duration", "1"], check=True, capture_output=True)
        c.join(timeout=30)
        raw = [m for ch, _, m in c.got if ch == "POF_RAW" and m.sensor_id == "BURST"]
        self.assertEqual([m.seq for m in raw], list(range(20)), "every fragmented block, in order")
        self.assertEqual(raw[0].n_scans, 8000)
        self.assertAlmostEqual(raw[0].volts[7999][1], 4.35, places=5)
        angles = [m for ch, _, m in c.got if ch == "POF_ANGLE"]
        self.assertGreater(len(angles), 50)
        self.assertEqual([m.seq for m in angles], list(range(len(angles))))
        self.assertEqual(c.sub.stats["malformed"], 0)

    def test_authenticated_mode_yields_only_verified_messages(self):
        # A key as `pof keygen` writes it (64 hex digits, mode 0600), read as the daemons read it.
        d = tempfile.mkdtemp()
        path = os.path.join(d, "bus.key")
        key = bytes(range(32))
        with open(os.open(path, os.O_WRONLY | os.O_CREAT, 0o600), "w") as f:
            f.write(key.hex() + "\n")
        self.assertEqual(pofkit.auth.read_key(path), key)
        os.chmod(path, 0o640)
        with self.assertRaisesRegex(ValueError, "bus.key.*group or others"):
            pofkit.auth.read_key(path)
        os.chmod(path, 0o600)
        with open(path, "w") as f:
            f.write("0" * 64 + "\n")
        with self.assertRaisesRegex(ValueError, "bus.key.*all zeros"):
            pofkit.auth.read_key(path)
        shutil.rmtree(d)

        url = private_url()
        group, port, _ = pofkit.parse_udpm_url(url)
        c = Collector(url, ["POF_ANGLE"], quiet_s=1.0, key=key)
        c.start()
        import pof
        now = time.time_ns() // 1000

        def angle(seq):
            a = pof.angle_t()
            a.seq, a.angle_deg = seq, float(seq)
            return a.encode()

        def datagram(payload, seq):
            return struct.pack(">II", 0x4C433032, seq) + b"POF_ANGLE\0" + payload

        sign = pofkit.auth.sign
        good = [sign(key, "POF_ANGLE", angle(i), now + i, sender=7) for i in range(3)]
        tampered = bytearray(sign(key, "POF_ANGLE", angle(90), now + 10, sender=7))
        tampered[12] ^= 1
        sent = good + [
            angle(91),                                                            # unsigned
            sign(bytes(32), "POF_ANGLE", angle(92), now + 11, sender=7),          # another key
            bytes(tampered),                                                      # altered
            sign(key, "POF_ANGLE", angle(93), now - 60_000_000, sender=7),        # an old session's
            good[1],                                                              # replayed
        ]
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
        # The Subscriber joined the group when the Collector was made: what is sent now is queued.
        for i, m in enumerate(sent):
            s.sendto(datagram(m, i), (group, port))
        c.join(timeout=20)
        self.assertEqual([m.seq for _, _, m in c.got], [0, 1, 2], "only the verified angles")
        st = c.sub.stats
        self.assertEqual((st["auth_unsigned"], st["auth_bad_mac"], st["auth_stale"], st["auth_replayed"]),
                         (1, 2, 1, 1), st)

    def test_hostile_datagrams_are_counted_not_raised(self):
        url = private_url()
        group, port, _ = pofkit.parse_udpm_url(url)
        c = Collector(url, None, quiet_s=1.0)
        c.start()
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
        hostile = [
            b"",                                                    # empty
            b"LC02",                                                # short header
            struct.pack(">II", 0x4C433032, 1) + b"POF_RAW",         # no channel terminator
            struct.pack(">IIIIHH", 0x4C433033, 2, 100, 0xFFFFFFFF, 1, 2),  # offset far out
            struct.pack(">IIIIHH", 0x4C433033, 3, 0xFFFFFFFF, 0, 0, 2) + b"POF_RAW\0",  # 4 GiB message
            struct.pack(">II", 0x4C433032, 4) + b"POF_RAW\0" + b"\x00" * 3,  # payload shorter than a fingerprint
        ]
        # A raw_block_t whose fingerprint is right but whose arrays claim 2^31-1 scans.
        import pof
        b = pof.raw_block_t()
        b.channel_names, b.channel_units, b.n_channels = ["sensor"], ["V"], 1
        good = b.encode()
        huge = bytearray(good)
        n_scans_at = len(good) - 4 - 4  # ... n_scans (i32), volts (empty), flags (i32)
        huge[n_scans_at:n_scans_at + 4] = struct.pack(">i", 2**31 - 1)
        hostile.append(struct.pack(">II", 0x4C433032, 5) + b"POF_RAW\0" + bytes(huge))
        hostile += [random.randbytes(random.randint(1, 1500)) for _ in range(300)]
        for d in hostile:
            s.sendto(d, (group, port))
        s.sendto(struct.pack(">II", 0x4C433032, 6) + b"POF_RAW\0" + good, (group, port))
        c.join(timeout=20)
        self.assertFalse(c.is_alive())
        self.assertEqual(len(c.got), 1, "only the one good message comes through")
        st = c.sub.stats
        self.assertGreaterEqual(st["malformed"] + st["undecodable"], 6, st)


class Logs(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="pofkit-py-")

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def record(self):
        """A log of pof-testpub's session written by stock lcm-logger."""
        url = private_url()
        port = pofkit.parse_udpm_url(url)[1]
        path = os.path.join(self.dir, "session.lcmlog")
        logger = subprocess.Popen(["lcm-logger", "--lcm-url", url, "-q", path],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            # lcm-logger does not say when it is ready: it is once its socket is bound on the port
            # (liblcm joins the group right after binding).
            self.assertTrue(pof_wait.wait_until(
                lambda: pof_wait.sockets_of(logger.pid, port) > 0 or logger.poll() is not None, 20))
            self.assertIsNone(logger.poll(), "lcm-logger exited")
            subprocess.run([TESTPUB, "--lcm-url", url, "session", "--duration", "2"], check=True,
                           capture_output=True)
            # Stopped once it read everything the kernel queued for it.
            self.assertTrue(pof_wait.wait_until(lambda: pof_wait.drained(port), 20))
        finally:
            logger.terminate()
            logger.wait(timeout=10)
        return path

    def test_lcm_logger_log_into_arrays(self):
        path = self.record()
        everything = pofkit.read_log(path)
        self.assertNotIn("FOREIGN_TELEMETRY", everything, "foreign types are left out")
        angles = everything["POF_ANGLE"]
        n = len(angles["seq"])
        self.assertGreater(n, 150)
        np.testing.assert_array_equal(angles["seq"], np.arange(n))
        self.assertTrue(np.all(angles["angle_deg"] - angles["angle_ref_deg"] > 0.39))
        raw = pofkit.read_log(path, channel="POF_RAW")
        self.assertEqual(len(raw["scan_index"]) % 10, 0, "10 scans per block")
        np.testing.assert_array_equal(raw["scan_index"], np.arange(len(raw["scan_index"])))
        np.testing.assert_allclose(raw["reference"], 4.35, rtol=1e-6)
        # Scan times step by 1/scan_rate inside each block (testpub: 10 scans at 1 kHz).
        np.testing.assert_array_equal(np.diff(raw["utime"].reshape(-1, 10), axis=1), 1000)

    def test_damaged_log_names_the_offset_and_salvage_counts(self):
        path = self.record()
        blob = bytearray(open(path, "rb").read())
        # The second event's data length becomes 0x7fffffff.
        second = blob.find(struct.pack(">I", pofkit.log.SYNC), 4)
        blob[second + 24:second + 28] = struct.pack(">I", 0x7FFFFFFF)
        bad = os.path.join(self.dir, "bad.lcmlog")
        open(bad, "wb").write(bytes(blob))
        with self.assertRaises(pofkit.LogError) as e:
            pofkit.read_log(bad)
        self.assertEqual(e.exception.offset, second)
        stats = {}
        events = list(pofkit.read_events(bad, salvage=True, stats=stats))
        self.assertGreater(stats["damaged_bytes"], 0)
        self.assertEqual(len(events), len(list(pofkit.read_events(path))) - 1)
        with self.assertRaises(pofkit.LogError):
            pofkit.read_log("/dev/zero")


class UrlRules(unittest.TestCase):
    """pofkit.resolve_url and parse_udpm_url mirror common/bus/include/pof/bus/url.hpp (Python cannot share
    the C++ code): both read every URL of a list alike, with $LCM_DEFAULT_URL set and unset. The C++
    side is build/tests/url_probe (tests/support/url_probe.cpp)."""

    URLS = [
        "", "udpm://239.255.76.67:7667?ttl=0", "udpm://239.255.76.68:7700?ttl=1&recv_buf_size=4194304",
        "udpm://", "udpm://239.255.76.67", "udpm://239.255.76.67?ttl=1", "udpm://224.0.0.1:1",
        "udpm://239.1:7667", "udpm://0xef.1.2.3:7667", "udpm://239.255.76.67 x:7667",
        "udpm://239.255.76.67:", "udpm://239.255.76.67:0", "udpm://239.255.76.67:65535", "udpm://239.255.76.67:65536",
        "udpm://239.255.76.67:+80", "udpm://239.255.76.67: 80", "udpm://239.255.76.67:7667:1", "udpm://:7700",
        "udpm://10.0.0.1:7667", "udpm://240.0.0.1:7667", "udpm://not.a.host:7667",
        "udpm://239.255.76.67:7667?ttl=256", "udpm://239.255.76.67:7667?ttl=x", "udpm://239.255.76.67:7667?ttl=",
        "udpm://239.255.76.67:7667?ttl", "udpm://239.255.76.67:7667?ttl=1_0", "udpm://239.255.76.67:7667?ttl=2&ttl=3",
        "udpm://239.255.76.67:7667?recv_buf_size=1073741824", "udpm://239.255.76.67:7667?recv_buf_size=1073741825",
        "udpm://239.255.76.67:7667?&transmit_only=true&", "udpm://239.255.76.67:7667?xrecv_buf_size=5",
        "udpm://239.255.76.67:7667?ttl=\u0661", "memq://", "file:///tmp/x.lcmlog?mode=w", "UDPM://239.255.76.67:7667",
    ]

    def python_side(self, url, env_url):
        env = {k: v for k, v in os.environ.items() if k != "LCM_DEFAULT_URL"}
        if env_url is not None:
            env["LCM_DEFAULT_URL"] = env_url
        saved = dict(os.environ)
        try:
            os.environ.clear()
            os.environ.update(env)
            resolved = pofkit.resolve_url(url or None)
        finally:
            os.environ.clear()
            os.environ.update(saved)
        try:
            group, port, opts = pofkit.parse_udpm_url(url)
            return [resolved, group, str(port), str(opts["ttl"]), str(opts["recv_buf_size"]), ""]
        except ValueError as e:
            prefix = f"LCM URL '{url}': "
            self.assertTrue(str(e).startswith(prefix), str(e))
            return [resolved, None, None, None, None, str(e)[len(prefix):]]

    def test_python_and_cpp_read_every_url_alike(self):
        for env_url in (None, "udpm://239.255.76.69:7001?ttl=1"):
            env = {k: v for k, v in os.environ.items() if k != "LCM_DEFAULT_URL"}
            if env_url is not None:
                env["LCM_DEFAULT_URL"] = env_url
            out = subprocess.run([URL_PROBE, *self.URLS], env=env, capture_output=True, text=True, check=True).stdout
            lines = out.split("\n")[:-1]
            self.assertEqual(len(lines), len(self.URLS), out)
            for url, line in zip(self.URLS, lines):
                cpp = line.split("\t")
                py = self.python_side(url, env_url)
                with self.subTest(url=url, env=env_url):
                    self.assertEqual(py[0], cpp[0], "resolved URL")
                    self.assertEqual(py[5], cpp[5], "error")
                    if not cpp[5]:
                        self.assertEqual(py[1:5], cpp[1:5], "group, port, ttl, recv_buf_size")


if __name__ == "__main__":
    unittest.main()
