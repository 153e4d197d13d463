#!/usr/bin/python3
"""Loops and effect traces of a simulated session (written by `pof sim --plot`).

usage: sim_loops.py TRACE.csv OUT.png [--title T]

TRACE.csv has the recording columns plus the simulator's per-effect contributions (EffectTrace in
daq/sim/include/pof/sim/simulator.hpp). Panels: the sensor loop (normalised voltage against the
reference angle, coloured by signed angular velocity, holds grey); the dynamic part of the voltage
against the true angle (what the paper's f1-f4 compensate); the motion; each sensor effect against
time; the light path; the potentiometer error (backlash, linearity, vibration).
"""
import argparse
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def moving_mean(y, n):
    """Centred moving average over n samples (shows slow changes under the noise)."""
    n = max(1, min(int(n), len(y)))
    k = np.ones(n)
    # Divide by the number of samples under the window so the ends are not pulled towards 0.
    return np.convolve(y, k, mode="same") / np.convolve(np.ones_like(y), k, mode="same")


def min_span(ax, centre, half):
    """Keep at least +-half around centre on ax's y axis (a flat trace is not blown up into noise)."""
    lo, hi = ax.get_ylim()
    ax.set_ylim(min(lo, centre - half), max(hi, centre + half))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("trace")
    ap.add_argument("png")
    ap.add_argument("--title", default="")
    ap.add_argument("--reference-level", type=float, default=0.0,
                    help="reference voltage at nominal source power [V] (default: median of the first second)")
    a = ap.parse_args()
    d = np.genfromtxt(a.trace, delimiter=",", names=True)
    if d.size < 2:
        print(f"{a.trace}: no data to plot", file=sys.stderr)
        return 65
    t = d["t_s"]
    ref0 = a.reference_level or np.median(d["reference_v"][: max(1, min(len(t), 200))])
    # Reference-normalised sensor voltage, v = sensor_v * level / reference_v (contract in the brief).
    vnorm = d["sensor_v"] * ref0 / d["reference_v"]
    w = d["velocity_rad_s"]
    moving = d["direction"] != 0
    step = max(1, len(t) // 80000)  # enough points for the eye, a PNG in seconds
    s = slice(None, None, step)

    fig, ax = plt.subplots(3, 2, figsize=(15, 13))
    fig.suptitle(f"pof sim: {a.title}" if a.title else "pof sim")

    vmax = max(0.05, np.nanmax(np.abs(w)))
    p = ax[0, 0]
    hold = ~moving
    p.scatter(d["angle_ref_deg"][hold][::step], vnorm[hold][::step], s=1, c="0.6", label="hold", rasterized=True)
    sc = p.scatter(d["angle_ref_deg"][moving][::step], vnorm[moving][::step], s=1, c=w[moving][::step],
                   cmap="coolwarm", vmin=-vmax, vmax=vmax, rasterized=True)
    fig.colorbar(sc, ax=p, label="angular velocity [rad/s] (+ flexion, - extension)")
    p.set_xlabel("reference angle (potentiometer) [deg]")
    p.set_ylabel("normalised sensor voltage [V]")
    p.set_title("sensor loop")
    p.legend(loc="upper right", markerscale=8)

    p = ax[0, 1]
    dyn = vnorm - d["quasi_static_v"]
    sc = p.scatter(d["angle_true_deg"][moving][::step], 1e3 * dyn[moving][::step], s=1, c=w[moving][::step],
                   cmap="coolwarm", vmin=-vmax, vmax=vmax, rasterized=True)
    fig.colorbar(sc, ax=p, label="angular velocity [rad/s]")
    p.axhline(0, color="k", lw=0.5)
    p.set_xlabel("true angle [deg]")
    p.set_ylabel("measured - quasi-static voltage [mV]")
    p.set_title("dynamic part of the response while moving (hysteresis, creep, ...)")

    p = ax[1, 0]
    p.plot(t[s], d["angle_true_deg"][s], lw=0.8, label="true angle")
    p.plot(t[s], d["angle_ref_deg"][s], lw=0.6, alpha=0.7, label="reference (pot) angle")
    p.set_xlabel("time [s]")
    p.set_ylabel("angle [deg]")
    q = p.twinx()
    q.plot(t[s], w[s], lw=0.5, color="tab:red", alpha=0.5)
    q.set_ylabel("angular velocity [rad/s]", color="tab:red")
    p.legend(loc="upper left")
    p.set_title("motion")

    p = ax[1, 1]
    for name, label in [("hysteresis_v", "hysteresis (f1-f4)"), ("rate_dependent_hysteresis_v", "extra rate-dep. hysteresis"),
                        ("creep_v", "creep (Prony memory)"), ("acceleration_v", "acceleration"),
                        ("drift_v", "drift"), ("static_nonlinearity_v", "static nonlinearity")]:
        y = d[name]
        if np.any(y != 0):
            p.plot(t[s], 1e3 * y[s], lw=0.7, label=label)
    p.set_xlabel("time [s]")
    p.set_ylabel("contribution to normalised voltage [mV]")
    p.set_title("sensor effects")
    p.legend(loc="best", fontsize=8)

    p = ax[2, 0]
    fs = 1.0 / np.median(np.diff(t))
    p.plot(t[s], d["source_power_rel"][s], lw=0.8, label="source power / nominal")
    p.plot(t[s], moving_mean(d["reference_v"] / ref0, fs)[s], lw=0.8, ls="--", label="reference_v / level (1 s mean)")
    p.set_xlabel("time [s]")
    p.set_ylabel("relative power")
    q = p.twinx()
    q.plot(t[s], 1e3 * moving_mean(vnorm - d["normalised_v"], fs)[s], lw=0.8, color="tab:green")
    q.set_ylabel("normalised - noise-free sensor voltage [mV], 1 s mean\n(uncancelled power; noise averaged out)", color="tab:green")
    min_span(p, 1.0, 0.005)
    min_span(q, 0.0, 2.0)
    p.legend(loc="upper left", fontsize=8)
    p.set_title("light path: what the reference cancels and what it does not")

    p = ax[2, 1]
    err = d["angle_ref_deg"] - d["angle_true_deg"]
    p.scatter(d["angle_true_deg"][moving][::step], err[moving][::step], s=1, c=w[moving][::step],
              cmap="coolwarm", vmin=-vmax, vmax=vmax, rasterized=True, label="moving")
    p.scatter(d["angle_true_deg"][hold][::step], err[hold][::step], s=1, c="0.5", rasterized=True, label="hold")
    p.set_xlabel("true angle [deg]")
    p.set_ylabel("reference - true angle [deg]")
    p.set_title("potentiometer error (backlash, linearity, vibration, quantisation)")
    p.legend(loc="best", markerscale=8)

    fig.tight_layout()
    fig.savefig(a.png, dpi=90)
    return 0


if __name__ == "__main__":
    sys.exit(main())
