#!/usr/bin/python3
"""Checks of tests/e2e/lcm_auth.sh on the files it leaves in its work directory (the current
directory): forged.json (what the forger sent, per verdict), raw.csv / angle.csv / status.csv
(`pof export` of the verified recording auth.lcmlog), auth.manifest.json, stock.lcmlog (lcm-logger)
and spy.txt. The trailer is checked with pofkit's Python implementation (lcmtypes/python/pofkit/auth.py, hashlib).
"""
import csv
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, "py")
import lcm_hostile  # noqa: E402
import pofkit  # noqa: E402
from pof import raw_block_t  # noqa: E402

VERDICTS = ("unsigned", "bad_mac", "stale", "replayed")


def check(ok, what):
    """Fails the test, saying what was wrong (asserts would vanish under python3 -O)."""
    if not ok:
        sys.exit(f"FAIL: {what}")


sent = json.load(open("forged.json"))
print("forged and sent:", sent)
check(sent == {"unsigned": 3, "bad_mac": 4, "stale": 3, "replayed": 3}, f"the forger sent {sent}")

# The compensator's angles: exactly one per scan of pof-daqd's blocks, nothing forged.
raw = list(csv.DictReader(open("raw.csv")))
ang = list(csv.DictReader(open("angle.csv")))
check(len(raw) > 500, f"only {len(raw)} scans recorded")
raw_idx = [int(r["scan_index"]) for r in raw]
ang_idx = [int(a["scan_index"]) for a in ang]
check(max(raw_idx) < 10**12, "a forged block was recorded as verified")
check(ang_idx == raw_idx, f"{len(ang_idx)} angles for {len(raw_idx)} scans, or other indices "
      f"(forged from 10^12: {sum(i >= 10**12 for i in ang_idx)})")
print(f"{len(ang_idx)} angles, one per scan of the {len(raw_idx)} verified scans; none forged")

# Its last status: the drops per verdict, and nothing reached the pipeline.
st = list(csv.DictReader(open("status.csv")))[-1]
print("last compensator status:", {k: st[k] for k in ("authenticated", "blocks", "duplicate_blocks", "decode_errors")
                                   + tuple("auth_" + v for v in VERDICTS)})
check(st["authenticated"] == "1", f"status says authenticated={st['authenticated']}")
for v in VERDICTS:
    check(int(st["auth_" + v]) == sent[v], f"auth_{v} {st['auth_' + v]}, sent {sent[v]}")
for k in ("duplicate_blocks", "decode_errors", "rejected_blocks", "lost_blocks", "lost_scans", "publish_failures"):
    check(st[k] == "0", f"{k} {st[k]}: a forgery reached the pipeline or the stream broke")

# The recorder: the same drops, every verified block recorded.
m = json.load(open("auth.manifest.json"))
a = m["authentication"]
check(a["enabled"] and a["window_s"] == 5.0, f"manifest authentication {a}")
check(a["key_id"] == lcm_hostile.auth.key_id(lcm_hostile.auth.read_key("bus.key")).hex(), f"manifest key id {a['key_id']}")
check(a["dropped"] == sent, f"manifest dropped {a['dropped']}, sent {sent}")

# Stock lcm-logger logged the signed bytes: lcm-gen's decoder reads them (it ignores the trailer),
# and the MAC of every block recorded as verified checks out with hashlib (the forgeries do not, or
# carry a counter 60 s from the time lcm-logger received them, or are replays).
key = lcm_hostile.auth.read_key("bus.key")
recorded = {(b.seq, b.first_scan) for b in (raw_block_t.decode(d) for _, ch, d in pofkit.read_events("auth.lcmlog")
                                            if ch == "POF_RAW")}
good = set()
for utime, channel, data in pofkit.read_events("stock.lcmlog"):
    if channel != "POF_RAW":
        continue
    v = lcm_hostile.verify(key, channel, data)
    if v is None or abs(v[2] - utime) > 5_000_000:
        continue  # a forgery: not signed with the key, altered, or stale
    message = v[0]
    b = raw_block_t.decode(data)  # the stock decoder, given the whole signed message
    check(raw_block_t.decode(message).encode() == message and b.encode() == message,
          "a signed block does not decode as its message")
    good.add((b.seq, b.first_scan))
check(good == recorded, f"lcm-logger has {len(good)} verified blocks, pof record {len(recorded)}")
print(f"lcm-logger: {len(good)} signed blocks, MACs verified with hashlib, the same as pof record's")

# pof spy, verifying with the key (from the environment), shows the drops in its header.
spy = open("spy.txt").read()
check("authenticated (key " + a["key_id"] + "): dropped unsigned" in spy, f"spy header: {spy[:300]}")
head = [line for line in spy.splitlines() if line.startswith("authenticated (key")][0]
counts = dict(zip(head.split()[4::2], (int(x) for x in head.split()[5::2])))
check(all(counts[v] >= 1 for v in VERDICTS), f"spy counts {counts}")
check("SIGNED, NOT VERIFIED" not in spy and "DECODE ERRORS" not in spy, "spy shows unverified or undecodable messages")
print("pof spy:", head)
