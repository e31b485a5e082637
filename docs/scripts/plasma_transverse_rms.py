#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The plasma's transverse velocity in a run's fluid snapshots.

    /usr/bin/python3 docs/scripts/plasma_transverse_rms.py [--from T] RUN_DIR...

The vessel's axis is z, so U_x, U_y are the cross-flow the particles' feedback stirs. For each
run, over the fluid snapshots from t = T s (default 0.02), in mm/s (the stirring of
docs/performance.md §6; history: docs/notes/performance-log.md, "what moves D at short intervals"):
  rms            sqrt<U_x^2 + U_y^2> over the cells (and per snapshot)
  grid-scale     rms of U - (mean of the cell's face neighbours), transverse part; for a field
                 uncorrelated between cells it is about the rms itself, for a smooth one small
  neighbour mean rms of that mean
  face flux      on the faces across the flow (normal within 60 deg of the section): rms of
                 phi_f/|S_f|, of the interpolated cell velocity (U_o + U_n)/2 . n, and of
                 their difference
"""
import os
import re
import sys

import numpy as np


def _list_body(path, kind):
    text = open(path).read()
    if kind is None:
        header = re.search(r"\n(\d+)\s*\n\(", text)
    else:
        header = re.search(r"internalField\s+nonuniform\s+List<" + kind + r">\s*\n(\d+)\s*\n\(", text)
    return int(header.group(1)), text[header.end():]


def cell_vectors(path):
    count, body = _list_body(path, "vector")
    rows = re.findall(r"\(([^()]+)\)", body)[:count]
    return np.array([[float(x) for x in row.split()] for row in rows])


def cell_scalars(path):
    count, body = _list_body(path, "scalar")
    return np.array(body.split(")")[0].split()[:count], dtype=float)


def mesh_labels(path):
    count, body = _list_body(path, None)
    return np.array(body.split(")")[0].split()[:count], dtype=int)


def mesh_points_faces(run):
    """The points and the faces (lists of point labels) of a run's fluid mesh."""
    mesh = f"{run}/fluid/constant/polyMesh"
    count, body = _list_body(f"{mesh}/points", None)
    points = np.array([[float(x) for x in row.split()] for row in re.findall(r"\(([^()]+)\)", body)[:count]])
    count, body = _list_body(f"{mesh}/faces", None)
    faces = [list(map(int, row.split())) for row in re.findall(r"\d+\(([^()]+)\)", body)[:count]]
    return points, faces


def internal_faces(run):
    """Owner, neighbour, unit normal and area of every internal face."""
    mesh = f"{run}/fluid/constant/polyMesh"
    points, faces = mesh_points_faces(run)
    neighbour = mesh_labels(f"{mesh}/neighbour")
    owner = mesh_labels(f"{mesh}/owner")[: len(neighbour)]
    area_vectors = np.array([0.5 * sum(np.cross(points[f[i]], points[f[(i + 1) % len(f)]]) for i in range(len(f)))
                             for f in faces[: len(neighbour)]])
    areas = np.linalg.norm(area_vectors, axis=1)
    return owner, neighbour, area_vectors / areas[:, None], areas


def snapshot_times(run):
    names = [d for d in os.listdir(f"{run}/fluid") if re.fullmatch(r"[0-9.e+-]+", d)]
    return sorted((d for d in names if float(d) > 0), key=float)


def transverse_measures(run, U, phi, faces):
    owner, neighbour, normals, areas = faces
    T = U[:, :2]
    total, count = np.zeros_like(T), np.zeros(len(T))
    np.add.at(total, owner, T[neighbour])
    np.add.at(total, neighbour, T[owner])
    np.add.at(count, owner, 1)
    np.add.at(count, neighbour, 1)
    neighbour_mean = total / count[:, None]
    across = np.abs(normals[:, 2]) < 0.5
    flux_velocity = (phi[: len(neighbour)] / areas)[across]
    cell_velocity = (0.5 * (U[owner] + U[neighbour]) * normals).sum(axis=1)[across]

    def rms(x):
        return np.sqrt(np.mean(x**2) * (x.shape[1] if x.ndim == 2 else 1))

    return [rms(T), rms(T - neighbour_mean), rms(neighbour_mean),
            rms(flux_velocity), rms(cell_velocity), rms(flux_velocity - cell_velocity)]


if __name__ == "__main__":
    args = sys.argv[1:]
    start = 0.02
    if args[:1] == ["--from"]:
        start, args = float(args[1]), args[2:]
    for run in args:
        faces = internal_faces(run)
        per_snapshot, late = [], []
        for t in snapshot_times(run):
            m = transverse_measures(run, cell_vectors(f"{run}/fluid/{t}/U"), cell_scalars(f"{run}/fluid/{t}/phi"), faces)
            per_snapshot.append(m[0] * 1e3)
            if float(t) >= start - 1e-12:
                late.append(m)
        r = np.mean(late, axis=0) * 1e3
        print(f"{run}: rms per snapshot {' '.join(f'{x:.3f}' for x in per_snapshot)}")
        print(f"  from {start:g} s: rms {r[0]:.3f}, grid-scale {r[1]:.3f}, neighbour mean {r[2]:.3f}; "
              f"face flux {r[3]:.3f}, interpolated cells {r[4]:.3f}, difference {r[5]:.3f} mm/s")
