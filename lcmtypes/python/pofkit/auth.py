"""The authenticated mode of pofkit's bus, for Python (docs/deployment.md, "Authenticated mode").

With a bus key, every message a pofkit process publishes ends in a 60-byte trailer: magic "POFA",
version 1, key id, sender id, counter (the sender's clock, us) and a keyed BLAKE2b-256 MAC
(RFC 7693) over the channel, the message and the trailer's first 28 bytes. The layout is
common/bus/include/pof/bus/auth_trailer.hpp; the verdicts and their order are those of
common/bus/include/pof/bus/auth.hpp, so a Python client drops what pofkit's own receivers drop.
Keyed BLAKE2b is :func:`hashlib.blake2b` with ``key=``: nothing beyond the standard library.

    key = pofkit.auth.read_key("/etc/pof/lcm.key")
    with pofkit.Subscriber(["POF_ANGLE"], key=key) as sub:   # only verified messages are yielded
        ...
"""
import hashlib
import hmac
import os
import stat
import struct
import time

TRAILER_MAGIC, TRAILER_VERSION = 0x504F4641, 1
TRAILER_BYTES, HEADER_BYTES, MAC_BYTES = 60, 28, 32
KEY_BYTES = 32
OK, UNSIGNED, BAD_MAC, STALE, REPLAYED = "ok", "unsigned", "bad_mac", "stale", "replayed"


def read_key(path):
    """The bus key in ``path``: 64 hex digits and a line end (``pof keygen``) or 32 raw bytes.
    Refused, as pofkit's daemons refuse it, when group or others may read it or it is all zeros
    (ValueError naming the file); OSError when it cannot be read."""
    st = os.stat(path)
    if st.st_mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise ValueError("bus key file '%s': mode %o lets group or others read it (chmod 600)"
                         % (path, stat.S_IMODE(st.st_mode)))
    with open(path, "rb") as f:
        data = f.read(2 * KEY_BYTES + 3)
    if len(data) == KEY_BYTES:
        return data
    text = data.rstrip(b"\r\n")
    try:
        key = bytes.fromhex(text.decode("ascii"))
    except (UnicodeDecodeError, ValueError):
        key = b""
    if len(key) != KEY_BYTES or len(text) != 2 * KEY_BYTES:
        raise ValueError("bus key file '%s': expected 32 bytes, or 64 hex digits and a line end "
                         "(pof keygen writes one)" % path)
    if key == bytes(KEY_BYTES):
        raise ValueError("bus key file '%s': the key is all zeros, which anyone can guess; "
                         "pof keygen -o FILE writes a random one" % path)
    return key


def key_id(key):
    """The 4 bytes that name a key in trailers (not secret)."""
    return hashlib.blake2b(b"pofkit-lcm-key-id", key=key, digest_size=16).digest()[:4]


def mac(key, channel, message, header):
    ch = channel.encode()
    h = hashlib.blake2b(key=key, digest_size=MAC_BYTES)
    h.update(struct.pack(">I", len(ch)) + ch + struct.pack(">Q", len(message)) + message + header)
    return h.digest()


def sign(key, channel, message, counter, sender):
    """``message`` with its trailer, as a pofkit publisher with ``key`` sends it."""
    header = struct.pack(">II", TRAILER_MAGIC, TRAILER_VERSION) + key_id(key) + struct.pack(">QQ", sender, counter)
    return message + header + mac(key, channel, message, header)


class Verifier:
    """Checks trailers in the order of pof/bus/auth.hpp and counts the verdicts in ``counts``.

    The counter must be within ``window_s`` of this host's clock (sender and receivers need
    synchronised clocks) and beyond the last one accepted from that sender on that channel."""

    MAX_SENDERS = 4096  # (sender, channel) pairs remembered; the oldest is forgotten beyond

    def __init__(self, key, window_s=2.0):
        if len(key) != KEY_BYTES:
            raise ValueError("a bus key is %d bytes, got %d" % (KEY_BYTES, len(key)))
        self._key, self._id = key, key_id(key)
        self._window_us = int(window_s * 1e6)
        self._last = {}
        self.counts = {UNSIGNED: 0, BAD_MAC: 0, STALE: 0, REPLAYED: 0}

    def verify(self, channel, data, now_us=None):
        """(verdict, the LCM message in front of the trailer or None)."""
        verdict, message = self._check(channel, data, time.time_ns() // 1000 if now_us is None else now_us)
        if verdict != OK:
            self.counts[verdict] += 1
        return verdict, message

    def _check(self, channel, data, now_us):
        if len(data) < TRAILER_BYTES:
            return UNSIGNED, None
        message, header, tag = data[:-TRAILER_BYTES], data[-TRAILER_BYTES:-MAC_BYTES], data[-MAC_BYTES:]
        if struct.unpack(">II", header[:8]) != (TRAILER_MAGIC, TRAILER_VERSION):
            return UNSIGNED, None
        if header[8:12] != self._id or not hmac.compare_digest(tag, mac(self._key, channel, message, header)):
            return BAD_MAC, None
        sender, counter = struct.unpack(">QQ", header[12:28])
        if abs(counter - now_us) > self._window_us:
            return STALE, None
        last = self._last.get((sender, channel))
        if last is not None and counter <= last:
            return REPLAYED, None
        self._last.pop((sender, channel), None)
        self._last[(sender, channel)] = counter
        if len(self._last) > self.MAX_SENDERS:
            self._last.pop(next(iter(self._last)))
        return OK, message
