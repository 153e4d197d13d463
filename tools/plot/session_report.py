#!/usr/bin/python3
"""Plots a live session recorded by `pof record`, from CSVs written by `pof export`:
the compensated and uncompensated angles against the reference over time, the error, and the
per-cycle statistics (table 3 of Leal-Junior et al. 2017).

usage: session_report.py angles.csv stats.csv out.png [--title T]

The title gains the number of cycles in the table (the rows of stats.csv), so it cannot disagree
with the table; stats.csv '-' draws no table.
"""
import argparse
import csv
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STAT_COLUMNS = ["cycle", "velocity_rad_s", "rmse_comp_deg", "rmse_uncomp_deg", "hysteresis_comp_pct",
                "hysteresis_uncomp_pct", "max_error_deg"]
STAT_HEADS = ["cycle", "w [rad/s]", "RMSE comp [deg]", "RMSE uncomp [deg]", "H comp [%]", "H uncomp [%]",
              "max err [deg]"]


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def cycles_title(title, n):
    return f"{title}: {n} complete cycle{'' if n == 1 else 's'} on POF_STATS"


def legend_above(ax):
    # Above the axes, outside the data: inside, a legend hides whatever the session does in its
    # corner (the last cycle's peak in the demo).
    ax.legend(loc="lower left", bbox_to_anchor=(0, 1.01), ncol=3, fontsize=8, frameon=False, borderaxespad=0)


def figure(rows, stats, title):
    """The session figure: angles, error, and the table of `stats` (one row per cycle)."""
    t0 = int(rows[0]["utime"])
    t = [(int(r["utime"]) - t0) * 1e-6 for r in rows]
    comp = [float(r["angle_deg"]) for r in rows]
    unc = [float(r["angle_uncomp_deg"]) for r in rows]
    ref = [float(r["angle_ref_deg"]) for r in rows]
    flagged = [int(r["quality"]) != 0 for r in rows]

    table_h = 0.21 * (len(stats) + 1) + 0.2 if stats else 0.6  # inches: a row per cycle and the header
    fig = plt.figure(figsize=(11, 6.9 + table_h), layout="constrained")
    ax1, ax2, ax3 = fig.subplots(3, 1, gridspec_kw={"height_ratios": [3, 2, table_h]})
    ax2.sharex(ax1)
    fig.suptitle(cycles_title(title, len(stats)))
    ax1.plot(t, ref, color="black", lw=1.2, label="reference (potentiometer)")
    ax1.plot(t, unc, color="tab:orange", lw=0.8, label="POF, quasi-static line f5 only")
    ax1.plot(t, comp, color="tab:blue", lw=0.8, label="POF, compensated (the calibration's active model)")
    ax1.set_ylabel("knee angle [deg]")
    legend_above(ax1)
    ax1.grid(alpha=0.3)

    e_c = [c - r for c, r in zip(comp, ref)]
    e_u = [u - r for u, r in zip(unc, ref)]
    ax2.plot(t, e_u, color="tab:orange", lw=0.6, label="uncompensated")
    ax2.plot(t, e_c, color="tab:blue", lw=0.6, label="compensated")
    # The estimator's own error band (angle_t.angle_sigma_deg; absent in older exports, NaN when the
    # active model gives none): where the error leaves +-2 sigma, the model, not the noise, is off.
    sigma = [float(r.get("angle_sigma_deg") or "nan") for r in rows]
    if any(math.isfinite(x) for x in sigma):
        band = [2 * x if math.isfinite(x) else float("nan") for x in sigma]
        ax2.fill_between(t, [-b for b in band], band, color="tab:blue", alpha=0.2, lw=0,
                         label="estimator's +-2 sigma")
        ax1.fill_between(t, [c - b for c, b in zip(comp, band)], [c + b for c, b in zip(comp, band)],
                         color="tab:blue", alpha=0.2, lw=0)
    ft = [x for x, f in zip(t, flagged) if f]
    if ft:
        ax2.plot(ft, [0] * len(ft), "|", color="tab:red", ms=4, label="quality flag set")
    ax2.axhline(0, color="black", lw=0.5)
    ax2.set_ylabel("error vs reference [deg]")
    ax2.set_xlabel("time [s]")
    legend_above(ax2)
    ax2.grid(alpha=0.3)

    ax3.axis("off")
    if stats:
        cells = [[s["cycle"]] + [f"{float(s[c]):.3f}" for c in STAT_COLUMNS[1:]] for s in stats]
        tab = ax3.table(cellText=cells, colLabels=STAT_HEADS, loc="upper center", cellLoc="right")
        tab.auto_set_font_size(False)
        tab.set_fontsize(8)
        ax3.set_title(f"per-cycle statistics published on POF_STATS (table 3), {len(stats)} "
                      f"cycle{'' if len(stats) == 1 else 's'}", fontsize=9)
    else:
        ax3.text(0.5, 0.5, "no complete cycle in this session", ha="center", va="center")
    return fig


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("angles")
    ap.add_argument("stats")
    ap.add_argument("png")
    ap.add_argument("--title", default="pofkit live session")
    a = ap.parse_args()
    rows = read(a.angles)
    stats = read(a.stats) if a.stats != "-" else []
    if not rows:
        raise SystemExit(f"{a.angles}: no angles")
    figure(rows, stats, a.title).savefig(a.png, dpi=110)


if __name__ == "__main__":
    main()
