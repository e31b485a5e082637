#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The phase-separation table of a bifurcation study: per run, outlet 1's shares of the blood
(F_B), red cells (F_E) and platelets over the analysis window, the standard error of F_E - F_B
from the window's intervals of analysis.json's "shares_over_time" (intervals of 5 ms against a
transit of about 20 ms: correlated, so the error is a lower bound), and the in-vivo fit's F_E at
that F_B.

    python3 docs/scripts/phase_separation_table.py STUDY_DIR
"""
import json
import math
import sys
from pathlib import Path


def row(run_dir: Path):
    j = json.loads((run_dir / "analysis.json").read_text())
    share = j["branches"]["outlet_1"]
    start, end = j["window"]["start_s"], j["window"]["end_s"]
    t = j["shares_over_time"]
    o = t["outlets"]["outlet_1"]
    diffs = [e - b for s, f, e, b in zip(t["start_s"], t["end_s"], o["rbc_fraction"], o["blood_fraction"])
             if s >= start - 1e-12 and f <= end + 1e-12]
    n = len(diffs)
    mean = sum(diffs) / n
    sem = math.sqrt(sum((d - mean) ** 2 for d in diffs) / (n - 1) / n) if n > 1 else float("nan")
    return (run_dir.name, share["blood_fraction"], share["rbc_fraction"], share["platelet_fraction"],
            share["rbc_fraction"] - share["blood_fraction"], sem, n)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    runs = sorted(p for p in (Path(sys.argv[1]) / "runs").iterdir() if (p / "analysis.json").exists())
    print("| run | F_B | F_E | F_P | F_E - F_B | ± (intervals) |")
    print("|---|---|---|---|---|---|")
    for r in runs:
        name, fb, fe, fp, d, sem, n = row(r)
        print(f"| {name} | {fb:.3f} | {fe:.3f} | {fp:.3f} | {d:+.3f} | {sem:.3f} ({n}) |")


if __name__ == "__main__":
    main()
