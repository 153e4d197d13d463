#!/usr/bin/python3
"""Checks of tests/e2e/gap_cli.sh on `pof gap`'s gap.json for a session with hidden creep (tau 4 s):
the keys, creep found first with its time constant, and the gap at least halved by the model.

  gap_cli_check.py REPORT/gap.json
  gap_cli_check.py --applied WITH.csv WITHOUT.csv   (pof compensate --csv with and without [gap])
"""
import json
import sys


def check(ok, what):
    """Fails the test, saying what was wrong (asserts would vanish under python3 -O)."""
    if not ok:
        sys.exit(f"FAIL: {what}")


def main():
    j = json.load(open(sys.argv[1]))
    for k in ("baseline_gap_deg", "steps", "final_gap_deg", "unexplained"):
        check(k in j, f"no '{k}'")
    s = j["steps"][0]
    check(s["effect"] == "creep", f"first step: {s['effect']}")
    for k in ("effect", "gap_deg", "where", "parameters", "evidence"):
        check(k in s, f"first step has no '{k}'")
    check(abs(s["parameters"]["tau_s"] - 4.0) < 1.5, f"creep parameters {s['parameters']}")
    check(j["final_gap_deg"] <= 0.5 * j["baseline_gap_deg"],
          f"gap {j['baseline_gap_deg']} -> {j['final_gap_deg']} deg, not halved")
    c = j["compensated"]
    check(c["rmse_after_deg"] < 0.8 * c["rmse_before_deg"],
          f"compensated angle on held-out blocks {c['rmse_before_deg']} -> {c['rmse_after_deg']} deg: not 20 % lower")
    # What model.toml holds, each block's choice made on the other blocks: creep helps on every
    # block, so every block keeps it and the nested figure is the found model's.
    nested = c["model_toml_nested"]
    check(abs(nested["rmse_deg"] - c["rmse_written_deg"]) < 1e-9 and nested["rmse_deg"] < 0.8 * c["rmse_before_deg"],
          f"model.toml's nested held-out angle {nested} against written {c['rmse_written_deg']}, before {c['rmse_before_deg']}")

    # The compensated angle beside the forward gap (docs/gap.md, section 5, "Angle against the
    # forward gap"): the same two figures as the report's, and a verdict that follows the ratio.
    a = j["angle_vs_forward"]
    check(abs(a["angle_rmse_deg"] - c["rmse_after_deg"]) < 1e-9 and a["forward_gap_deg"] == j["final_gap_deg"],
          f"angle_vs_forward {a['angle_rmse_deg']} / {a['forward_gap_deg']} against compensated.rmse_after_deg "
          f"{c['rmse_after_deg']} / final_gap_deg {j['final_gap_deg']}")
    expected = ("comparable",) if a["ratio"] <= a["ratio_threshold"] else ("noise_amplification", "bias")
    check(a["verdict"] in expected, f"verdict {a['verdict']} at ratio {a['ratio']}")
    check((a["where"] is not None) == (a["verdict"] == "bias"), f"where {a['where']} with verdict {a['verdict']}")
    check(len(a["segments"]) >= 4 and abs(sum(s["share_of_scans"] for s in a["segments"]) - 1) < 1e-9,
          f"segments {a['segments']}")


def rmse(path):
    """RMS of angle_deg - angle_ref_deg over the rows where both are numbers."""
    import csv
    import math
    ss, n = 0.0, 0
    with open(path) as f:
        for row in csv.DictReader(f):
            try:
                e = float(row["angle_deg"]) - float(row["angle_ref_deg"])
            except ValueError:
                continue
            if math.isfinite(e):
                ss, n = ss + e * e, n + 1
    check(n > 0, f"{path}: no rows with an angle")
    return math.sqrt(ss / n)


def applied(with_gap, without):
    a, b = rmse(with_gap), rmse(without)
    check(a < 0.8 * b, f"pof compensate RMSE {a:.3f} deg ({with_gap}) vs {b:.3f} ({without}): not 20 % lower")


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--applied":
        applied(sys.argv[2], sys.argv[3])
    else:
        main()
