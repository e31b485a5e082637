#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Where a bifurcation's red cells sit across its parent: per run directory, the mean x and y of
the red cells' centres between z = 3 and 30 um (the parent's upstream part, before the junction
bends the flow) over every snapshot after the first, with the standard error over the snapshots,
and the mean over the runs given. Daughter 1 lies towards +x; y is across the bifurcation's
plane, where the vessel is mirror-symmetric, so a mean y off 0 is the inflow's.

    python3 docs/scripts/parent_offset.py RUN_DIR [RUN_DIR ...]
"""
import sys

import h5py
import numpy as np

Z_FROM, Z_TO = 3e-6, 30e-6  # m
RBC = 0                       # species id of the red cells in particles.h5


def offset(run):
    xs, ys = [], []
    with h5py.File(run + "/particles.h5", "r") as f:
        snapshots = sorted(f["snapshots"].keys())
        for key in snapshots[1:]:
            g = f["snapshots"][key]
            p, species = g["position"][:], g["species"][:]
            parent = (species == RBC) & (p[:, 2] > Z_FROM) & (p[:, 2] < Z_TO)
            xs.append(p[parent, 0].mean() * 1e6)
            ys.append(p[parent, 1].mean() * 1e6)
    xs, ys = np.array(xs), np.array(ys)
    n = len(xs)
    return xs.mean(), xs.std() / np.sqrt(n), ys.mean(), ys.std() / np.sqrt(n), n


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    means = []
    print("| run | mean x (um) | mean y (um) | snapshots |\n|---|---|---|---|")
    for run in sys.argv[1:]:
        x, ex, y, ey, n = offset(run)
        means.append((x, y))
        print(f"| {run} | {x:+.3f} ± {ex:.3f} | {y:+.3f} ± {ey:.3f} | {n} |")
    m = np.array(means)
    if len(m) > 1:
        se = m.std(axis=0) / np.sqrt(len(m))
        print(f"\nover {len(m)} runs: x {m[:, 0].mean():+.3f} ± {se[0]:.3f} um, y {m[:, 1].mean():+.3f} ± {se[1]:.3f} um")


if __name__ == "__main__":
    main()
