#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The cell-free layer of a run over time: `hemocosim analyze --json` over consecutive windows.

    cfl_over_time.py RUN_DIR WINDOW_S [--hemocosim PATH] [--branch NAME]

Prints, per window [t, t + WINDOW_S) of the run's snapshots, the layer by the edge and profile
measures of a tube (a periodic or open straight vessel; the edge's ± is the scatter of its
samples over their square root), or by the edge measure of one branch of a surface vessel
(`--branch parent`). What a developed
feeder is measured with (vessel.feeder_develop_s; docs/design.md, "Open ends").
"""
import argparse
import json
import os
import subprocess


def analyze(hemocosim, run_dir, t0, t1):
    out = subprocess.run([hemocosim, "analyze", run_dir, "--json", "--window-start", repr(t0), "--window-end",
                          repr(t1)], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run_dir")
    p.add_argument("window_s", type=float)
    p.add_argument("--hemocosim", default=os.path.join(os.path.dirname(__file__), "../../build/bin/hemocosim"))
    p.add_argument("--branch", default="")
    a = p.parse_args()
    end = analyze(a.hemocosim, a.run_dir, 0.0, -1)["window"]["end_s"]
    print("| window (s) | edge (um) | profile (um) |" if not a.branch else "| window (s) | edge (um) |")
    print("|---|---|---|" if not a.branch else "|---|---|")
    for k in range(int(end / a.window_s + 1e-6)):
        t = k * a.window_s
        j = analyze(a.hemocosim, a.run_dir, t, t + a.window_s)
        if a.branch:
            c = j["per_branch"][a.branch]["cfl"]
            print(f"| {t:.4g}-{t + a.window_s:.4g} | {c['thickness_m'] * 1e6:.2f} |")
        else:
            e, f = j["cfl"]["edge"], j["cfl"]["profile"]
            err = e["edge_std_m"] / max(e["samples"], 1) ** 0.5  # the edges' scatter over their samples
            print(f"| {t:.4g}-{t + a.window_s:.4g} | {e['thickness_m'] * 1e6:.2f} ± {err * 1e6:.2f} "
                  f"| {f['thickness_m'] * 1e6:.2f} |")


if __name__ == "__main__":
    main()
