#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The fluid's Courant number of open-vessel runs against the steps when cells cross an end: per
run directory, its largest and median Courant number, the steps above 1 and 0.75, the largest in
the steps with a centre crossing an end (the particle node's inserted and left counts changed)
and the two after them, the largest elsewhere, and the smallest plasma fraction (alpha_min).

    python3 docs/scripts/courant_at_ends.py RUN_DIR [RUN_DIR ...]
"""
import collections
import csv
import sys


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for run in sys.argv[1:]:
        m = collections.defaultdict(dict)
        with open(run + "/metrics.csv") as f:
            for r in csv.DictReader(f):
                m[(r["node"], r["name"])][int(r["step"])] = float(r["value"])
        courant = m[("fluid", "courant_max")]
        alpha = m[("fluid", "alpha_min")]
        steps = sorted(s for s in courant if s > 0)

        def total(*names):
            return {s: sum(m[("particles", n)].get(s, 0) for n in names) for s in [0] + steps}

        left = total("rbc_left_outlet", "platelet_left_outlet", "rbc_left_inlet", "platelet_left_inlet")
        entered = total("rbc_inserted", "platelet_inserted")
        crossing = [s for s in steps if left[s] != left[s - 1] or entered[s] != entered[s - 1]]
        near = sorted({t for s in crossing for t in (s, s + 1, s + 2) if t in courant})
        far = [s for s in steps if s not in near]
        values = [courant[s] for s in steps]
        worst = max(steps, key=lambda s: courant[s])
        print(f"{run}: {len(steps)} steps; Courant max {courant[worst]:.3g} (step {worst}), "
              f"median {sorted(values)[len(values) // 2]:.3g}, above 1 at {sum(v > 1 for v in values)} steps, "
              f"above 0.75 at {sum(v > 0.75 for v in values)}; {len(crossing)} steps with a centre crossing an end, "
              f"max {max((courant[s] for s in near), default=float('nan')):.3g} in them and the two after, "
              f"{max((courant[s] for s in far), default=float('nan')):.3g} elsewhere; "
              f"alpha_min {min(alpha[s] for s in steps if s in alpha):.3g}; "
              f"{entered[steps[-1]]:.0f} entered, {left[steps[-1]]:.0f} left")


if __name__ == "__main__":
    main()
