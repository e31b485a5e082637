#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""One Markdown table of a seeded study from its summary.csv: mean +- standard error over seeds per configuration.

    /usr/bin/python3 docs/scripts/seeded_table.py docs/study-reports/momentum/summary.csv [--reference default]

Runs are grouped by their label without its seed ("<config>-s<seed>"). Per configuration: D, the
edge-method CFL thickness, mu_app/mu, the wall's share of the driving tau_w / tau_w,imposed, the
realised wall shear rate, the discharge hematocrit, the margination index and the platelets'
axis enrichment, each as mean +- one standard error over seeds, and D against the reference
configuration's, paired by seed. Only finished runs ("ran") count.
"""
import argparse
import csv
import math
import os
import re
import sys
from collections import defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from readings_table import fmt, mean_se  # noqa: E402

COLUMNS = [  # (summary.csv column, header, scale, digits)
    ("D_m2_s", "D (10⁻¹¹ m²/s)", 1e11, 2),
    ("cfl_edge_m", "δ edge (µm)", 1e6, 2),
    ("relative_apparent_viscosity", "µ_app/µ", 1, 3),
    ("wall_shear_stress_ratio", "τ_w / τ_w,imposed", 1, 3),
    ("wall_shear_rate_per_s", "realised γ̇ (s⁻¹)", 1, 0),
    ("discharge_hematocrit", "H_D", 1, 3),
    ("margination_index", "margination", 1, 3),
    ("platelet_axis_enrichment", "axis enrichment", 1, 2),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("summary")
    ap.add_argument("--reference", default="default", help="configuration D is paired against")
    a = ap.parse_args()
    runs = defaultdict(dict)  # config -> seed -> row
    order = []
    with open(a.summary) as f:
        for row in csv.DictReader(f):
            m = re.fullmatch(r"(.+)-s(\d+)", row["label"])
            if not m or row["status"] not in ("ran", "finished earlier"):
                continue
            if m.group(1) not in order:
                order.append(m.group(1))
            runs[m.group(1)][int(m.group(2))] = row
    if a.reference not in runs:
        sys.exit(f"seeded_table: no finished runs of the reference configuration '{a.reference}'")
    ref = runs[a.reference]
    print("| configuration | seeds | " + " | ".join(h for _, h, _, _ in COLUMNS) + f" | D / D({a.reference}), paired |")
    print("|---|---|" + "---|" * len(COLUMNS) + "---|")
    for config in order:
        got = runs[config]
        cells = []
        for column, _, scale, digits in COLUMNS:
            values = [float(r[column]) for r in got.values() if r[column] not in ("", "nan")]
            cells.append(fmt(*mean_se(values), scale, digits))
        paired = [float(got[s]["D_m2_s"]) / float(ref[s]["D_m2_s"]) for s in got if s in ref]
        print(f"| {config} | {len(got)} | " + " | ".join(cells) + f" | {fmt(*mean_se(paired), 1, 3)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
