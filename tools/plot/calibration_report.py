#!/usr/bin/python3
"""Plots of a `pof calibrate --report DIR` run (Leal-Junior et al. 2017 figures 6, 7 and 12).

Reads DIR/calibration.json and DIR/compensated.csv (written by pof calibrate) and writes:
  fig6_quasi_static.png  hold averages, the quasi-static line f5 and its residuals (fig. 6)
  fig7_regressions.png   f1 (hysteresis vs velocity), f3 per velocity, f2 (a_x, b_x vs h) (fig. 7)
  loops.png              sensor angle vs reference angle, before and after compensation
  error_vs_angle.png     error against the reference angle, before and after (fig. 12)
  dynamic_loop.png       the dynamic model: fitted forward voltage against the measured one, as a
                         loop (minus the quasi-static polynomial) against the reference angle
  heldout_error.png      both models' error on held-out blocks against angle and against time
                         (each block predicted by models fitted without it)
The dynamic figures need DIR/dynamic.csv (written when the dynamic model was fitted).
Run with /usr/bin/python3 (Debian's matplotlib). Usage: calibration_report.py DIR
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

COLORS = {"flexion": "tab:red", "extension": "tab:blue", "hold": "0.6"}


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


def fig6(rep, out):
    qs = rep["quasi_static"]
    a = np.asarray(qs["hold_angle_deg"])
    v = np.asarray(qs["hold_v"])
    fit = qs["v_of_angle"]
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(6.4, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
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
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig6_quasi_static.png"), dpi=110)
    plt.close(fig)


def fig7(rep, out):
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
    cmap = plt.get_cmap("viridis")
    for i, t in enumerate(tests):
        c = cmap(i / max(1, len(tests) - 1))
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
    fig.savefig(os.path.join(out, "fig7_regressions.png"), dpi=110)
    plt.close(fig)


def loops(d, rep, out):
    moving = d["phase"] != "hold"
    fig, axs = plt.subplots(1, 2, figsize=(12, 5.2), sharex=True, sharey=True)
    stats = rep.get("self_check", {}).get("overall", {})
    for ax, key, title, hk, rk in ((axs[0], "angle_uncomp_deg", "before: quasi-static line f5 only", "hysteresis_uncomp_pct", "rmse_uncomp_deg"),
                                   (axs[1], "angle_deg", "after: eq. (11)/(12)", "hysteresis_comp_pct", "rmse_comp_deg")):
        for ph in ("flexion", "extension"):
            m = d["phase"] == ph
            step = max(1, int(m.sum() / 20000))
            ax.plot(d["angle_ref_deg"][m][::step], (d[key] - d["angle_ref_deg"])[m][::step], ".", ms=1.2,
                    color=COLORS[ph], label=ph)
        ax.axhline(0, color="k", lw=0.8)
        h = stats.get(hk)
        r = stats.get(rk)
        extra = f"\nRMSE {r:.3f} deg, hysteresis {h:.2f} % (eq. 1, mean of cycles)" if h is not None and r is not None else ""
        ax.set_title(title + extra, fontsize=10)
        ax.set_xlabel("reference angle [deg]")
        ax.grid(alpha=0.3)
        ax.legend(markerscale=8, fontsize=8)
    axs[0].set_ylabel("sensor angle - reference angle [deg]")
    if not moving.any():
        axs[0].text(0.5, 0.5, "no movement in the recording", transform=axs[0].transAxes, ha="center")
    fig.suptitle("Flexion/extension loops of the calibration recording (moving scans)", fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "loops.png"), dpi=110)
    plt.close(fig)


def error_vs_angle(rep, out):
    prof = rep.get("self_check", {}).get("error_profile", [])
    fig, ax = plt.subplots(figsize=(7, 4.6))
    if prof:
        a = np.array([p["angle_deg"] for p in prof])
        ax.bar(a - 1.1, [p["mean_abs_error_uncomp_deg"] for p in prof], width=2.2, color="0.6", label="uncompensated (f5)")
        ax.bar(a + 1.1, [p["mean_abs_error_comp_deg"] for p in prof], width=2.2, color="tab:red", label="compensated (eq. 11/12)")
        ax.legend(fontsize=8)
    ax.set_xlabel("reference angle [deg] (5 deg bins)")
    ax.set_ylabel("mean |error| [deg]")
    ax.set_title("Error against angle over all moving scans (fig. 12)", fontsize=10)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "error_vs_angle.png"), dpi=110)
    plt.close(fig)


def load_dynamic(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: np.asarray(data[name], dtype=float) for name in data.dtype.names}


def dynamic_loop(dyn, rep, out):
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
    fig.savefig(os.path.join(out, "dynamic_loop.png"), dpi=110)
    plt.close(fig)


def heldout_error(dyn, rep, out):
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
    fig.savefig(os.path.join(out, "heldout_error.png"), dpi=110)
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = sys.argv[1]
    try:
        with open(os.path.join(out, "calibration.json"), encoding="utf-8") as f:
            rep = json.load(f)
        d = load_csv(os.path.join(out, "compensated.csv"))
    except (OSError, ValueError, KeyError) as e:
        print(f"calibration_report.py: {e}", file=sys.stderr)
        return 65
    fig6(rep, out)
    fig7(rep, out)
    loops(d, rep, out)
    error_vs_angle(rep, out)
    dyn_path = os.path.join(out, "dynamic.csv")
    if "poly" in rep.get("dynamic", {}) and os.path.exists(dyn_path):
        dyn = load_dynamic(dyn_path)
        dynamic_loop(dyn, rep, out)
        heldout_error(dyn, rep, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
