#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The plasma's transverse velocity in a run's fluid snapshots.

    /usr/bin/python3 docs/scripts/plasma_transverse_rms.py RUN_DIR...

For every time directory of RUN_DIR/fluid (after t = 0) prints sqrt(<U_x^2 + U_y^2>) over the
cells (mm/s; the vessel's axis is z, so this is the cross-flow stirring the particles' feedback
drives), then its mean from t = 0.02 s (docs/performance.md, "what moves D at short intervals").
"""
import os
import re
import sys

import numpy as np

VECTOR_FIELD = re.compile(r"internalField\s+nonuniform\s+List<vector>\s*\n(\d+)\s*\n\(")


def cell_vectors(path):
    text = open(path).read()
    header = VECTOR_FIELD.search(text)
    count = int(header.group(1))
    rows = re.findall(r"\(([^()]+)\)", text[header.end():])[:count]
    return np.array([[float(x) for x in row.split()] for row in rows])


def snapshot_times(run):
    names = [d for d in os.listdir(f"{run}/fluid") if re.fullmatch(r"[0-9.e+-]+", d)]
    return sorted((d for d in names if float(d) > 0), key=float)


if __name__ == "__main__":
    for run in sys.argv[1:]:
        series = []
        for t in snapshot_times(run):
            U = cell_vectors(f"{run}/fluid/{t}/U")
            series.append((float(t), np.sqrt(np.mean(U[:, 0] ** 2 + U[:, 1] ** 2)) * 1e3))
        late = [rms for t, rms in series if t >= 0.02]
        print(f"{run}: {' '.join(f'{rms:.3f}' for _, rms in series)}  mean from 0.02 s: {np.mean(late):.3f} mm/s")
