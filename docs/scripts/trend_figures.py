#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The paper's trends from the full-size studies: cell-free layer and platelet D against the
swept quantity (shear rate, hematocrit, vessel diameter).

    /usr/bin/python3 docs/scripts/trend_figures.py --out docs/figures/validation/trends.png \
        --d-rel-sd 0.042 shear-rate=docs/study-reports/former-default/shear-rate/summary.csv \
        hematocrit=docs/study-reports/former-default/hematocrit/summary.csv diameter=docs/study-reports/former-default/diameter/summary.csv

Each STUDY=SUMMARY is a `hemocosim study` summary.csv; a missing file leaves its column empty
("not run yet"). The top row is the CFL thickness (edge and profile methods, docs/model.md §5),
the bottom row D. Every point is one seed; the error bar on D is the seed-to-seed standard
deviation measured at the calibration point (--d-rel-sd, relative; docs/calibration.md: 32
seeds, SD 0.23·10⁻¹¹ of 5.46·10⁻¹¹ m²/s), applied to each single-seed value. The paper's
calibration point (δ ≈ 5.7 µm, D ≈ 2.3·10⁻¹⁰ m²/s at 799 s⁻¹, Ht 15 %, d = 100 µm) is drawn
as a star in each panel where the sweep passes through it.
"""
import argparse
import csv
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

AXES = {  # study: (swept value -> x, x label, x of the calibration point)
    "shear-rate": (lambda v: float(v), "wall shear rate γ̇ (1/s)", 799.0),
    "hematocrit": (lambda v: 100 * float(v), "hematocrit Ht (%)", 15.0),
    "diameter": (lambda v: float(v), "vessel diameter d (µm)", 100.0),
}
PAPER_DELTA_UM, PAPER_D = 5.7, 2.3e-10


def read(summary, to_x):
    rows = []
    with open(summary, newline="") as f:
        for r in csv.DictReader(f):
            if r["status"] == "failed" or not r["cfl_edge_m"]:
                continue
            rows.append((to_x(r["swept_value"]), float(r["cfl_edge_m"]) * 1e6,
                         float(r["cfl_profile_m"]) * 1e6, float(r["D_m2_s"]), float(r["end_time_s"])))
    return sorted(rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--d-rel-sd", type=float, required=True, help="seed-to-seed SD of D, relative")
    ap.add_argument("studies", nargs="+", metavar="STUDY=SUMMARY")
    a = ap.parse_args()
    studies = [s.split("=", 1) for s in a.studies]
    fig, ax = plt.subplots(2, len(studies), figsize=(4.2 * len(studies), 7), squeeze=False)
    for col, (name, summary) in enumerate(studies):
        to_x, label, x_cal = AXES[name]
        top, bottom = ax[0][col], ax[1][col]
        bottom.set_xlabel(label)
        top.set_title(name)
        if not os.path.exists(summary):
            for p in (top, bottom):
                p.text(0.5, 0.5, "not run yet", ha="center", va="center", transform=p.transAxes)
            continue
        rows = read(summary, to_x)
        x = [r[0] for r in rows]
        top.plot(x, [r[1] for r in rows], "o-", label="ours, edge")
        top.plot(x, [r[2] for r in rows], "s--", label="ours, profile")
        d = [r[3] for r in rows]
        bottom.errorbar(x, d, yerr=[a.d_rel_sd * v for v in d], fmt="o-", capsize=3, label="ours (1 seed each)")
        if min(x) <= x_cal <= max(x):
            top.plot([x_cal], [PAPER_DELTA_UM], "*", ms=14, color="k", label="paper (calibration point)")
            bottom.plot([x_cal], [PAPER_D], "*", ms=14, color="k", label="paper (calibration point)")
        short = [r[0] for r in rows if r[4] < 2.0 - 1e-9]
        if short:
            top.text(0.02, 0.02, f"ended before 2 s at {short}", transform=top.transAxes, fontsize=7)
        top.set_ylim(bottom=0)
        bottom.set_yscale("log")
        top.legend(fontsize=8)
        bottom.legend(fontsize=8)
    ax[0][0].set_ylabel("cell-free layer δ at 2 s (µm)")
    ax[1][0].set_ylabel("platelet radial D (m²/s)")
    fig.suptitle("Full-size studies, seed 1 (this 2-core machine, busy: no wall time here is a speed figure)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(a.out, dpi=110)
    print(a.out)


if __name__ == "__main__":
    main()
