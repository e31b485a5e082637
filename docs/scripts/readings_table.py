#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""One table of a seeded study: D, CFL thickness and mu_app/mu per configuration, mean +- standard error over seeds.

    /usr/bin/python3 docs/scripts/readings_table.py STUDY_DIR [STUDY_DIR ...] [--reference LABEL]

Runs are grouped by their label without its seed ("<config>-<shape>-s<seed>"); each run's
analysis.json is made with `hemocosim analyze` when missing. Per configuration: D (m^2/s), the
edge-method CFL thickness and mu_app/mu over the run's window, their means and standard errors,
the oblate/sphere D ratio (seeds paired), and D against the reference configuration's.
Prints a Markdown table.
"""
import argparse
import math
import os
import re
import sys
from collections import defaultdict

from run_analysis import analysis


def mean_se(values):
    n = len(values)
    if n == 0:
        return float("nan"), float("nan")
    m = sum(values) / n
    if n == 1:
        return m, float("nan")
    return m, math.sqrt(sum((v - m) ** 2 for v in values) / (n - 1) / n)


def fmt(m, se, scale=1.0, digits=2):
    if math.isnan(m):
        return "—"
    if math.isnan(se):
        return f"{m * scale:.{digits}f}"
    return f"{m * scale:.{digits}f} ± {se * scale:.{digits}f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("studies", nargs="+")
    ap.add_argument("--reference", default="ours")
    ap.add_argument("--hemocosim", default=os.path.join(os.path.dirname(__file__), "../../build/bin/hemocosim"))
    a = ap.parse_args()
    runs = defaultdict(dict)  # (config, shape) -> seed -> analysis
    failed = defaultdict(int)
    for study in a.studies:
        for name in sorted(os.listdir(os.path.join(study, "runs"))):
            m = re.fullmatch(r"\d+-(.+)-(oblate|sphere)-s(\d+)", name)
            if not m:
                continue
            run = os.path.join(study, "runs", name)
            if not os.path.exists(os.path.join(run, "study-finished.toml")):
                failed[(m.group(1), m.group(2))] += 1
                continue
            runs[(m.group(1), m.group(2))][int(m.group(3))] = analysis(run, a.hemocosim)
    configs = []
    for config, _ in runs:
        if config not in configs:
            configs.append(config)
    for config, _ in failed:
        if config not in configs:
            configs.append(config)
    ref = {seed: r["diffusion"]["D_m2_s"] for seed, r in runs.get((a.reference, "oblate"), {}).items()}
    print("| configuration | shape | seeds | D (10⁻¹¹ m²/s) | D / D(ours), paired | oblate / sphere D, paired | δ edge at 0.1 s (µm) | µ_app/µ | unfinished |")
    print("|---|---|---|---|---|---|---|---|---|")
    for config in configs:
        for shape in ("oblate", "sphere"):
            got = runs.get((config, shape), {})
            if not got and not failed.get((config, shape)):
                continue
            D = [r["diffusion"]["D_m2_s"] for r in got.values()]
            delta = [r["cfl"]["edge"]["thickness_m"] for r in got.values() if r["cfl"]["edge"].get("thickness_m") is not None]
            mu = [r["rheology"]["relative_apparent_viscosity"] for r in got.values()]
            vs_ref = [got[s]["diffusion"]["D_m2_s"] / ref[s] for s in got if s in ref] if shape == "oblate" else []
            sphere = runs.get((config, "sphere"), {})
            ratio = [got[s]["diffusion"]["D_m2_s"] / sphere[s]["diffusion"]["D_m2_s"] for s in got if s in sphere] \
                if shape == "oblate" else []
            print(f"| {config} | {shape} | {len(got)} | {fmt(*mean_se(D), 1e11)} | {fmt(*mean_se(vs_ref), 1, 3)} | "
                  f"{fmt(*mean_se(ratio), 1, 3)} | {fmt(*mean_se(delta), 1e6)} | {fmt(*mean_se(mu), 1, 3)} | "
                  f"{failed.get((config, shape), 0)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
