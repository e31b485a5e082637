#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""What moves the platelets in a run: radial drift by radius, orientation activity, near-axis density.

    /usr/bin/python3 docs/scripts/readings_mechanism.py RUN_DIR [RUN_DIR ...] [--window T0 T1] [--csv OUT.csv]

For each run directory (its particles.h5: /snapshots/<step> with species, position, orientation):
  - the mean radial velocity dr/dt of platelets and of red cells in five bands of r/R, from
    consecutive snapshots over the run (um/s; negative: towards the axis);
  - the platelets' mean rotation rate of the symmetry axis n between snapshots (rad/s, a lower
    bound: several turns between two snapshots count as their net angle), and the fraction of
    platelets whose axis left the start orientation by more than 60 degrees by the last snapshot;
  - the platelets' local radial diffusivity in the same bands, <(dr)^2> / (2 dt) over consecutive
    snapshots (m^2/s): where a collision-driven random walk is slower, its walkers accumulate;
  - the platelet number density within r < 0.2 R at the last snapshot over that at t = 0;
  - the plasma's own mean radial velocity U.e_r in the same bands, from the fluid node's time
    directories (cell centres from fluid/constant/polyMesh; um/s);
  - the plasma's net outward flux through the cell faces that separate the cells with centres
    inside r = 0.4, 0.6, 0.8 R from the rest, per unit area of that cylinder (um/s), once from
    the conservative face fluxes (alpha_f phi_f) and once from the cell-centre U interpolated to
    the faces (alpha_f (U_o + U_n)/2 . S_f): where the two part, the particles that sample U see
    a radial flow the plasma's volume does not make.
--window restricts everything to the snapshots and fluid times in [T0, T1] s (default: the whole
run); the near-axis density is then the last snapshot's in the window over the first's.
One line per run on stdout; --csv writes the same as a table.
"""
import argparse
import csv
import math
import os
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plasma_transverse_rms import (cell_scalars, cell_vectors, internal_faces, mesh_labels,  # noqa: E402
                                   mesh_points_faces, snapshot_times)

BANDS = [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]


def snapshots(path):
    with h5py.File(path, "r") as f:
        g = f["snapshots"]
        for step in sorted(g.keys(), key=int):
            s = g[step]
            yield (float(s.attrs["time_s"]), np.asarray(s["id"]), np.asarray(s["species"]),
                   np.asarray(s["position"]).reshape(-1, 3),
                   np.asarray(s["orientation"]).reshape(-1, 4) if "orientation" in s else None)


def axis_of(q):
    # n = R(q) e_z for unit quaternions (w, x, y, z)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=1)


def cell_centres(run):
    """Mean of each cell's face points (exact enough for banding by radius)."""
    mesh = f"{run}/fluid/constant/polyMesh"
    points, faces = mesh_points_faces(run)
    owner = mesh_labels(f"{mesh}/owner")
    neighbour = mesh_labels(f"{mesh}/neighbour")
    n_cells = int(max(owner.max(), neighbour.max())) + 1
    sums = np.zeros((n_cells, 3))
    counts = np.zeros(n_cells)
    for f, cells in enumerate(zip(owner, list(neighbour) + [-1] * (len(owner) - len(neighbour)))):
        centre = points[faces[f]].mean(axis=0)
        for c in cells:
            if c >= 0:
                sums[c] += centre
                counts[c] += 1
    return sums / counts[:, None]


WINDOW = (-math.inf, math.inf)


def in_window(t):
    return WINDOW[0] - 1e-9 <= float(t) <= WINDOW[1] + 1e-9


def plasma_drift(run, radius):
    centres = cell_centres(run)
    r = np.hypot(centres[:, 0], centres[:, 1])
    e_r = np.stack([centres[:, 0] / r, centres[:, 1] / r], axis=1)
    out = [[] for _ in BANDS[1:]]
    for t in filter(in_window, snapshot_times(run)):
        path = f"{run}/fluid/{t}/U"
        if not os.path.exists(path):
            continue
        try:
            U = cell_vectors(path)
        except (AttributeError, ValueError):
            continue
        u_r = (U[:, :2] * e_r).sum(axis=1) * 1e6
        for b in range(len(BANDS) - 1):
            m = (r / radius >= BANDS[b]) & (r / radius < BANDS[b + 1])
            if m.any():
                out[b].append(u_r[m].mean())
    return [float(np.mean(v)) if v else float("nan") for v in out]


def plasma_fluxes(run, radius, length):
    centres = cell_centres(run)
    r = np.hypot(centres[:, 0], centres[:, 1])
    owner, neighbour, normals, areas = internal_faces(run)
    out = {}
    for rho in (0.4, 0.6, 0.8):
        inside = r < rho * radius
        cross = inside[owner] != inside[neighbour]
        sign = np.where(inside[owner], 1.0, -1.0)
        cylinder = 2 * np.pi * rho * radius * length
        by_phi, by_u = [], []
        for t in filter(in_window, snapshot_times(run)):
            if not all(os.path.exists(f"{run}/fluid/{t}/{f}") for f in ("U", "alpha", "phi")):
                continue
            try:
                alpha = cell_scalars(f"{run}/fluid/{t}/alpha")
                U = cell_vectors(f"{run}/fluid/{t}/U")
                phi = cell_scalars(f"{run}/fluid/{t}/phi")[: len(neighbour)]
            except (AttributeError, ValueError):  # a uniform field (a one-way run's steady plasma): no radial flow
                continue
            alpha_f = 0.5 * (alpha[owner] + alpha[neighbour])
            by_phi.append((sign * alpha_f * phi)[cross].sum() / cylinder * 1e6)
            u_f = 0.5 * (U[owner] + U[neighbour])
            by_u.append((sign * alpha_f * (u_f * normals).sum(axis=1) * areas)[cross].sum() / cylinder * 1e6)
        out[f"plasma_outflow_{rho:.1f}R_faces_um_s"] = float(np.mean(by_phi)) if by_phi else float("nan")
        out[f"plasma_outflow_{rho:.1f}R_cell_U_um_s"] = float(np.mean(by_u)) if by_u else float("nan")
    return out


def analyse(run):
    with open(os.path.join(run, "scene.toml")) as f:
        text = f.read()
    radius = None
    for line in text.splitlines():
        if line.strip().startswith("diameter_um") and radius is None:
            radius = float(line.split("=")[1].split("#")[0]) * 0.5e-6
    snaps = [s for s in snapshots(os.path.join(run, "particles.h5")) if in_window(s[0])]
    if len(snaps) < 2:
        raise ValueError(f"fewer than two snapshots in the window {WINDOW} s")
    drift = {0: [[] for _ in BANDS[1:]], 1: [[] for _ in BANDS[1:]]}
    spread = [[] for _ in BANDS[1:]]  # platelets' (dr)^2 / (2 dt), m^2/s
    rates = []
    first_axis = None
    for (t0, id0, sp0, x0, q0), (t1, id1, sp1, x1, q1) in zip(snaps, snaps[1:]):
        assert (id0 == id1).all(), "snapshots list the particles in the same order"
        r0 = np.hypot(x0[:, 0], x0[:, 1]) / radius
        r1 = np.hypot(x1[:, 0], x1[:, 1]) / radius
        v = (r1 - r0) * radius / (t1 - t0) * 1e6  # um/s
        for species in (0, 1):
            for b in range(len(BANDS) - 1):
                m = (sp0 == species) & (r0 >= BANDS[b]) & (r0 < BANDS[b + 1])
                if m.any():
                    drift[species][b].append(v[m].mean())
                    if species == 1:
                        spread[b].append((((r1 - r0)[m] * radius) ** 2).mean() / (2 * (t1 - t0)))
        if q0 is not None and q1 is not None:
            plt = sp0 == 1
            n0, n1 = axis_of(q0[plt]), axis_of(q1[plt])
            if first_axis is None:
                first_axis = n0
            angle = np.arccos(np.clip(np.abs((n0 * n1).sum(axis=1)), 0, 1))
            rates.append(angle.mean() / (t1 - t0))
    t_first, _, sp_first, x_first, _ = snaps[0]
    t_last, _, sp_last, x_last, q_last = snaps[-1]
    near = lambda x, sp: ((np.hypot(x[:, 0], x[:, 1]) < 0.2 * radius) & (sp == 1)).sum()
    out = {"run": os.path.basename(os.path.normpath(run)), "t_end_s": t_last,
           "axis_enrichment": near(x_last, sp_last) / max(1, near(x_first, sp_first))}
    for species, name in ((1, "plt"), (0, "rbc")):
        for b in range(len(BANDS) - 1):
            vals = drift[species][b]
            out[f"{name}_drift_{BANDS[b]:.1f}_{BANDS[b + 1]:.1f}_um_s"] = float(np.mean(vals)) if vals else float("nan")
    for b in range(len(BANDS) - 1):
        out[f"plt_D_{BANDS[b]:.1f}_{BANDS[b + 1]:.1f}_m2_s"] = float(np.mean(spread[b])) if spread[b] else float("nan")
    length = None
    for line in text.splitlines():
        if line.strip().startswith("length_um") and length is None:
            length = float(line.split("=")[1].split("#")[0]) * 1e-6
    out.update(plasma_fluxes(run, radius, length))
    for b, v in enumerate(plasma_drift(run, radius)):
        out[f"plasma_ur_{BANDS[b]:.1f}_{BANDS[b + 1]:.1f}_um_s"] = v
    out["plt_axis_rate_rad_s"] = float(np.mean(rates)) if rates else float("nan")
    if first_axis is not None and q_last is not None:
        n_last = axis_of(q_last[sp_last == 1])
        out["plt_turned_60deg"] = float((np.abs((first_axis * n_last).sum(axis=1)) < 0.5).mean())
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--window", nargs=2, type=float, metavar=("T0", "T1"))
    ap.add_argument("--csv")
    a = ap.parse_args()
    if a.window:
        global WINDOW
        WINDOW = tuple(a.window)
    rows = []
    for run in a.runs:
        try:
            rows.append(analyse(run))
        except (OSError, KeyError, ValueError) as e:
            print(f"{run}: {e}", file=sys.stderr)
            continue
        print(", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in rows[-1].items()))
    if a.csv and rows:
        keys = sorted({k for r in rows for k in r}, key=lambda k: (k != "run", k))
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=keys)
            w.writeheader()
            w.writerows(rows)
    return 0 if rows else 1


if __name__ == "__main__":
    sys.exit(main())
