#!/usr/bin/env python3
# Figures of `hemocosim bench`: for each suite with a reference, the errors of its runs against
# the wall time (run time against error). Reads OUT/bench.csv only; writes OUT/figures/<suite>.png
# and prints "wrote <file>" per figure.
# SPDX-License-Identifier: GPL-3.0-or-later
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ERRORS = [("err_U", "e_U (mean velocity)"), ("err_r_platelet", "e_rPLT (mean PLT r)"),
          ("err_r_rbc", "e_rRBC (mean RBC r)"), ("err_D", "e_D (platelet D)"),
          ("L1_platelet", "L1 PLT profile"), ("L1_rbc", "L1 RBC profile")]
FLOOR = 1e-6  # the reference's own error (0) is drawn here on the log axis


def num(s):
    try:
        return float(s)
    except (TypeError, ValueError):
        return None


def main(csv_path, out_dir):
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    suites = []
    for r in rows:
        if r["suite"] not in suites:
            suites.append(r["suite"])
    os.makedirs(out_dir, exist_ok=True)
    for s in suites:
        runs = [r for r in rows if r["suite"] == s and r["err_U"] != ""]
        if not runs:
            continue
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for key, label in ERRORS:
            pts = [(num(r["wall_s"]), num(r[key]), r["value"], r["reference"] == "1") for r in runs]
            pts = [p for p in pts if p[0] is not None and p[1] is not None]
            if not pts:
                continue
            line, = ax.plot([p[0] for p in pts], [max(p[1], FLOOR) for p in pts], "o", label=label, alpha=0.8)
            if key == "err_U":
                for x, y, v, ref in pts:
                    ax.annotate(v + (" (ref)" if ref else ""), (x, max(y, FLOOR)), textcoords="offset points",
                                xytext=(4, 4), fontsize=7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time of the run (s)")
        ax.set_ylabel("error against the reference (reference at %g)" % FLOOR)
        ax.set_title("%s: %s" % (s, runs[0]["key"]))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="best")
        fig.tight_layout()
        path = os.path.join(out_dir, s + ".png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        print("wrote " + path)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
