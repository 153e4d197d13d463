#!/usr/bin/python3
"""The datagrams of `pof bridge` (bridge.sh) against what pof-testpub's session mode publishes
(tests/e2e/pof_testpub.cpp), read the way PlotJuggler's UDP Server reads them (docs/export.md, "PlotJuggler"):
one JSON object per datagram, a top-level numeric "timestamp" in seconds, one object per channel.

  bridge_check.py listen PORT OUT         binds 127.0.0.1:PORT, keeps every datagram until SIGTERM,
                                          then writes them to OUT (a JSON list of strings)
  bridge_check.py check OUT STDERR MAX_RATE
                                          checks OUT against the session (suffix _LEFT_KNEE, --raw)
                                          and the counts pof bridge printed to STDERR
"""
import json
import re
import signal
import socket
import sys
import time


def listen(port, out):
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    sock.bind(("127.0.0.1", port))
    got = []

    def stop(*_):
        with open(out, "w") as f:
            json.dump(got, f)
        sys.exit(0)

    signal.signal(signal.SIGTERM, stop)
    while True:
        got.append(sock.recv(65536).decode("utf-8", "replace"))


def no_constant(name):
    raise AssertionError(f"{name} in a datagram: not JSON, PlotJuggler would stop")


def check(out, stderr, max_rate):
    datagrams = json.load(open(out))
    assert datagrams, "no datagram arrived"
    now = time.time()
    by_channel = {}
    for i, text in enumerate(datagrams):
        # PlotJuggler stops its UDP server on a datagram that does not parse: bare NaN must not occur.
        d = json.loads(text, parse_constant=no_constant)
        assert isinstance(d.get("timestamp"), float), f"datagram {i}: no numeric timestamp: {text[:200]}"
        assert abs(d["timestamp"] - now) < 120, f"datagram {i}: timestamp {d['timestamp']} is not this session's"
        channels = [k for k in d if k != "timestamp"]
        assert len(channels) == 1, f"datagram {i}: channels {channels}"
        by_channel.setdefault(channels[0], []).append((d["timestamp"], d[channels[0]]))
    want = {"POF_ANGLE_LEFT_KNEE", "POF_STATS_LEFT_KNEE", "POF_DAQ_STATUS_LEFT_KNEE", "POF_RAW_LEFT_KNEE"}
    assert set(by_channel) == want, f"channels {sorted(by_channel)}, expected {sorted(want)} (not FOREIGN_TELEMETRY)"

    angles = by_channel["POF_ANGLE_LEFT_KNEE"]
    for t, a in angles:
        # pof-testpub: angle = ref + 0.4, uncompensated = ref + 2.5, ref on a 0..90 deg cosine.
        assert 0 <= a["angle_ref_deg"] <= 90, f"angle_ref_deg {a['angle_ref_deg']}"
        assert abs(a["angle_deg"] - a["angle_ref_deg"] - 0.4) < 1e-3, f"angle {a}"
        assert abs(a["angle_uncomp_deg"] - a["angle_ref_deg"] - 2.5) < 1e-3, f"angle {a}"
        assert a["quality"] in (0, 64) and a["phase"] in (0, 1, 2), f"angle {a}"
        assert a["angle_sigma_deg"] is None, f"angle_sigma_deg (NaN) should be null: {a}"
    seqs = [a["seq"] for _, a in angles]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs), "angle seq not increasing"
    times = [t for t, _ in angles]
    gaps = [b - a for a, b in zip(times, times[1:])]
    # --max-rate: no two angles sent closer than 1/rate in message time (utime to the microsecond).
    assert min(gaps) >= 1 / max_rate - 2e-6, f"angles {min(gaps) * 1e3:.3f} ms apart at --max-rate {max_rate}"
    assert seqs[1] - seqs[0] >= 2, f"100 Hz angles at --max-rate {max_rate} were not thinned: seq {seqs[:5]}"

    for _, s in by_channel["POF_STATS_LEFT_KNEE"]:
        assert abs(s["rmse_comp_deg"] - 1.1) < 1e-6 and s["n_samples"] == 2000, f"stats {s}"
    for _, s in by_channel["POF_DAQ_STATUS_LEFT_KNEE"]:
        assert s["state"] == 1 and s["scan_rate_hz"] == 1000.0 and "state_text" not in s, f"status {s}"
    for _, r in by_channel["POF_RAW_LEFT_KNEE"]:
        # Block means of the volts: the reference is 4.35 V in every scan, pot = ref / 30.
        assert abs(r["reference_v"] - 4.35) < 1e-5 and r["n_scans"] == 10, f"raw {r}"
        assert -1e-3 <= r["pot_v"] * 30 <= 90.001, f"raw {r}"

    # pof bridge's own counts: what it sent is what arrived; received = sent + decimated.
    text = open(stderr).read()
    for channel, rows in by_channel.items():
        m = re.search(rf"{channel}: received (\d+), sent (\d+), decimated (\d+), send failures (\d+)", text)
        assert m, f"no count line for {channel} in: {text}"
        received, sent, decimated, failures = map(int, m.groups())
        assert sent == len(rows) and failures == 0, f"{channel}: sent {sent}, arrived {len(rows)}, failures {failures}"
        assert received == sent + decimated, f"{channel}: {m.group(0)}"
        if channel == "POF_ANGLE_LEFT_KNEE":
            assert decimated > 0, f"{channel}: nothing decimated: {m.group(0)}"
            print(f"angles: received {received}, sent {sent}, decimated {decimated}")
    print(f"{len(datagrams)} datagrams: " + ", ".join(f"{c} {len(r)}" for c, r in sorted(by_channel.items())))


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "listen":
        listen(int(sys.argv[2]), sys.argv[3])
    elif len(sys.argv) == 5 and sys.argv[1] == "check":
        try:
            check(sys.argv[2], sys.argv[3], float(sys.argv[4]))
        except AssertionError as e:
            sys.exit(f"FAIL: {e}")
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
