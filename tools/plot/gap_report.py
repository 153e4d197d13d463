#!/usr/bin/python3
"""Plots of a `pof gap` run (called by `pof gap`; docs/gap.md).

usage: gap_report.py DIR

Reads DIR/series.csv (t_s, angle_deg, w_rad_s, v, model_baseline_v, model_final_v,
resid_baseline_deg, resid_final_deg: held-out residuals, block by block; angle_comp_before_deg,
angle_comp_after_deg: the compensator's angle with the baseline and, block by block, with the model
fitted on the other blocks) and DIR/gap.json, writes:
  residual_time.png      residual against time, before (baseline) and after (all accepted effects)
  residual_angle.png     residual against the reference angle, flexion/extension/hold coloured
  residual_velocity.png  residual against the signed angular velocity
  loops.png              measured voltage against angle with the baseline and the improved model
  gap_steps.png          held-out gap after each step
  compensated.png        the compensator's angle error against the reference, before and after the
                         found model is applied (held-out blocks), with the RMSE of each; not drawn
                         for a report written while the analysis ran (no compensated angle yet)
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

HOLD = 0.01  # rad/s, the gap workflow's hold threshold, docs/gap.md


def moving_rms(y, n):
    n = max(1, min(int(n), len(y)))
    k = np.ones(n)
    return np.sqrt(np.convolve(y * y, k, mode="same") / np.convolve(np.ones_like(y), k, mode="same"))


def colours(w):
    c = np.full(len(w), "0.6", dtype=object)
    c[w >= HOLD] = "tab:red"
    c[w <= -HOLD] = "tab:blue"
    return list(c)


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    d = Path(sys.argv[1])
    try:
        s = np.genfromtxt(d / "series.csv", delimiter=",", names=True)
        g = json.loads((d / "gap.json").read_text())
    except (OSError, ValueError) as e:
        print(f"gap_report.py: {e}", file=sys.stderr)
        return 66
    t, a, w = s["t_s"], s["angle_deg"], s["w_rad_s"]
    rb, rf = s["resid_baseline_deg"], s["resid_final_deg"]
    effects = " + ".join(st["effect"] for st in g["steps"]) or "nothing added"
    # What the baseline names itself (docs/gap.md, section 1): already in the "before" model.
    in_base = " + ".join(st["effect"] for st in g.get("in_baseline", []))
    base_label = f"baseline ({in_base} in it)" if in_base else "baseline"
    after = f"after: {effects}"
    src = Path(g.get("source", "")).name
    dt = np.median(np.diff(t)) if len(t) > 1 else 1.0
    nwin = max(1, int(round(2.0 / dt)))

    fig, ax = plt.subplots(3, 1, figsize=(12, 8), sharex=True)
    ax[0].plot(t, a, lw=0.6, color="k")
    ax[0].set_ylabel("reference angle [deg]")
    for axi, r, lab in ((ax[1], rb, "baseline"), (ax[2], rf, after)):
        axi.plot(t, r, lw=0.3, color="tab:gray", label="held-out residual")
        axi.plot(t, moving_rms(r, nwin), lw=1.0, color="tab:orange", label="2 s moving RMS")
        axi.set_ylabel("residual [deg]")
        axi.set_title(f"{lab}: held-out RMS {np.sqrt(np.mean(r * r)):.3f} deg", fontsize=9)
        axi.legend(loc="upper right", fontsize=8)
    lim = np.percentile(np.abs(rb), 99.9) * 1.1 + 1e-9
    ax[1].set_ylim(-lim, lim)
    ax[2].set_ylim(-lim, lim)
    ax[2].set_xlabel("time [s]")
    fig.suptitle(f"pof gap {src}: residual against time (positive: sensor reads more than the model)")
    fig.tight_layout()
    fig.savefig(d / "residual_time.png", dpi=90)
    plt.close(fig)

    for name, x, xl in (("residual_angle.png", a, "reference angle [deg]"),
                        ("residual_velocity.png", w, "angular velocity [rad/s] (+ flexion)")):
        fig, ax = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
        c = colours(w)
        for axi, r, lab in ((ax[0], rb, "baseline"), (ax[1], rf, after)):
            axi.scatter(x, r, s=1, c=c, alpha=0.4, rasterized=True)
            axi.set_title(f"{lab} (RMS {np.sqrt(np.mean(r * r)):.3f} deg)", fontsize=9)
            axi.set_xlabel(xl)
            axi.axhline(0, color="k", lw=0.5)
        ax[0].set_ylabel("held-out residual [deg]  (red flexion, blue extension, grey hold)")
        ax[0].set_ylim(-lim, lim)
        fig.suptitle(f"pof gap {src}")
        fig.tight_layout()
        fig.savefig(d / name, dpi=90)
        plt.close(fig)

    # The loops are a few mV wide on a 2 V span: show v minus the straight line fitted to the holds
    # (the quasi-static line f5), in mV, so the hysteresis and each effect's shape are visible.
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.8), sharey=True)
    c = colours(w)
    hold = np.abs(w) < HOLD
    coef = np.polyfit(a[hold], s["v"][hold], 1) if hold.sum() > 10 else np.polyfit(a, s["v"], 1)
    line = np.polyval(coef, a)
    ax[0].scatter(a, 1e3 * (s["v"] - line), s=1, c=c, alpha=0.4, rasterized=True)
    ax[0].set_title("measured (normalised) voltage", fontsize=9)
    ax[1].scatter(a, 1e3 * (s["model_baseline_v"] - line), s=1, c=c, alpha=0.4, rasterized=True)
    ax[1].set_title("baseline model (held-out)", fontsize=9)
    ax[2].scatter(a, 1e3 * (s["model_final_v"] - line), s=1, c=c, alpha=0.4, rasterized=True)
    ylo, yhi = np.percentile(1e3 * (s["v"] - line), [0.1, 99.9])
    ax[0].set_ylim(ylo - 0.2 * (yhi - ylo), yhi + 0.2 * (yhi - ylo))
    ax[2].set_title(f"improved model (held-out): {effects}", fontsize=9)
    for axi in ax:
        axi.set_xlabel("reference angle [deg]")
    ax[0].set_ylabel("v - quasi-static line [mV]")
    fig.suptitle(f"pof gap {src}: loops (red flexion, blue extension, grey hold)")
    fig.tight_layout()
    fig.savefig(d / "loops.png", dpi=90)
    plt.close(fig)

    labels = [base_label] + [st["effect"] for st in g["steps"]]
    gaps = [g["baseline_gap_deg"]] + [st["gap_deg"] for st in g["steps"]]
    fig, ax = plt.subplots(figsize=(max(5, 1.6 * len(labels)), 4))
    ax.bar(range(len(gaps)), gaps, color=["tab:gray"] + ["tab:green"] * (len(gaps) - 1))
    for i, v in enumerate(gaps):
        ax.text(i, v, f"{v:.3f}", ha="center", va="bottom", fontsize=9)
    ax.set_xticks(range(len(gaps)), labels, rotation=15, fontsize=8)
    ax.set_ylabel("held-out RMS gap [deg]")
    title = f"pof gap {src}: the gap after each step" + (" (structure remains)" if g["unexplained"] else "")
    if "stage" in g:  # written while the analysis ran (docs/gap.md, section 5, "Written as it goes")
        title += f"\nso far: {g['stage']}"
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(d / "gap_steps.png", dpi=90)
    plt.close(fig)

    # The loop closed: what the found model does to the angle the controller gets. A report
    # written while the analysis ran (gap.json's "stage") has no compensated angle yet: NaN.
    c = g.get("compensated", {})
    ref = s["angle_deg"]
    eb, ea = s["angle_comp_before_deg"] - ref, s["angle_comp_after_deg"] - ref
    if np.all(np.isnan(eb)):
        return 0
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.plot(t, eb, lw=0.5, color="tab:gray", label=f"baseline: RMSE {c.get('rmse_before_deg', float('nan')):.3f} deg")
    ax.plot(t, ea, lw=0.5, color="tab:green", alpha=0.8,
            label=f"with the found model: RMSE {c.get('rmse_after_deg', float('nan')):.3f} deg")
    ax.axhline(0, color="k", lw=0.5)
    lim = np.nanpercentile(np.abs(np.concatenate([eb, ea])), 99.5)
    ax.set_ylim(-1.2 * lim, 1.2 * lim)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("compensated angle - reference [deg]")
    skipped = ", not applied online: " + ", ".join(c["not_applied"]) if c.get("not_applied") else ""
    ax.set_title(f"pof gap {src}: the compensator's angle on held-out blocks{skipped}", fontsize=10)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(d / "compensated.png", dpi=90)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
