#!/usr/bin/python3
"""The fault soak's checker (tools/soak/soak.sh): judges each part against its target and writes one
JSON result per part; `summary` joins them into summary.json and summary.md.

  soak_check.py unplug REPORT --cycles N --slack-s S --out JSON
      pof-vdaq's report of an unplug soak (--scenario unplug --unplug-every): per unplug, the
      FLAG_GAP block after the replug and its index advance. docs/daq.md ("States"): after a lost
      session the scan index advances by the time that passed and the first block after it carries
      FLAG_GAP. So a cycle costs (unplugged time + reconnect time) x published rate, the reconnect
      time being replug -> first block after it; S covers the scans the USB transfers in flight
      held when the cable went (they are lost too) and the first block's own publish latency.
      A cycle passes when the daemon reconnected (one FLAG_GAP block after the replug, before the
      next unplug), the gap is within [unplugged x rate x 0.95, cost + S x rate], and nothing
      jumped without a flag.
  soak_check.py restarts STREAM-CSV KILLS --what NAME --rate HZ --slack-s S --out JSON
      SIGKILL/restart cycles of a publisher heard by soak_listen.py. KILLS: one line per cycle,
      "<cycle> <kill time> <ready time>" (epoch seconds). Per cycle: the restarted publisher's first
      message has seq 0 (the restart is visible), and the time lost between the last message of the
      killed one and the first of the new one is at most kill -> READY=1 + S (a daemon cannot
      publish before it runs; S: the last block in progress when killed and the first one after
      READY). Within a publisher, every seq follows the previous one and every index jump is
      flagged (FLAG_GAP / QUALITY_GAP).
  soak_check.py record CHECK-DIR KILLS --cycles N --block-s B --slack-s S --out JSON
      SIGKILL/restart cycles of `pof record` while pof-daqd publishes: CHECK-DIR/rec.<i>.check holds
      `pof record --check` of log i (after --repair for a killed one: the soak writes
      rec.<i>.rc with the exit codes "check repair recheck"). Each log must end clean, hold
      POF_RAW without a sequence gap, and the blocks missing between two logs must fit in
      kill -> READY=1 + S (B seconds per block).
  soak_check.py rss-sample --pid NAME=PID... --interval S --duration S --out CSV
      Samples VmRSS (/proc/PID/status, proc(5)) of each process every S seconds.
  soak_check.py rss CSV --warmup S --max-mb-per-h M --out JSON
      Growth after the warm-up: last - first, and the least-squares slope [MB/h]; passes when each
      process stayed alive and its slope is below M.
  soak_check.py summary JSON... --command TEXT --out-dir DIR
      Writes DIR/summary.json and DIR/summary.md; exit 1 when any part failed.
"""
import argparse
import csv
import json
import os
import re
import sys
import time

import numpy as np


def _write(path, result):
    with open(path, "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")
    print(f"{result['part']}: {'PASS' if result['pass'] else 'FAIL'}: {result['headline']}")


def _stats(values):
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return {"n": 0}
    return {"n": int(v.size), "min": round(float(v.min()), 4), "p50": round(float(np.median(v)), 4),
            "p99": round(float(np.percentile(v, 99)), 4), "max": round(float(v.max()), 4)}


def cmd_unplug(a):
    with open(a.report) as f:
        r = json.load(f)
    rate = float(r.get("published_rate_hz") or 0)
    unplugs, gaps = r.get("unplugs", []), r.get("gap_events", [])
    cycles, failures = [], []
    for i, u in enumerate(unplugs):
        end = unplugs[i + 1]["unplugged_s"] if i + 1 < len(unplugs) else float("inf")
        after = [g for g in gaps if u["replugged_s"] <= g["received_s"] < end]
        off_s = u["replugged_s"] - u["unplugged_s"]
        c = {"cycle": i + 1, "unplugged_s": round(off_s, 4), "gap_blocks": len(after)}
        if len(after) != 1:
            c["ok"] = False
            c["why"] = f"{len(after)} FLAG_GAP blocks between the replug and the next unplug (expected 1)"
        else:
            g = after[0]
            reconnect_s = g["received_s"] - u["replugged_s"]
            cost = (off_s + reconnect_s) * rate
            c.update(reconnect_s=round(reconnect_s, 4), gap_scans=g["scans"], documented_cost_scans=round(cost, 1),
                     excess_scans=round(g["scans"] - cost, 1))
            lo, hi = 0.95 * off_s * rate, cost + a.slack_s * rate
            c["ok"] = lo <= g["scans"] <= hi
            if not c["ok"]:
                c["why"] = f"gap of {g['scans']} scans outside [{lo:.0f}, {hi:.0f}]"
        cycles.append(c)
    bad = [c for c in cycles if not c["ok"]]
    # A gap block outside every replug window is a gap nobody unplugged for.
    stray = [g for g in gaps if not any(u["replugged_s"] <= g["received_s"] for u in unplugs)]
    reconnects = r.get("status", {}).get("reconnects", 0)
    if len(unplugs) != a.cycles:
        failures.append(f"{len(unplugs)} unplugs done, {a.cycles} asked")
    if bad:
        failures.append(f"{len(bad)} cycles failed, first: cycle {bad[0]['cycle']}: {bad[0]['why']}")
    if stray:
        failures.append(f"{len(stray)} FLAG_GAP blocks before the first replug")
    if reconnects < a.cycles:
        failures.append(f"pof-daqd counted {reconnects} reconnects for {a.cycles} unplugs")
    if r.get("index_jumps_without_gap_flag", 0):
        failures.append(f"{r['index_jumps_without_gap_flag']} index jumps without FLAG_GAP")
    if not r.get("pass", False):
        failures.append("pof-vdaq: " + "; ".join(r.get("failures", [])))
    ok_cycles = len(unplugs) - len(bad)
    res = {
        "part": "unplug", "pass": not failures, "failures": failures,
        "headline": f"{ok_cycles}/{a.cycles} cycles reconnected with the gap flagged and within cost; "
                    f"reconnect p50 {_stats([c.get('reconnect_s', 0) for c in cycles]).get('p50')} s",
        "cycles_ok": ok_cycles, "cycles_asked": a.cycles, "reconnects_counted": reconnects,
        "published_rate_hz": rate, "gap_blocks": r.get("gap_blocks"),
        "index_jumps_without_gap_flag": r.get("index_jumps_without_gap_flag"), "seq_gaps": r.get("seq_gaps"),
        "reconnect_s": _stats([c["reconnect_s"] for c in cycles if "reconnect_s" in c]),
        "gap_scans": _stats([c["gap_scans"] for c in cycles if "gap_scans" in c]),
        "excess_over_cost_scans": _stats([c["excess_scans"] for c in cycles if "excess_scans" in c]),
        "slack_s": a.slack_s, "cycles": cycles,
    }
    _write(a.out, res)


def _kills(path):
    with open(path) as f:
        return [(int(c), float(k), float(r)) for c, k, r in (line.split() for line in f if line.strip())]


def cmd_restarts(a):
    with open(a.stream) as f:
        rows = [{k: int(v) for k, v in row.items()} for row in csv.DictReader(f)]
    gap_flag = 8 if a.what == "pof-compensatord" else 2  # angle_t.QUALITY_GAP, raw_block_t.FLAG_GAP
    # Split the stream into publisher instances where seq restarts (as soak_listen.py counts them).
    inst, failures = [], []
    seq_gaps = unflagged = 0
    for m in rows:
        if not inst or m["seq"] <= inst[-1][-1]["seq"]:
            inst.append([m])
            continue
        p = inst[-1][-1]
        if m["seq"] != p["seq"] + 1:
            seq_gaps += 1
        elif m["index"] != p["index"] + p["n"] and not m["flags"] & gap_flag:
            unflagged += 1
        inst[-1].append(m)
    kills = _kills(a.kills)
    cycles = []
    for cycle, t_kill, t_ready in kills:
        c = {"cycle": cycle, "kill_to_ready_s": round(t_ready - t_kill, 4)}
        if cycle >= len(inst):
            c.update(ok=False, why="the restarted publisher was never heard")
        else:
            old, new = inst[cycle - 1][-1], inst[cycle][0]
            end_old = old["utime"] + old["n"] * 1e6 / a.rate
            lost_s = (new["utime"] - end_old) / 1e6
            c.update(first_seq=new["seq"], lost_s=round(lost_s, 4), lost_scans=round(lost_s * a.rate),
                     excess_s=round(lost_s - (t_ready - t_kill), 4))
            c["ok"] = new["seq"] == 0 and lost_s <= t_ready - t_kill + a.slack_s
            if new["seq"] != 0:
                c["why"] = f"the restarted publisher's first message heard has seq {new['seq']}, not 0"
            elif not c["ok"]:
                c["why"] = f"lost {lost_s:.3f} s > kill->ready {t_ready - t_kill:.3f} s + {a.slack_s} s"
        cycles.append(c)
    bad = [c for c in cycles if not c["ok"]]
    if len(inst) != len(kills) + 1:
        failures.append(f"{len(inst)} publisher instances heard for {len(kills)} kills (expected {len(kills) + 1})")
    if bad:
        failures.append(f"{len(bad)} cycles failed, first: cycle {bad[0]['cycle']}: {bad[0]['why']}")
    if seq_gaps:
        failures.append(f"{seq_gaps} seq gaps within a publisher (messages lost outside the kills)")
    if unflagged:
        failures.append(f"{unflagged} index jumps without a gap flag")
    res = {
        "part": f"kill {a.what}", "pass": not failures and len(kills) == a.cycles, "failures": failures,
        "headline": f"{len(kills) - len(bad)}/{a.cycles} SIGKILL cycles resumed from seq 0 within kill->ready + "
                    f"{a.slack_s} s; kill->ready p50 {_stats([c['kill_to_ready_s'] for c in cycles]).get('p50')} s",
        "cycles_ok": len(kills) - len(bad), "cycles_asked": a.cycles, "messages_heard": len(rows),
        "seq_gaps_within_publisher": seq_gaps, "index_jumps_without_flag": unflagged, "rate_hz": a.rate,
        "kill_to_ready_s": _stats([c["kill_to_ready_s"] for c in cycles]),
        "lost_s": _stats([c["lost_s"] for c in cycles if "lost_s" in c]),
        "lost_scans": _stats([c["lost_scans"] for c in cycles if "lost_scans" in c]),
        "lost_minus_kill_to_ready_s": _stats([c["excess_s"] for c in cycles if "excess_s" in c]),
        "slack_s": a.slack_s, "cycles": cycles,
    }
    if len(kills) != a.cycles:
        res["failures"].append(f"{len(kills)} kills done, {a.cycles} asked")
    _write(a.out, res)


# `pof record --check` per channel: "<channel> <type> <n> events  seq A..B, G gaps (M missing), R restarts"
_CHECK_RAW = re.compile(r"^\s*POF_RAW\s+\S+\s+(\d+) events\s+seq (-?\d+)\.\.(-?\d+), (\d+) gaps", re.M)


def cmd_record(a):
    kills = {c: (k, r) for c, k, r in _kills(a.kills)}
    logs, failures = [], []
    for i in range(a.cycles + 1):
        base = os.path.join(a.check_dir, f"rec.{i}")
        with open(base + ".rc") as f:
            rc = [int(x) for x in f.read().split()]
        with open(base + ".check") as f:
            text = f.read()
        m = _CHECK_RAW.search(text)
        log = {"log": i, "check_exit": rc[0], "repaired": len(rc) > 1, "final_check_exit": rc[-1]}
        if m is None:
            log.update(ok=False, why="no POF_RAW events in the log")
        else:
            log.update(events=int(m[1]), first_seq=int(m[2]), last_seq=int(m[3]), gaps=int(m[4]))
            # The last log was stopped with SIGTERM: it must be clean without repair.
            clean = rc[-1] == 0 and (i < a.cycles or rc[0] == 0)
            log["ok"] = clean and log["gaps"] == 0
            if not log["ok"]:
                log["why"] = f"--check exits {rc}, {log['gaps']} sequence gaps"
        logs.append(log)
    cycles = []
    for i in range(1, a.cycles + 1):
        t_kill, t_ready = kills.get(i, (float("nan"), float("nan")))
        prev, new = logs[i - 1], logs[i]
        c = {"cycle": i, "kill_to_ready_s": round(t_ready - t_kill, 4)}
        if "last_seq" in prev and "first_seq" in new:
            lost = new["first_seq"] - prev["last_seq"] - 1
            c.update(lost_blocks=lost, lost_s=round(lost * a.block_s, 4))
            c["ok"] = prev["ok"] and new["ok"] and lost * a.block_s <= t_ready - t_kill + a.slack_s
            if not c["ok"]:
                c["why"] = (f"logs {i - 1}/{i}: {prev.get('why') or new.get('why') or ''} lost {lost} blocks "
                            f"({lost * a.block_s:.3f} s) for kill->ready {t_ready - t_kill:.3f} s")
        else:
            c.update(ok=False, why=f"log {i - 1} or {i} holds no POF_RAW")
        cycles.append(c)
    bad = [c for c in cycles if not c["ok"]]
    if bad:
        failures.append(f"{len(bad)} cycles failed, first: cycle {bad[0]['cycle']}: {bad[0]['why']}")
    if not logs[-1].get("ok"):
        failures.append(f"the last (SIGTERM) log: {logs[-1].get('why')}")
    res = {
        "part": "kill pof record", "pass": not failures and len(kills) == a.cycles, "failures": failures,
        "headline": f"{a.cycles - len(bad)}/{a.cycles} SIGKILL cycles: logs pass --check (after --repair), "
                    f"no gap within a log, loss within kill->ready + {a.slack_s} s",
        "cycles_ok": a.cycles - len(bad), "cycles_asked": a.cycles,
        "killed_logs_needing_repair": sum(1 for log in logs[:-1] if log["repaired"]),
        "kill_to_ready_s": _stats([c["kill_to_ready_s"] for c in cycles]),
        "lost_blocks": _stats([c["lost_blocks"] for c in cycles if "lost_blocks" in c]),
        "lost_s": _stats([c["lost_s"] for c in cycles if "lost_s" in c]),
        "slack_s": a.slack_s, "logs": logs, "cycles": cycles,
    }
    _write(a.out, res)


def _rss_kb(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return -1  # gone


def cmd_rss_sample(a):
    procs = [p.split("=", 1) for p in a.pid]
    t0 = time.monotonic()
    with open(a.out, "w") as f:
        f.write("t_s," + ",".join(name for name, _ in procs) + "\n")
        k = 0
        while True:
            # A sampling clock, not a wait for something to happen: sample k at t0 + k x interval.
            delay = t0 + k * a.interval - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            t = time.monotonic() - t0
            f.write(f"{t:.3f}," + ",".join(str(_rss_kb(pid)) for _, pid in procs) + "\n")
            f.flush()
            k += 1
            if t >= a.duration:
                break


def cmd_rss(a):
    with open(a.csv) as f:
        rows = list(csv.DictReader(f))
    names = [n for n in rows[0] if n != "t_s"]
    t = np.array([float(r["t_s"]) for r in rows])
    res = {"part": "rss", "failures": [], "warmup_s": a.warmup, "duration_s": round(float(t[-1]), 1),
           "samples": len(rows), "max_mb_per_h": a.max_mb_per_h, "processes": {}}
    keep = t >= a.warmup
    heads = []
    for n in names:
        kb = np.array([int(r[n]) for r in rows], dtype=float)
        p = {"first_kb": int(kb[0])}
        if (kb < 0).any():
            res["failures"].append(f"{n} exited during the RSS run (at {t[np.argmax(kb < 0)]:.0f} s)")
        tw, kw = t[keep & (kb >= 0)], kb[keep & (kb >= 0)]
        if tw.size >= 3 and tw[-1] > tw[0]:
            slope = float(np.polyfit(tw / 3600.0, kw / 1024.0, 1)[0])
            p.update(after_warmup_first_kb=int(kw[0]), last_kb=int(kw[-1]), max_kb=int(kw.max()),
                     growth_kb=int(kw[-1] - kw[0]), slope_mb_per_h=round(slope, 3),
                     growth_mb_per_h=round((kw[-1] - kw[0]) / 1024.0 / ((tw[-1] - tw[0]) / 3600.0), 3))
            if slope >= a.max_mb_per_h:
                res["failures"].append(f"{n}: RSS slope {slope:.3f} MB/h >= {a.max_mb_per_h} MB/h")
            heads.append(f"{n} {int(kw[0]) / 1024:.1f} -> {int(kw[-1]) / 1024:.1f} MB, slope {slope:+.3f} MB/h")
        else:
            res["failures"].append(f"{n}: fewer than 3 samples after the {a.warmup} s warm-up")
        res["processes"][n] = p
    res["pass"] = not res["failures"]
    res["headline"] = "; ".join(heads) or "no samples"
    _write(a.out, res)


def cmd_summary(a):
    parts = []
    for path in a.results:
        with open(path) as f:
            parts.append(json.load(f))
    ok = all(p["pass"] for p in parts) and bool(parts)
    summary = {"pass": ok, "command": a.command, "parts": {p["part"]: {k: v for k, v in p.items()
                                                                      if k not in ("cycles", "logs")}
                                                          for p in parts}}
    with open(os.path.join(a.out_dir, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
        f.write("\n")
    lines = [f"# Fault soak: {'PASS' if ok else 'FAIL'}", "", f"`{a.command}`", "",
             "| part | result | figures |", "|---|---|---|"]
    for p in parts:
        lines.append(f"| {p['part']} | {'pass' if p['pass'] else 'FAIL'} | {p['headline']} |")
    for p in parts:
        for why in p["failures"]:
            lines.append(f"\n- {p['part']}: {why}")
    text = "\n".join(lines) + "\n"
    with open(os.path.join(a.out_dir, "summary.md"), "w") as f:
        f.write(text)
    print(text)
    sys.exit(0 if ok else 1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("unplug")
    p.add_argument("report")
    p.add_argument("--cycles", type=int, required=True)
    p.add_argument("--slack-s", type=float, required=True)
    p.add_argument("--out", required=True)
    p = sub.add_parser("restarts")
    p.add_argument("stream")
    p.add_argument("kills")
    p.add_argument("--what", required=True)
    p.add_argument("--cycles", type=int, required=True)
    p.add_argument("--rate", type=float, required=True)
    p.add_argument("--slack-s", type=float, required=True)
    p.add_argument("--out", required=True)
    p = sub.add_parser("record")
    p.add_argument("check_dir")
    p.add_argument("kills")
    p.add_argument("--cycles", type=int, required=True)
    p.add_argument("--block-s", type=float, required=True)
    p.add_argument("--slack-s", type=float, required=True)
    p.add_argument("--out", required=True)
    p = sub.add_parser("rss-sample")
    p.add_argument("--pid", action="append", required=True, metavar="NAME=PID")
    p.add_argument("--interval", type=float, required=True)
    p.add_argument("--duration", type=float, required=True)
    p.add_argument("--out", required=True)
    p = sub.add_parser("rss")
    p.add_argument("csv")
    p.add_argument("--warmup", type=float, required=True)
    p.add_argument("--max-mb-per-h", type=float, required=True)
    p.add_argument("--out", required=True)
    p = sub.add_parser("summary")
    p.add_argument("results", nargs="+")
    p.add_argument("--command", required=True)
    p.add_argument("--out-dir", required=True)
    a = ap.parse_args()
    {"unplug": cmd_unplug, "restarts": cmd_restarts, "record": cmd_record, "rss-sample": cmd_rss_sample,
     "rss": cmd_rss, "summary": cmd_summary}[a.cmd](a)


if __name__ == "__main__":
    main()
