#!/usr/bin/python3
"""Plots of a `pof calibrate --report DIR` run (Leal-Junior et al. 2017 figures 6, 7, 10/11, 12).

Reads DIR/calibration.json and DIR/compensated.csv (written by pof calibrate) and writes:
  fig6_quasi_static.png  hold averages, the quasi-static line f5 and its residuals (fig. 6)
  fig7_regressions.png   f1 (hysteresis vs velocity), f3 per velocity, f2 (a_x, b_x vs h) (fig. 7)
  loops.png              flexion/extension loops of each velocity test (figs. 10/11): sensor angle
                         against reference angle, before and after compensation, one colour per
                         velocity; below, the same loops minus the reference angle
  error_vs_angle.png     mean |error| in 5 deg bins of the reference angle, before and after (fig. 12)
  dynamic_loop.png       the dynamic model: fitted forward voltage against the measured one, as a
                         loop (minus the quasi-static polynomial) against the reference angle
  heldout_error.png      both models' error on held-out blocks against angle and against time
                         (each block predicted by models fitted without it)
The paper draws fig. 12 on validation data. A report has none, so when DIR/dynamic.csv
holds both models' held-out angles (written when the dynamic model was fitted and scored) loops.png
and error_vs_angle.png draw those; otherwise they draw the calibration applied to its own recording
(in-sample). Each figure's title says which. The dynamic figures need DIR/dynamic.csv.
Run with /usr/bin/python3 (Debian's matplotlib). Usage: calibration_report.py DIR
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
import numpy as np  # noqa: E402


def load_csv(path):
    cols = {"t_s": [], "angle_deg": [], "angle_uncomp_deg": [], "angle_ref_deg": [], "velocity_rad_s": [], "phase": []}
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
        idx = {name: header.index(name) for name in cols}
        for line in f:
            p = line.rstrip("\n").split(",")
            for name, i in idx.items():
                cols[name].append(p[i] if name == "phase" else float(p[i]))
    out = {k: np.asarray(v, dtype=float) for k, v in cols.items() if k != "phase"}
    out["phase"] = np.asarray(cols["phase"])
    return out


def fig6(rep):
    qs = rep["quasi_static"]
    a = np.asarray(qs["hold_angle_deg"])
    v = np.asarray(qs["hold_v"])
    fit = qs["v_of_angle"]
    # Constrained layout and a residual panel half the main one's height: at 3:1 the residual
    # panel was barely taller than its y label, which overran it.
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(6.4, 6.8), sharex=True, layout="constrained",
                                  gridspec_kw={"height_ratios": [2, 1]})
    xs = np.linspace(min(a.min(), 0), max(a.max(), 90), 100)
    ax.plot(a, v, "o", color="tab:blue", label="hold averages (settled part)")
    ax.plot(xs, fit["slope"] * xs + fit["intercept"], "-", color="tab:red",
            label=f"f5: alpha = {-qs['c9']:.4f} V + {qs['c10']:.3f}")
    ax.set_ylabel("normalised sensor voltage [V]")
    ax.set_title(f"Quasi-static test (fig. 6): sensitivity {qs['sensitivity_v_per_deg']:.4f} V/deg, "
                 f"R$^2$ {qs['linearity_r2']:.5f}", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    axr.axhline(0, color="0.5", lw=0.8)
    axr.plot(a, np.asarray(qs["residuals_deg"]), "o", color="tab:blue", ms=4)
    axr.set_xlabel("reference angle [deg]")
    axr.set_ylabel("f5 residual [deg]")
    axr.grid(alpha=0.3)
    fig.align_ylabels([ax, axr])
    return fig


def fig7(rep):
    tests = rep["velocity_tests"]
    w = np.array([t["velocity_rad_s"] for t in tests])
    h = np.array([t["hysteresis_pct"] for t in tests])
    f1 = rep["f1"]
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.6))
    ax = axs[0]
    ws = np.linspace(0, w.max() * 1.1, 200)
    ax.plot(w, h, "o", color="tab:purple", label="eq. (1) per velocity")
    ax.plot(ws, f1["c1"] * np.exp(f1["c2"] * ws), "-", color="k",
            label=f"f1: h = {f1['c1']:.3f} exp({f1['c2']:.3f} w)")
    ax.set_xlabel("angular velocity w [rad/s]")
    ax.set_ylabel("hysteresis h [%]")
    ax.set_title(f"f1, R$^2$ {f1['r2']:.4f}", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)

    ax = axs[1]
    qs = rep["quasi_static"]
    vlo, vhi = min(qs["hold_v"]), max(qs["hold_v"])
    vv = np.linspace(vlo, vhi, 50)
    for t, c in zip(tests, velocity_colours(len(tests))):  # the colours loops.png gives the velocities
        ax.plot(vv, t["f3_flexion"]["slope"] * vv + t["f3_flexion"]["intercept"] - vv, "-", color=c, lw=1.2,
                label=f"{t['velocity_rad_s']:.4f} rad/s")
        ax.plot(vv, t["f3_extension"]["slope"] * vv + t["f3_extension"]["intercept"] - vv, "--", color=c, lw=1.2)
    ax.set_xlabel("measured voltage V$_{meas}$ [V]")
    ax.set_ylabel("V$_{qs}$ - V$_{meas}$ [V]  (f3 regression minus identity)")
    ax.set_title("f3 per velocity: solid flexion, dashed extension", fontsize=10)
    ax.legend(fontsize=6, ncol=2)
    ax.grid(alpha=0.3)

    ax = axs[2]
    hf = np.array([t["f1_pct"] for t in tests])
    f2 = rep["f2"]
    hs = np.linspace(hf.min() * 0.95, hf.max() * 1.05, 50)
    af = [t["f3_flexion"]["slope"] for t in tests]
    ae = [t["f3_extension"]["slope"] for t in tests]
    bf = [t["f3_flexion"]["intercept"] for t in tests]
    be = [t["f3_extension"]["intercept"] for t in tests]
    ax.plot(hf, af, "o", color="tab:red", label="a$_f$")
    ax.plot(hf, ae, "s", color="tab:blue", label="a$_e$")
    ax.plot(hs, f2["a_flexion"]["slope"] * hs + f2["a_flexion"]["intercept"], "-", color="tab:red")
    ax.plot(hs, f2["a_extension"]["slope"] * hs + f2["a_extension"]["intercept"], "-", color="tab:blue")
    ax.set_xlabel("hysteresis f1(w) [%]")
    ax.set_ylabel("a$_x$ [-]")
    ax2 = ax.twinx()
    ax2.plot(hf, bf, "^", color="tab:orange", label="b$_f$")
    ax2.plot(hf, be, "v", color="tab:green", label="b$_e$")
    ax2.plot(hs, f2["b_flexion"]["slope"] * hs + f2["b_flexion"]["intercept"], "--", color="tab:orange")
    ax2.plot(hs, f2["b_extension"]["slope"] * hs + f2["b_extension"]["intercept"], "--", color="tab:green")
    ax2.set_ylabel("b$_x$ [V]")
    lines = ax.get_legend_handles_labels()
    lines2 = ax2.get_legend_handles_labels()
    ax.legend(lines[0] + lines2[0], lines[1] + lines2[1], fontsize=8, loc="upper center",
              bbox_to_anchor=(0.5, -0.13), ncol=4, frameon=False)
    ax.set_title("f2: regression terms against hysteresis (fig. 7b)", fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


# CalibrationSettings::velocity_tolerance (calibration.hpp) groups sweeps within 8 % of the slowest
# one into a velocity test, so every sweep of a test lies within ~8 % of the test's mean speed.
VELOCITY_TOLERANCE = 0.09


def test_sweeps(rep):
    """[(velocity_rad_s, [segment, ...]) per velocity test]: each test's sweeps picked from the
    report's segments as the calibration grouped them: moving segments within the grouping tolerance
    of the test's mean speed, the test's n_flexion_sweeps longest flexions and n_extension_sweeps
    longest extensions (the protocol's 5 deg quasi-static steps can share a test's speed, never its
    sweep length)."""
    segs = [s for s in rep.get("segments", []) if s["kind"] in ("flexion", "extension")]
    out = []
    for t in rep.get("velocity_tests", []):
        w = t["velocity_rad_s"]
        picked = []
        for kind, n in (("flexion", t["n_flexion_sweeps"]), ("extension", t["n_extension_sweeps"])):
            near = [s for s in segs
                    if s["kind"] == kind and w > 0 and abs(abs(s["velocity_rad_s"]) / w - 1) <= VELOCITY_TOLERANCE]
            near.sort(key=lambda s: -abs(s["angle_end_deg"] - s["angle_begin_deg"]))
            picked += near[:n]
        out.append((w, sorted(picked, key=lambda s: s["t_begin_s"])))
    return out


def velocity_colours(n):
    # viridis up to 0.9: its last tenth is too pale to read on white.
    cmap = plt.get_cmap("viridis")
    return [cmap(0.9 * i / max(1, n - 1)) for i in range(n)]


def held_out_angles(d, dyn, rep):
    """Both models' held-out angles aligned with compensated.csv, or None. dynamic.csv and
    compensated.csv are both one row per scan of the calibration recording."""
    if dyn is None or "heldout_paper_deg" not in dyn or len(dyn["t_s"]) != len(d["t_s"]):
        return None
    if not np.allclose(dyn["t_s"], d["t_s"], rtol=0, atol=1e-5):
        return None
    h = rep.get("dynamic", {}).get("held_out", {})
    if not h.get("folds_used"):
        return None
    return {"paper": dyn["heldout_paper_deg"], "dynamic": dyn["heldout_dynamic_deg"], "folds": int(h["folds_used"])}


def held_out_caption(folds):
    return (f"held-out: the calibration recording cut into {folds} blocks, each predicted by models "
            "fitted without it")


def sensor_angles(d, held):
    """(label, sensor angle per scan) for each panel: before (the f5 line, always fitted on this
    recording's holds) and after, preferring the held-out predictions over the in-sample ones."""
    panels = [("before: quasi-static line f5 only (in-sample)", d["angle_uncomp_deg"])]
    if held is not None:
        panels += [("after: eq. (11)/(12), held-out", held["paper"]),
                   ("after: dynamic model, held-out", held["dynamic"])]
    else:
        panels += [("after: eq. (11)/(12), in-sample", d["angle_deg"])]
    return panels


def loops(d, rep, held):
    """Figs. 10/11 of the paper: sensor angle against reference angle over each velocity test's
    flexion and extension sweeps (top), and the same loops minus the reference (bottom), where a
    1-2 deg loop over 90 deg becomes visible."""
    tests = test_sweeps(rep)
    colours = velocity_colours(len(tests))
    panels = sensor_angles(d, held)
    t, ref = d["t_s"], d["angle_ref_deg"]
    fig = plt.figure(figsize=(5.0 * len(panels) + 2.2, 8.6), layout="constrained")
    gs = fig.add_gridspec(2, len(panels) + 1, width_ratios=[1] * len(panels) + [0.38])
    axs = []
    for r in range(2):  # one y scale per row, so the panels compare
        first = fig.add_subplot(gs[r, 0])
        axs.append([first] + [fig.add_subplot(gs[r, c], sharey=first) for c in range(1, len(panels))])
    for c, (title, angle) in enumerate(panels):
        top, bottom = axs[0][c], axs[1][c]
        sq, n = 0.0, 0
        for (w, sweeps), colour in zip(tests, colours):
            for s in sweeps:
                i0, i1 = np.searchsorted(t, [s["t_begin_s"], s["t_end_s"]], side="left")
                i1 = min(i1 + 1, len(t))
                step = max(1, (i1 - i0) // 600)
                sl = slice(i0, i1, step)
                style = "-" if s["kind"] == "flexion" else "--"
                top.plot(ref[sl], angle[sl], style, color=colour, lw=0.9)
                bottom.plot(ref[sl], (angle - ref)[sl], style, color=colour, lw=0.9)
                e = (angle - ref)[i0:i1]
                e = e[np.isfinite(e)]
                sq += float(np.sum(e * e))
                n += e.size
        lo, hi = np.nanmin(ref), np.nanmax(ref)
        top.plot([lo, hi], [lo, hi], color="k", lw=0.6, zorder=0)
        bottom.axhline(0, color="k", lw=0.6, zorder=0)
        rmse = f"\nRMSE {np.sqrt(sq / n):.3f} deg over the sweeps drawn" if n else ""
        top.set_title(title + rmse, fontsize=10)
        top.set_ylabel("sensor angle [deg]")
        bottom.set_ylabel("sensor angle - reference angle [deg]")
        top.set_xlabel("reference angle [deg]")
        bottom.set_xlabel("reference angle [deg]")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    if not tests:
        axs[0][0].text(0.5, 0.5, "no velocity test in the recording", transform=axs[0][0].transAxes, ha="center")
    lax = fig.add_subplot(gs[:, -1])
    lax.axis("off")
    handles = [Line2D([], [], color=c, lw=2) for c in colours]
    labels = [f"{w:.4f} rad/s" for w, _ in tests]
    handles += [Line2D([], [], color="k", ls="-"), Line2D([], [], color="k", ls="--"), Line2D([], [], color="k", lw=0.6)]
    labels += ["flexion", "extension", "sensor = reference"]
    lax.legend(handles, labels, loc="center left", fontsize=8, title="velocity test", title_fontsize=9, frameon=False)
    where = (held_out_caption(held["folds"]) + "; f5 fitted on the whole recording's holds" if held is not None
             else "on the calibration recording (in-sample): the model is applied to the data it was fitted on")
    fig.suptitle("Flexion/extension loops per velocity test (figs. 10/11 of Leal-Junior et al. 2017)\n" + where,
                 fontsize=11)
    return fig


def binned_abs_error(ref, err, moving):
    """Mean |err| in the 5 deg bins of the reference angle that ErrorProfile (statistics.hpp) uses:
    18 bins over 0-90 deg, moving scans only."""
    b = np.floor(ref / 5.0)
    ok = moving & np.isfinite(err) & np.isfinite(b) & (b >= 0) & (b < 18)
    centres, means = [], []
    for k in range(18):
        m = ok & (b == k)
        if m.any():
            centres.append((k + 0.5) * 5.0)
            means.append(float(np.mean(np.abs(err[m]))))
    return np.array(centres), np.array(means)


def error_vs_angle(d, rep, held):
    """Fig. 12 of the paper (there on validation data): mean |error| against the reference angle.
    Held-out predictions when the report has them, else the in-sample self-check, said in the title."""
    fig, ax = plt.subplots(figsize=(8, 4.8), layout="constrained")
    moving = d["phase"] != "hold"
    ref = d["angle_ref_deg"]
    if held is not None:
        bars = [("uncompensated (f5, in-sample)", d["angle_uncomp_deg"], "0.6"),
                ("eq. (11)/(12), held-out", held["paper"], "tab:red"),
                ("dynamic model, held-out", held["dynamic"], "tab:blue")]
        series = [(label, *binned_abs_error(ref, a - ref, moving), colour) for label, a, colour in bars]
        where = held_out_caption(held["folds"])
    else:
        prof = rep.get("self_check", {}).get("error_profile", [])
        a = np.array([p["angle_deg"] for p in prof])
        series = [("uncompensated (f5)", a, np.array([p["mean_abs_error_uncomp_deg"] for p in prof]), "0.6"),
                  ("compensated (eq. 11/12)", a, np.array([p["mean_abs_error_comp_deg"] for p in prof]), "tab:red")]
        where = "on the calibration recording (in-sample): the model is applied to the data it was fitted on"
    width = 4.4 / len(series)
    for k, (label, a, e, colour) in enumerate(series):
        if len(a):
            ax.bar(a + (k - (len(series) - 1) / 2) * width, e, width=width, color=colour, label=label)
    if any(len(a) for _, a, _, _ in series):
        ax.legend(fontsize=8)
    ax.set_xlabel("reference angle [deg] (5 deg bins)")
    ax.set_ylabel("mean |error| over moving scans [deg]")
    ax.set_title("Error against angle (fig. 12 of Leal-Junior et al. 2017)\n" + where, fontsize=10)
    ax.grid(alpha=0.3, axis="y")
    return fig


def load_dynamic(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: np.asarray(data[name], dtype=float) for name in data.dtype.names}


def dynamic_loop(dyn, rep):
    d = rep["dynamic"]
    poly = np.asarray(d["poly"])
    a = dyn["angle_ref_deg"]
    ok = np.isfinite(a) & np.isfinite(dyn["v_meas"])
    # q(x) of the fitted model, the line both loops are drawn around (x = (a - centre) / scale).
    centre, scale = d["angle_centre_deg"], d["angle_scale_deg"]
    q = np.polyval(poly[::-1], (a - centre) / scale)
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.6))
    step = max(1, int(ok.sum() // 20000))
    idx = np.flatnonzero(ok)[::step]
    ax[0].plot(a[idx], (dyn["v_meas"] - q)[idx] * 1e3, ",", color="0.5", label="measured")
    ax[0].plot(a[idx], (dyn["v_dynamic"] - q)[idx] * 1e3, ",", color="tab:red", label="dynamic model")
    ax[0].set_xlabel("reference angle [deg]")
    ax[0].set_ylabel("V minus quasi-static polynomial [mV]")
    ax[0].set_title("loop: measured (grey) and fitted dynamic model (red)")
    t = dyn["t_s"]
    ax[1].plot(t[idx], (dyn["v_meas"] - dyn["v_dynamic"])[idx] * 1e3, ",", color="k")
    ax[1].set_xlabel("time [s]")
    ax[1].set_ylabel("measured minus model [mV]")
    ax[1].set_title(f"fit residual (train RMSE {d['train_rmse_deg']:.3f} deg)")
    fig.tight_layout()
    return fig


def heldout_error(dyn, rep):
    h = rep["dynamic"].get("held_out")
    a, t = dyn["angle_ref_deg"], dyn["t_s"]
    ep = dyn["heldout_paper_deg"] - a
    ed = dyn["heldout_dynamic_deg"] - a
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.6))
    for e, name, color in ((ep, "paper", "tab:blue"), (ed, "dynamic", "tab:red")):
        ok = np.isfinite(e)
        label = name
        if h:
            label += f" (RMSE {h[name]['rmse_deg']:.3f}, p99 {h[name]['p99_abs_deg']:.2f} deg)"
        ax[0].plot(a[ok], e[ok], ",", color=color, alpha=0.6)
        ax[1].plot(t[ok], e[ok], lw=0.5, color=color, label=label)
    ax[0].set_xlabel("reference angle [deg]")
    ax[0].set_ylabel("error on held-out blocks [deg]")
    ax[0].set_title("held-out error against angle (blue paper, red dynamic)")
    ax[1].set_xlabel("time [s]")
    ax[1].set_ylabel("error on held-out blocks [deg]")
    ax[1].set_title("held-out error against time")
    ax[1].legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    return fig


def figures(out):
    """{png name: Figure} of the report in DIR `out` (the tests inspect these)."""
    with open(os.path.join(out, "calibration.json"), encoding="utf-8") as f:
        rep = json.load(f)
    d = load_csv(os.path.join(out, "compensated.csv"))
    dyn_path = os.path.join(out, "dynamic.csv")
    dyn = load_dynamic(dyn_path) if "poly" in rep.get("dynamic", {}) and os.path.exists(dyn_path) else None
    held = held_out_angles(d, dyn, rep)
    figs = {"fig6_quasi_static.png": fig6(rep), "fig7_regressions.png": fig7(rep),
            "loops.png": loops(d, rep, held), "error_vs_angle.png": error_vs_angle(d, rep, held)}
    if dyn is not None:
        figs["dynamic_loop.png"] = dynamic_loop(dyn, rep)
        figs["heldout_error.png"] = heldout_error(dyn, rep)
    return figs


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = sys.argv[1]
    try:
        figs = figures(out)
    except (OSError, ValueError, KeyError) as e:
        print(f"calibration_report.py: {e}", file=sys.stderr)
        return 65
    for name, fig in figs.items():
        fig.savefig(os.path.join(out, name), dpi=110)
        plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
