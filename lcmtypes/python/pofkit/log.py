"""LCM log files (``lcm-logger``, ``pof record``) into Python objects and NumPy arrays.

Format (lcm/eventlog.c; every integer big-endian), one event after another:

    u32 sync 0xEDA1DA01 | i64 event number | i64 timestamp [us] | i32 channel length |
    i32 data length | channel bytes | data bytes

Every length is checked against the bytes that remain in the file before anything is allocated, so
a damaged log cannot make the reader allocate gigabytes; damage is reported by LogError with the
byte offset, never skipped silently (``salvage=True`` skips to the next sync word and counts).
"""
import os
import struct

import numpy as np

from .types import decode

SYNC = 0xEDA1DA01
_HEADER = struct.Struct(">IqqII")
_MAX_CHANNEL = 256  # liblcm's limit on channel names (LCM_MAX_CHANNEL_NAME_LENGTH 63, with margin)


class LogError(ValueError):
    """A damaged or unreadable log; ``offset`` is the byte where the damage starts."""

    def __init__(self, path, offset, what):
        super().__init__(f"{path}: byte {offset}: {what}")
        self.path, self.offset = path, offset


def read_events(path, salvage=False, stats=None):
    """Yields (timestamp_us, channel, data bytes) for every event of the log at ``path``.

    Raises LogError at the first damaged event unless ``salvage``; then damaged stretches are
    skipped to the next sync word and counted in ``stats['damaged_bytes']`` (a dict you pass).
    """
    if stats is None:
        stats = {}
    stats.setdefault("damaged_bytes", 0)
    stats.setdefault("events", 0)
    with open(path, "rb") as f:
        if not os.path.isfile(path):
            raise LogError(path, 0, "not a regular file")
        blob = f.read()
    n, pos = len(blob), 0
    while pos < n:
        err = None
        if n - pos < _HEADER.size:
            err = f"truncated event header ({n - pos} bytes left)"
        else:
            sync, _num, utime, clen, dlen = _HEADER.unpack_from(blob, pos)
            rest = n - pos - _HEADER.size
            if sync != SYNC:
                err = f"sync word 0x{sync:08X}, expected 0x{SYNC:08X}"
            elif clen == 0 or clen > _MAX_CHANNEL or clen > rest:
                err = f"channel length {clen} (at most {min(_MAX_CHANNEL, rest)})"
            elif dlen > rest - clen:
                err = f"data length {dlen}, only {rest - clen} bytes left in the file"
        if err is not None:
            if not salvage:
                raise LogError(path, pos, err)
            nxt = blob.find(struct.pack(">I", SYNC), pos + 1)
            nxt = n if nxt < 0 else nxt
            stats["damaged_bytes"] += nxt - pos
            pos = nxt
            continue
        start = pos + _HEADER.size
        channel = blob[start:start + clen].decode("utf-8", "replace")
        data = blob[start + clen:start + clen + dlen]
        pos = start + clen + dlen
        stats["events"] += 1
        yield utime, channel, data


def read_log(path, channel=None, salvage=False):
    """The messages of one channel (or of every pofkit channel) as NumPy arrays.

    With ``channel``: a dict of arrays, one per field (see :func:`to_arrays`); raw_block_t channels
    come out per scan (:func:`raw_scans`). Without: a dict channel -> such a dict. Events that are
    not pofkit messages (a foreign type on the bus) are left out.
    """
    by_channel = {}
    for _utime, ch, data in read_events(path, salvage=salvage):
        if channel is not None and ch != channel:
            continue
        msg = decode(data)
        if msg is not None:
            by_channel.setdefault(ch, []).append(msg)
    out = {ch: (raw_scans(m) if type(m[0]).__name__ == "raw_block_t" else to_arrays(m))
           for ch, m in by_channel.items()}
    if channel is not None:
        return out.get(channel, {})
    return out


def to_arrays(messages):
    """Scalar fields of a list of messages of one type, as one NumPy array per field."""
    if not messages:
        return {}
    fields = [f for f in type(messages[0]).__slots__
              if isinstance(getattr(messages[0], f), (int, float))]
    return {f: np.array([getattr(m, f) for m in messages]) for f in fields}


def raw_scans(blocks):
    """raw_block_t messages as per-scan arrays: scan_index, utime (host time of each scan [us],
    block utime + k / scan_rate_hz), flags of the block, and one array of volts per channel name."""
    if not blocks:
        return {}
    names = list(blocks[0].channel_names)
    cols = {"scan_index": [], "utime": [], "flags": []}
    volts = {name: [] for name in names}
    for b in blocks:
        if list(b.channel_names) != names:
            raise ValueError(f"channel layout changed at block seq {b.seq}: {list(b.channel_names)} vs {names}")
        k = np.arange(b.n_scans)
        cols["scan_index"].append(b.first_scan + k)
        cols["utime"].append(b.utime + np.round(k * 1e6 / b.scan_rate_hz).astype(np.int64))
        cols["flags"].append(np.full(b.n_scans, b.flags))
        v = np.asarray(b.volts, dtype=np.float32).reshape(b.n_scans, len(names))
        for j, name in enumerate(names):
            volts[name].append(v[:, j])
    out = {k: np.concatenate(v) for k, v in cols.items()}
    out.update({name: np.concatenate(v) for name, v in volts.items()})
    return out
