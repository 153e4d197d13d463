"""Receive side of LCM's udpm:// transport, for pofkit's live stream in Python.

Wire format (lcm/lcm_udpm.c, protocol version 2, integers big-endian):
  short message: u32 magic 0x4C433032 ("LC02"), u32 sequence, channel '\\0', payload
  fragment:      u32 magic 0x4C433033 ("LC03"), u32 sequence, u32 message size, u32 fragment
                 offset, u16 fragment number, u16 fragment count; fragment 0 then carries
                 channel '\\0' before its payload bytes.
Fragments of one message come from one sender with one sequence number; a new message from the same
sender abandons an incomplete one, as liblcm does.

The socket joins the group like liblcm (SO_REUSEADDR, so it shares the port with LCM processes)
but binds to the group address, not 0.0.0.0, so unicast datagrams sent to the host's own address
are not received, and sets IP_MULTICAST_ALL=0 against other groups on the same port
(docs/deployment.md, "Threat model"). Every length is checked before use; a malformed datagram is
counted in ``stats`` and dropped, never raised.
"""
import os
import socket
import struct
import time

from . import auth
from .types import decode

HOST_ONLY_URL = "udpm://239.255.76.67:7667?ttl=0"
_SHORT = struct.Struct(">II")
_FRAG = struct.Struct(">IIIIHH")
_MAGIC_SHORT, _MAGIC_FRAG = 0x4C433032, 0x4C433033
MAX_MESSAGE_BYTES = 16 << 20  # larger announced sizes are malformed (pofkit's largest is ~1 MB)
_IP_MULTICAST_ALL = getattr(socket, "IP_MULTICAST_ALL", 49)  # Linux <linux/in.h>


def resolve_url(url=None, recv_buf_bytes=8 << 20):
    """The URL rule every pofkit process follows (common/bus/include/pof/bus/url.hpp, mirrored here): the
    argument, else $LCM_DEFAULT_URL, else udpm on this host only (ttl=0); a udpm URL without
    recv_buf_size asks for 8 MiB, since the kernel's default buffer drops bursts while the reader
    is descheduled (the host needs deploy/sysctl.d's rmem_max to grant it)."""
    url = url or os.environ.get("LCM_DEFAULT_URL") or HOST_ONLY_URL
    if url.startswith("udpm://") and "recv_buf_size=" not in url.partition("?")[2]:
        url += ("&" if "?" in url else "?") + f"recv_buf_size={recv_buf_bytes}"
    return url


def _decimal(text, top):
    """Decimal digits only (no sign, space, '_' or base prefix), at most ``top``; None otherwise."""
    if not text or len(text) > 10 or any(not "0" <= c <= "9" for c in text):
        return None
    value = int(text)
    return value if value <= top else None


def parse_udpm_url(url):
    """udpm://GROUP:PORT?ttl=N&recv_buf_size=N -> (group, port, {"ttl": n, "recv_buf_size": n}),
    by the rules of pof::bus::parse_udpm_url (common/bus/include/pof/bus/url.hpp; test_pofkit.py compares
    the two): GROUP an IPv4 multicast address as inet_aton(3) reads it, PORT 1..65535, ttl 0..255,
    recv_buf_size 0..2^30, in decimal digits; other options are ignored. ValueError otherwise, with
    the C++ error text."""
    def bad(why):
        return ValueError(f"LCM URL '{url}': {why}")
    if not url.startswith("udpm://"):
        raise bad("not a udpm:// URL")
    rest, _, query = url[len("udpm://"):].partition("?")
    group, port = "239.255.76.67", 7667
    if rest:
        group, colon, port_text = rest.partition(":")
        if colon:
            port = _decimal(port_text, 65535)
            if not port:
                raise bad("port: expected 1..65535")
    try:
        first = socket.inet_aton(group)[0]
    except (OSError, ValueError):
        first = -1
    if not 224 <= first <= 239:
        raise bad(f"'{group}' is not an IPv4 multicast address")
    opts = {"ttl": 0, "recv_buf_size": 0}
    for kv in query.split("&"):
        key, _, value = kv.partition("=")
        if key == "ttl":
            opts["ttl"] = _decimal(value, 255)
            if opts["ttl"] is None:
                raise bad("ttl: expected 0..255")
        elif key == "recv_buf_size":
            opts["recv_buf_size"] = _decimal(value, 1 << 30)
            if opts["recv_buf_size"] is None:
                raise bad("recv_buf_size: expected 0..1073741824 bytes")
    return group, port, opts


class Subscriber:
    """Messages of the given channels (all when None) from an LCM udpm:// bus, decoded."""

    def __init__(self, channels=None, url=None, key=None, auth_window_s=2.0):
        """``key``: the bus key (pofkit.auth.read_key) of the authenticated mode; then only verified
        messages are yielded and the others are counted per verdict in ``stats``
        (auth_unsigned, auth_bad_mac, auth_stale, auth_replayed)."""
        self.url = resolve_url(url)
        group, port, opts = parse_udpm_url(self.url)
        self.channels = set(channels) if channels else None
        self.stats = {"datagrams": 0, "malformed": 0, "incomplete": 0, "undecodable": 0, "foreign": 0}
        self._verifier = auth.Verifier(key, auth_window_s) if key is not None else None
        if self._verifier is not None:
            self.stats.update({"auth_" + v: 0 for v in self._verifier.counts})
        self._partial = {}  # sender -> [seq, size, got_bytes, n_frags, got_frags, channel, bytearray]
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if opts["recv_buf_size"] > 0:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, opts["recv_buf_size"])
        s.bind((group, port))
        mreq = struct.pack("4s4s", socket.inet_aton(group), socket.inet_aton("0.0.0.0"))
        s.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
        try:
            s.setsockopt(socket.IPPROTO_IP, _IP_MULTICAST_ALL, 0)
        except OSError:
            pass  # not Linux: the group binding still filters by destination address
        self._sock = s

    def close(self):
        self._sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def fileno(self):
        return self._sock.fileno()

    def messages(self, timeout_s=None):
        """Yields (channel, receive utime [us], message) until ``timeout_s`` passes without any
        message of ours (None: forever). Foreign and undecodable messages are counted, not yielded."""
        while True:
            self._sock.settimeout(timeout_s)
            try:
                data, sender = self._sock.recvfrom(65536)
            except socket.timeout:
                return
            now = time.time_ns() // 1000
            for channel, payload in self._datagram(data, sender):
                if self.channels is not None and channel not in self.channels:
                    continue
                if self._verifier is not None:
                    verdict, payload = self._verifier.verify(channel, payload, now)
                    if verdict != auth.OK:
                        self.stats["auth_" + verdict] += 1
                        continue
                msg = decode(payload)
                if msg is None:
                    self.stats["undecodable" if payload[:8] and len(payload) >= 8 else "malformed"] += 1
                    continue
                yield channel, now, msg

    def _datagram(self, d, sender):
        self.stats["datagrams"] += 1
        if len(d) < 8:
            self.stats["malformed"] += 1
            return
        magic, seq = _SHORT.unpack_from(d, 0)
        if magic == _MAGIC_SHORT:
            end = d.find(b"\0", 8)
            if end < 0 or end == 8:
                self.stats["malformed"] += 1
                return
            yield d[8:end].decode("utf-8", "replace"), d[end + 1:]
            return
        if magic != _MAGIC_FRAG or len(d) < _FRAG.size:
            self.stats["malformed"] += 1
            return
        _, seq, size, offset, frag_no, n_frags = _FRAG.unpack_from(d, 0)
        body = d[_FRAG.size:]
        if size == 0 or size > MAX_MESSAGE_BYTES or n_frags == 0 or frag_no >= n_frags:
            self.stats["malformed"] += 1
            return
        p = self._partial.get(sender)
        if frag_no == 0:
            end = body.find(b"\0")
            if end <= 0:
                self.stats["malformed"] += 1
                return
            channel, body = body[:end].decode("utf-8", "replace"), body[end + 1:]
            if p is not None and p[0] != seq:
                self.stats["incomplete"] += 1
            p = [seq, size, 0, n_frags, 0, channel, bytearray(size)]
            self._partial[sender] = p
            if len(self._partial) > 64:  # bounded: forget the oldest sender's partial message
                self._partial.pop(next(iter(self._partial)))
                self.stats["incomplete"] += 1
        elif p is None or p[0] != seq or p[1] != size or p[3] != n_frags:
            if p is not None:
                self._partial.pop(sender, None)
                self.stats["incomplete"] += 1
            return  # fragment of a message whose start we missed
        if offset > size or len(body) > size - offset:
            self.stats["malformed"] += 1
            return
        p[6][offset:offset + len(body)] = body
        p[2] += len(body)
        p[4] += 1
        if p[4] == p[3]:
            del self._partial[sender]
            if p[2] == p[1]:
                yield p[5], bytes(p[6])
            else:
                self.stats["malformed"] += 1
