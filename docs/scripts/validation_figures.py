#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The validation figures in the paper's layout, from full-size runs.

    /usr/bin/python3 docs/scripts/validation_figures.py --out DIR LABEL=RUN_DIR [LABEL=RUN_DIR ...]

Writes to DIR:
  profiles.png     platelet radial number density (normalised by its vessel mean) at t = 0,
                   0.5, 1, 2 s, one panel per run (the paper's margination figure);
  msd.png          the platelets' radial MSD against time over the first 0.2 s with the D fit
                   of `hemocosim analyze` (the line 2 D t), one curve per run;
  margination.png  the fraction of platelets within 5 um of the wall against time (how fast
                   they marginate), one curve per run.
Each run needs particles.h5 (snapshots) and analysis.json (`hemocosim analyze RUN_DIR`).
"""
import argparse
import json
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

TIMES = [0.0, 0.5, 1.0, 2.0]
BINS = 25
WALL_BAND = 5e-6  # m


def snapshots(path):
    with h5py.File(path, "r") as f:
        g = f["snapshots"]
        out = []
        for step in sorted(g.keys(), key=int):
            s = g[step]
            sp = np.asarray(s["species"])
            x = np.asarray(s["position"]).reshape(-1, 3)
            out.append((float(s.attrs["time_s"]), np.hypot(x[sp == 1, 0], x[sp == 1, 1])))
        return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("runs", nargs="+", help="LABEL=RUN_DIR")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    runs = []
    for item in a.runs:
        label, run = item.split("=", 1)
        with open(os.path.join(run, "analysis.json")) as f:
            analysis = json.load(f)
        runs.append((label, run, analysis, snapshots(os.path.join(run, "particles.h5"))))

    fig, axes = plt.subplots(1, len(runs), figsize=(4 * len(runs), 3.6), sharey=True, squeeze=False)
    for ax, (label, run, analysis, snaps) in zip(axes[0], runs):
        radius = analysis["vessel"]["radius_m"]
        edges = np.linspace(0, 1, BINS + 1)
        annulus = np.pi * (edges[1:] ** 2 - edges[:-1] ** 2)
        for t in TIMES:
            best = min(snaps, key=lambda s: abs(s[0] - t))
            if abs(best[0] - t) > 0.011:
                continue
            counts, _ = np.histogram(best[1] / radius, bins=edges)
            density = counts / annulus
            ax.plot(0.5 * (edges[1:] + edges[:-1]), density / (len(best[1]) / np.pi), label=f"t = {best[0]:g} s")
        ax.set_title(label, fontsize=9)
        ax.set_xlabel("r / R")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("platelets: n / mean n")
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "profiles.png"), dpi=110)

    fig, ax = plt.subplots(figsize=(5.5, 4))
    for label, run, analysis, snaps in runs:
        r0 = snaps[0][1]
        t = np.array([s[0] for s in snaps if s[0] <= 0.2 + 1e-9])
        msd = np.array([np.mean((s[1] - r0) ** 2) for s in snaps if s[0] <= 0.2 + 1e-9])
        D = analysis["diffusion"]["D_m2_s"]
        line, = ax.plot(t, msd * 1e12, "o-", ms=3, label=f"{label}: D = {D:.3g} m²/s")
        tf = analysis["diffusion"]["t_fit_s"]
        ax.plot([0, tf], [0, 2 * D * tf * 1e12], "--", color=line.get_color(), lw=1)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("radial MSD (µm²)")
    ax.set_title("platelet radial MSD; dashed: 2 D t over the fit window", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "msd.png"), dpi=110)

    fig, ax = plt.subplots(figsize=(5.5, 4))
    for label, run, analysis, snaps in runs:
        radius = analysis["vessel"]["radius_m"]
        ax.plot([s[0] for s in snaps], [np.mean(s[1] > radius - WALL_BAND) for s in snaps], label=label)
    ax.axhline(1 - (1 - WALL_BAND / 50e-6) ** 2, color="grey", lw=0.8, ls=":", label="uniform (d = 100 µm)")
    ax.set_xlabel("t (s)")
    ax.set_ylabel(f"platelets within {WALL_BAND * 1e6:g} µm of the wall")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "margination.png"), dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
