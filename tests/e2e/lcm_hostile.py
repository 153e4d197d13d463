#!/usr/bin/python3
"""Hostile and well-formed LCM udpm traffic for tests/e2e/compensatord_hostile.sh, by hand with
sockets (what any process on the host, or any machine on the segment, can send).

  lcm_hostile.py listen PORT OUT.json SCANS DUPLICATES DECODE_ERRORS
      joins the group, collects POF_ANGLE scan indices and the latest POF_COMPENSATOR_STATUS, and
      exits (writing OUT.json) once a status shows at least SCANS scans, DUPLICATES duplicate blocks
      and DECODE_ERRORS decode errors, or after 20 s.
  lcm_hostile.py hostile PORT   garbage, decode bombs, impossible fragments, a horde of senders,
                                unicast to 127.0.0.1, then a first block and two forged far ahead.
  lcm_hostile.py tail PORT      two replays/duplicates, then five good blocks after pof-testpub's.
  lcm_hostile.py forge PORT KEYFILE OUT.json [POF_RAW|POF_ANGLE]
      the authenticated mode (tests/e2e/lcm_auth.sh): captures 5 signed POF_RAW messages of the
      live pof-daqd, then sends 3 unsigned blocks, 2 signed with another key, 2 captured ones
      with a byte changed (4 bad MACs), 3 signed with the bus key but with counters 60 s off this
      host's clock (an old session's capture; 2 behind, 1 ahead: stale) and 3 captured ones again
      (replayed); writes what it sent per verdict to OUT.json. Every forged block claims scans
      from 10^12 on, far from the real stream's. With POF_ANGLE (tests/e2e/sdk_client.sh): the same
      on pof-compensatord's angles, forged angles of 90 deg claiming seq and scans from 10^12 on.

The message types come from lcm-gen's Python output in ./py (the script generates it).
Wire format: lcm/lcm_udpm.c (see common/bus/include/pof/bus/udpm_receiver.hpp). The authenticated mode's
trailer: common/bus/include/pof/bus/auth_trailer.hpp, in Python lcmtypes/python/pofkit/auth.py.
"""
import json
import os
import random
import socket
import struct
import sys
import time

sys.path.insert(0, "py")
sys.path.insert(1, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "lcmtypes", "python"))
from pof import angle_t, compensator_status_t, raw_block_t  # noqa: E402
from pofkit import auth  # noqa: E402  the trailer, its MAC and the key file, as pofkit's Python clients use them

GROUP = "239.255.76.67"
LC02, LC03 = 0x4C433032, 0x4C433033
SCANS_PER_BLOCK = 10


def now_us():
    return int(time.time() * 1e6)


def lc02(channel, payload, seq=0):
    return struct.pack(">II", LC02, seq) + channel.encode() + b"\0" + payload


def lc03(seq, size, offset, no, count, body, channel="POF_RAW"):
    head = struct.pack(">IIIIHH", LC03, seq, size, offset, no, count)
    return head + (channel.encode() + b"\0" if no == 0 else b"") + body


def block(seq, first_scan, utime):
    b = raw_block_t()
    b.utime = utime
    b.publish_utime = utime
    b.seq = seq
    b.first_scan = first_scan
    b.scan_rate_hz = 1000.0
    b.sensor_id = ""
    b.n_channels = 2
    b.channel_names = ["sensor", "reference"]
    b.channel_units = ["V", "V"]
    b.n_scans = SCANS_PER_BLOCK
    b.volts = [[4.0, 4.35] for _ in range(SCANS_PER_BLOCK)]
    b.flags = raw_block_t.FLAG_SIMULATED
    return b.encode()


def angle(seq, scan_index, utime):
    a = angle_t()
    a.utime = utime
    a.publish_utime = utime
    a.seq = seq
    a.scan_index = scan_index
    a.angle_deg = a.angle_uncomp_deg = 90.0
    a.angle_ref_deg = float("nan")
    return a.encode()


def raw_bytes(sensor_len=3, n_channels=2, names=("sensor", "reference"), n_scans=1, volts=2,
              fingerprint=None):
    """A raw_block_t written field by field, so any length can lie."""
    fp = fingerprint or raw_block_t._get_packed_fingerprint()
    t = now_us()
    b = fp + struct.pack(">qqqqd", t, t, 7, 70, 1000.0)
    b += struct.pack(">i", sensor_len) + b"LK\0"
    b += struct.pack(">h", n_channels)
    for n in names:
        b += struct.pack(">i", len(n) + 1) + n.encode() + b"\0"
    for _ in names:
        b += struct.pack(">i", 2) + b"V\0"
    b += struct.pack(">i", n_scans) + struct.pack(">%df" % volts, *([0.5] * volts))
    return b + struct.pack(">i", 0)


# --- The authenticated mode's trailer (common/bus/include/pof/bus/auth_trailer.hpp) --------------------
def sign(key, channel, message, counter, sender=0x0F0F0F0F0F0F0F0F):
    return auth.sign(key, channel, message, counter, sender)


def verify(key, channel, data):
    """(LCM message, sender, counter) of a message with a valid trailer (key and MAC: the caller
    checks the counter), else None."""
    if len(data) < auth.TRAILER_BYTES:
        return None
    message, header, tag = data[:-auth.TRAILER_BYTES], data[-auth.TRAILER_BYTES:-auth.MAC_BYTES], data[-auth.MAC_BYTES:]
    if struct.unpack(">II", header[:8]) != (auth.TRAILER_MAGIC, auth.TRAILER_VERSION) or header[8:12] != auth.key_id(key):
        return None
    sender, counter = struct.unpack(">QQ", header[12:28])
    return (message, sender, counter) if tag == auth.mac(key, channel, message, header) else None


def sender():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
    return s


def paced(s, port, datagrams):
    # 100 datagrams, then 10 ms: a burst must not overflow the receivers' kernel buffers, which
    # would make the counts below depend on the host's load.
    for i, d in enumerate(datagrams):
        s.sendto(d, (GROUP, port))
        if i % 100 == 99:
            time.sleep(0.01)


def hostile(port):
    s = sender()
    rng = random.Random(14)
    garbage = []
    for _ in range(1000):
        d = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 1400)))
        if d[:4] in (struct.pack(">I", LC02), struct.pack(">I", LC03)):
            d = b"\0" + d[1:]
        garbage.append(d)
    paced(s, port, garbage)  # 1000 malformed datagrams
    bombs = [
        raw_bytes(n_scans=2**31 - 1),                       # the 70-byte bad_alloc
        raw_bytes(n_scans=-1),
        raw_bytes(n_channels=-1),
        raw_bytes(sensor_len=0),                            # std::length_error in lcm-gen's decoder
        raw_bytes(sensor_len=-7),
        raw_bytes(fingerprint=b"\x01" * 8),                 # not a raw_block_t
        block(1, 10, now_us())[:40],                        # truncated
        raw_bytes(n_channels=0, names=(), n_scans=2**31 - 1, volts=0),  # a vector per scan, no bytes
    ]
    paced(s, port, [lc02("POF_RAW", b, seq=i) for i, b in enumerate(bombs)])  # 8 decode errors
    paced(s, port, [
        lc03(1, 100000, 0xFFFFFFFF, 1, 2, b"x" * 1000),    # crashed liblcm 1.3.1 (SIGSEGV)
        lc03(2, 0xFFFFFFFF, 0, 0, 65535, b"x" * 1000),     # a 4 GiB message
    ])  # 2 malformed
    horde = [sender() for _ in range(100)]  # 100 source ports, each opening a 16 MiB message
    for i, h in enumerate(horde):
        h.sendto(lc03(5, 16 << 20, 1000, 1, 256, b"y" * 1000), (GROUP, port))
        if i % 50 == 49:
            time.sleep(0.01)
    for h in horde:
        h.close()
    # A well-formed block sent to the host's own address: must not be received.
    s.sendto(lc02("POF_RAW", block(1, 500_000_000, now_us())), ("127.0.0.1", port))
    # The stream's first block, then two forged far ahead (seq 2^62, then 2^63-2).
    t0 = now_us() - 60_000_000
    paced(s, port, [
        lc02("POF_RAW", block(0, 0, t0)),
        lc02("POF_RAW", block(2**62, 2**62, t0 + 1)),
        lc02("POF_RAW", block(2**63 - 2, 2**63 - 1 - 2 * SCANS_PER_BLOCK, t0 + 2)),
    ])


def tail(port):
    s = sender()
    t = now_us()
    paced(s, port, [
        lc02("POF_RAW", block(0, 0, t - 60_000_000)),  # the first block replayed (old time)
        lc02("POF_RAW", block(50, 500, t)),            # pof-testpub's block 50 again
    ] + [lc02("POF_RAW", block(100 + k, 1000 + SCANS_PER_BLOCK * k, t + k)) for k in range(5)])


def receiver(port):
    r = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    r.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    r.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
    r.bind((GROUP, port))
    r.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                 socket.inet_aton(GROUP) + socket.inet_aton("0.0.0.0"))
    r.settimeout(0.2)
    return r


def forge(port, key_file, out, channel="POF_RAW"):
    key = auth.read_key(key_file)
    r = receiver(port)
    captured = []
    deadline = time.monotonic() + 30
    while len(captured) < 5 and time.monotonic() < deadline:
        try:
            d = r.recv(65536)
        except socket.timeout:
            continue
        if len(d) < 9 or struct.unpack(">I", d[:4])[0] != LC02:
            continue
        ch, _, payload = d[8:].partition(b"\0")
        if ch == channel.encode() and verify(key, channel, payload) is not None:
            captured.append(payload)
    if len(captured) < 5:
        sys.exit(f"forge: only {len(captured)} signed {channel} messages seen in 30 s")
    t = now_us()
    other = os.urandom(32)
    if channel == "POF_ANGLE":
        forged = [angle(10**12 + k, 10**12 + k, t) for k in range(8)]
    else:
        forged = [block(2**40 + k, 10**12 + SCANS_PER_BLOCK * k, t) for k in range(8)]
    altered = []
    for c in captured[:2]:
        m = bytearray(c)
        m[20] ^= 0x01  # inside the message (its utime), the trailer intact
        altered.append(bytes(m))
    sent = {
        "unsigned": [forged[0], forged[1], forged[2]],
        "bad_mac": [sign(other, channel, forged[3], t), sign(other, channel, forged[4], t + 1)] + altered,
        "stale": [sign(key, channel, forged[5], t - 60_000_000), sign(key, channel, forged[6], t - 59_000_000),
                  sign(key, channel, forged[7], t + 60_000_000)],
        "replayed": captured[2:5],
    }
    s = sender()
    paced(s, port, [lc02(channel, m, seq=1000 + i) for i, m in enumerate(sum(sent.values(), []))])
    json.dump({k: len(v) for k, v in sent.items()}, open(out, "w"))


def listen(port, out, want_scans, want_dups, want_decode):
    r = receiver(port)
    indices, status, statuses = [], None, 0
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        try:
            d = r.recv(65536)
        except socket.timeout:
            continue
        if len(d) < 9 or struct.unpack(">I", d[:4])[0] != LC02:
            continue
        ch, _, payload = d[8:].partition(b"\0")
        if ch == b"POF_ANGLE":
            indices.append(angle_t.decode(payload).scan_index)
        elif ch == b"POF_COMPENSATOR_STATUS":
            status = compensator_status_t.decode(payload)
            statuses += 1
            if (status.scans >= want_scans and status.duplicate_blocks >= want_dups
                    and status.decode_errors >= want_decode):
                break
    fields = ["blocks", "scans", "lost_blocks", "lost_scans", "rejected_blocks", "angles",
              "decode_errors", "malformed_datagrams", "duplicate_blocks", "publish_failures"]
    json.dump({"indices": indices, "statuses": statuses,
               "status": {f: getattr(status, f) for f in fields} if status else None},
              open(out, "w"))


if __name__ == "__main__":
    cmd, port = sys.argv[1], int(sys.argv[2])
    if cmd == "listen":
        listen(port, sys.argv[3], int(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6]))
    elif cmd == "hostile":
        hostile(port)
    elif cmd == "tail":
        tail(port)
    elif cmd == "forge":
        forge(port, sys.argv[3], sys.argv[4], *sys.argv[5:6])
    else:
        sys.exit("usage: lcm_hostile.py listen|hostile|tail|forge PORT ...")
