#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The table of `hemocosim bench fluid-solvers`: per run, the fluid's cost per step and its work
(PISO correctors, p and U iterations), and the observables against the reference run.

    /usr/bin/python3 docs/scripts/fluid_solver_table.py runs/bench-fsol [--hemocosim build/bin/hemocosim]
    /usr/bin/python3 docs/scripts/fluid_solver_table.py runs/bench-fsol --seeds runs/fsol-seeds

BENCH_DIR is the bench's --out. Per run (runs/bench-fsol/fluid-solvers/runs/NN-label): from
metrics.csv the means over steps 1.. of the fluid's compute_s, its momentum and pressure phases,
piso_correctors, p_iterations (all p solves of a step), U_iterations (worst component), the
largest Courant number and continuity_error / alpha_ddt_norm; from analysis.json (made with
`hemocosim analyze` when missing: window the run's second half) the CFL thickness (edge /
profile), D and mu_app/mu; from bench.csv the wall time and e_U. Prints a Markdown table, each
observable as its difference from the reference run's in per cent.

With --seeds DIR (runs named NN-label-sSEED, the bench's scene NN-label with run.seed changed):
per label, the differences from the reference of the same seed (the bench's runs are seed 1),
mean +- standard error over the seeds, each seed's in brackets, and the fluid compute per step.
"""
import argparse
import csv
import os
import subprocess
import sys
from collections import defaultdict

from run_analysis import analysis


def fluid_means(run):
    sums, counts, largest = defaultdict(float), defaultdict(int), defaultdict(float)
    ratio = {}
    with open(os.path.join(run, "metrics.csv")) as f:
        for row in csv.DictReader(f):
            if row["node"] != "fluid" or int(row["step"]) < 1:
                continue
            name, value = row["name"], float(row["value"])
            sums[name] += value
            counts[name] += 1
            largest[name] = max(largest[name], abs(value))
            if name in ("continuity_error", "alpha_ddt_norm"):
                ratio.setdefault(int(row["step"]), {})[name] = value
    mean = {k: sums[k] / counts[k] for k in sums}
    continuity = max((r["continuity_error"] / r["alpha_ddt_norm"] for r in ratio.values()
                      if r.get("alpha_ddt_norm", 0) > 0 and "continuity_error" in r), default=float("nan"))
    return mean, largest, continuity


def pct(value, reference):
    return f"{100 * (value / reference - 1):+.1f} %"


def seeded(a, bench_runs):
    import math
    import re
    per = defaultdict(dict)  # label -> seed -> (analysis, fluid compute per step)
    for name in sorted(os.listdir(bench_runs)):
        run = os.path.join(bench_runs, name)
        if os.path.exists(os.path.join(run, "study-finished.toml")):
            per[name][1] = (analysis(run, a.hemocosim), fluid_means(run)[0]["compute_s"])
    for name in sorted(os.listdir(a.seeds)):
        m = re.fullmatch(r"(.+)-s(\d+)", name)
        run = os.path.join(a.seeds, name)
        if m and os.path.isdir(run) and os.path.exists(os.path.join(run, "metrics.csv")):
            try:
                per[m.group(1)][int(m.group(2))] = (analysis(run, a.hemocosim), fluid_means(run)[0]["compute_s"])
            except (subprocess.CalledProcessError, KeyError):
                continue
    ref_name = next(n for n in per if n.endswith("-reference"))
    ref = per[ref_name]
    # (name, value, scale and unit of the reference's own row)
    quantities = [("CFL δ edge", lambda x: x["cfl"]["edge"]["thickness_m"], 1e6, " µm"),
                  ("CFL δ profile", lambda x: x["cfl"]["profile"]["thickness_m"], 1e6, " µm"),
                  ("D", lambda x: x["diffusion"]["D_m2_s"], 1e11, "·10⁻¹¹ m²/s"),
                  ("µ_app/µ", lambda x: x["rheology"]["relative_apparent_viscosity"], 1, "")]

    def mean_se(v):
        n = len(v)
        m = sum(v) / n
        return m, (math.sqrt(sum((x - m) ** 2 for x in v) / (n - 1) / n) if n > 1 else float("nan"))

    print("| run | seeds | fluid compute per step | " + " | ".join(q[0] for q in quantities) + " |")
    print("|---|---|---|" + "---|" * len(quantities))
    for name, runs in per.items():
        seeds = sorted(s for s in runs if s in ref)
        if len(seeds) < 2:
            continue
        cost = mean_se([1e3 * runs[s][1] for s in seeds])
        cells = []
        for _, get, scale, unit in quantities:
            if name == ref_name:
                m, se = mean_se([scale * get(runs[s][0]) for s in seeds])
                cells.append(f"{m:.4g} ± {se:.2g}{unit}")
                continue
            d = [100 * (get(runs[s][0]) / get(ref[s][0]) - 1) for s in seeds]
            m, se = mean_se(d)
            cells.append(f"{m:+.1f} ± {se:.1f} % (" + ", ".join(f"{x:+.1f}" for x in d) + ")")
        print(f"| {name} | {','.join(map(str, seeds))} | {cost[0]:.2f} ± {cost[1]:.2f} ms | " + " | ".join(cells) + " |")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("bench_dir")
    p.add_argument("--suite", default="fluid-solvers")
    p.add_argument("--hemocosim", default="build/bin/hemocosim")
    p.add_argument("--seeds", help="directory of the same scenes at other seeds (NN-label-sSEED)")
    a = p.parse_args()
    if a.seeds:
        seeded(a, os.path.join(a.bench_dir, a.suite, "runs"))
        return 0
    bench = {}
    with open(os.path.join(a.bench_dir, "bench.csv")) as f:
        for row in csv.DictReader(f):
            if row["suite"] == a.suite:
                bench[os.path.basename(row["run_dir"].rstrip("/"))] = row
    runs_dir = os.path.join(a.bench_dir, a.suite, "runs")
    rows = []
    for name in sorted(os.listdir(runs_dir)):
        run = os.path.join(runs_dir, name)
        if not os.path.exists(os.path.join(run, "study-finished.toml")):
            rows.append((name, None))
            continue
        rows.append((name, (fluid_means(run), analysis(run, a.hemocosim), bench.get(name, {}))))
    ref = next(r for n, r in rows if r is not None and n.endswith("-reference"))
    (_, _, _), ref_an, _ = ref
    print("| run | fluid compute per step (momentum + pressure) | PISO correctors | p iterations | U iterations "
          "| continuity | wall (s) | e_U | CFL δ edge / profile | D | µ_app/µ |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, r in rows:
        if r is None:
            print(f"| {name} | unfinished |||||||||")
            continue
        (mean, largest, continuity), an, b = r
        edge, profile = an["cfl"]["edge"]["thickness_m"], an["cfl"]["profile"]["thickness_m"]
        D, mu = an["diffusion"]["D_m2_s"], an["rheology"]["relative_apparent_viscosity"]
        if r is ref:
            obs = (f"{edge * 1e6:.3f} / {profile * 1e6:.3f} µm | {D * 1e11:.3f}·10⁻¹¹ m²/s | {mu:.4f}")
        else:
            obs = (f"{pct(edge, ref_an['cfl']['edge']['thickness_m'])} / "
                   f"{pct(profile, ref_an['cfl']['profile']['thickness_m'])} | "
                   f"{pct(D, ref_an['diffusion']['D_m2_s'])} | "
                   f"{100 * (mu / ref_an['rheology']['relative_apparent_viscosity'] - 1):+.2f} %")
        e_u = b.get("err_U", "")
        e_u = f"{100 * float(e_u):.3f} %" if e_u not in ("", None) else "—"
        wall = b.get("wall_s", "")
        wall = f"{float(wall):.0f}" if wall not in ("", None) else "—"
        print(f"| {name} | {1e3 * mean['compute_s']:.2f} ms ({1e3 * mean['phase_fluid_momentum_s']:.2f} + "
              f"{1e3 * mean['phase_fluid_pressure_s']:.2f}) | {mean['piso_correctors']:.2f} | "
              f"{mean['p_iterations']:.1f} | {mean['U_iterations']:.1f} | {continuity:.1e} | {wall} | {e_u} | {obs} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
