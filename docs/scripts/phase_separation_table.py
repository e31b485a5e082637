#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The phase-separation table of a bifurcation study: per run, outlet 1's shares of the blood
(F_B), red cells (F_E) and platelets over the analysis window, the standard error of F_E - F_B
from the window's intervals of analysis.json's "shares_over_time" (intervals of 5 ms against a
transit of about 20 ms: correlated, so the error is a lower bound), and the in-vivo fit's F_E at
that F_B. With several study directories (the same study run with other seeds), one table per
directory and then one of the runs of the same name over the seeds: the means, and the standard
error of F_E - F_B over the seeds beside the intervals' (the intervals' errors combined).

    python3 docs/scripts/phase_separation_table.py STUDY_DIR [STUDY_DIR ...]
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
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    by_name = {}
    for study in sys.argv[1:]:
        runs = sorted(p for p in (Path(study) / "runs").iterdir() if (p / "analysis.json").exists())
        print(f"{study}:\n")
        print("| run | F_B | F_E | F_P | F_E - F_B | ± (intervals) |")
        print("|---|---|---|---|---|---|")
        for r in runs:
            name, fb, fe, fp, d, sem, n = row(r)
            by_name.setdefault(name, []).append((fb, fe, fp, d, sem, n))
            print(f"| {name} | {fb:.3f} | {fe:.3f} | {fp:.3f} | {d:+.3f} | {sem:.3f} ({n}) |")
        print()
    if len(sys.argv) < 3:
        return
    print("Over the seeds:\n")
    print("| run | seeds | F_B | F_E | F_P | F_E - F_B | ± (seeds) | ± (intervals) |")
    print("|---|---|---|---|---|---|---|---|")
    for name, rows in sorted(by_name.items()):
        k = len(rows)
        mean = [sum(r[i] for r in rows) / k for i in range(4)]
        seeds = math.sqrt(sum((r[3] - mean[3]) ** 2 for r in rows) / (k - 1) / k) if k > 1 else float("nan")
        intervals = math.sqrt(sum(r[4] ** 2 for r in rows)) / k
        print(f"| {name} | {k} | {mean[0]:.3f} | {mean[1]:.3f} | {mean[2]:.3f} | {mean[3]:+.3f} | {seeds:.3f} | "
              f"{intervals:.3f} |")


if __name__ == "__main__":
    main()
