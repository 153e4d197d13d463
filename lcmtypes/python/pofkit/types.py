"""Decoding LCM payloads into lcm-gen's ``pof`` classes, chosen by the 8-byte type fingerprint.

An LCM message is its type's fingerprint (big-endian u64) followed by the fields; lcm-gen's
``decode()`` checks the fingerprint and raises ValueError on a mismatch. Here the fingerprint picks
the class, so one channel may carry any pofkit type and a foreign message is recognised as such.
"""
import struct

import pof  # lcm-gen -p output for lcmtypes/*.lcm (installed beside pofkit)

_CLASSES = [pof.raw_block_t, pof.angle_t, pof.cycle_stats_t, pof.daq_status_t, pof.compensator_status_t]
_BY_FINGERPRINT = {c._get_packed_fingerprint(): c for c in _CLASSES}


def message_class(data):
    """The pof class whose fingerprint starts ``data``, or None for a foreign or short payload."""
    return _BY_FINGERPRINT.get(bytes(data[:8]))


def decode(data):
    """The decoded message, or None when ``data`` is not a well-formed pofkit message.

    Malformed input never raises: a truncated payload, a negative or huge array length and a
    wrong fingerprint all give None (a live subscriber must not stop on one bad datagram).
    """
    cls = message_class(data)
    if cls is None:
        return None
    try:
        return cls.decode(bytes(data))
    except (ValueError, struct.error, MemoryError, OverflowError, UnicodeDecodeError, IndexError):
        return None
