"""pofkit for Python: read pofkit's LCM logs into NumPy arrays and subscribe to its live stream.

Debian ships no LCM Python module, so this package speaks the two LCM formats it needs itself:
the log file format (lcm/eventlog.c) in :mod:`pofkit.log` and the udpm:// multicast transport
(lcm/lcm_udpm.c, receive side) in :mod:`pofkit.udpm`. The message classes are lcm-gen's own
Python output for pofkit's .lcm files (package ``pof``, generated at build time and installed
beside this package), so every field keeps its name and unit from the .lcm documentation.

    import pofkit
    angles = pofkit.read_log("session.lcmlog", channel="POF_ANGLE")   # dict of NumPy arrays
    with pofkit.Subscriber(["POF_ANGLE"]) as sub:                       # $LCM_DEFAULT_URL
        for channel, utime, msg in sub.messages(timeout_s=5):
            print(msg.seq, msg.angle_deg)
    # The authenticated mode: only verified messages (pofkit.auth).
    pofkit.Subscriber(["POF_ANGLE"], key=pofkit.auth.read_key("/etc/pof/lcm.key"))
"""
from . import auth
from .types import decode, message_class
from .log import LogError, read_events, read_log, to_arrays, raw_scans
from .udpm import Subscriber, resolve_url, parse_udpm_url

__all__ = ["auth", "decode", "message_class", "LogError", "read_events", "read_log", "to_arrays", "raw_scans",
           "Subscriber", "resolve_url", "parse_udpm_url"]
