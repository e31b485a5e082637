#!/usr/bin/env python3
# hemocosim plot: the paper-style figures of one or more analysed runs, as PNG.
# SPDX-License-Identifier: GPL-3.0-or-later
#
# `hemocosim plot` runs this script after making sure every run directory holds the files of
# `hemocosim analyze` (analysis.json, profiles.csv); it can also be run by hand:
#
#   python3 hemocosim_plot.py --out DIR [--key scene.key] [--labels a,b,...] [--xlabel TEXT] RUN_DIR [RUN_DIR ...]
#
# Per run:    <run>_profiles.png  radial number density of RBCs and platelets at t = 0, 0.5, 1, 2 s
#                                 (or at 0, 1/4, 1/2, 1 of a shorter run: the snapshots nearest)
#             <run>_msd.png       radial MSD of the platelets with the fitted line MSD = 2 D t
#             <run>_balance.png   the momentum balance: tau_w / tau_w,imposed over time, with the band
#                                 in which it holds and the averaging window (when the fluid reported tau_w)
#             <run>_axial.png     a vessel shape that narrows: along the axis, the wall R(z) with the RBC
#                                 core's edge R - CFL, the hematocrit, the platelets near the wall and
#                                 their arrivals at it (analysis.json "axial")
# A surface vessel's run (a bifurcation) has no radial profiles; instead:
#             <run>_phase_separation.png  each outlet's share of the blood, the red cells and the
#                                 platelets over the run, and each species' share against the blood's
#                                 (the phase-separation points; the diagonal: no separation)
#                                 (analysis.json "shares_over_time", "branches")
#             <run>_branches.png  per branch: the cell-free layer along it, the discharge hematocrit
#                                 and the platelet flux through its end (analysis.json "per_branch")
# Several:    sweep.png           the observables analysis.json declares for it (CFL thickness by the
#                                 edge and profile methods, D, mu_app/mu) against the swept scene
#                                 key (--key, or the one key whose value differs)
#             compare_profiles.png, compare_msd.png: the runs' window-mean profiles and MSD overlaid
#                                 (of tube runs only: a surface run has neither)
#
# Reads only analysis.json, profiles.csv and scene.toml (no HDF5): the observables are computed
# once, by `hemocosim analyze` (docs/model.md §5), never here.
import argparse
import csv
import json
import math
import os
import sys

os.environ.setdefault("MPLBACKEND", "Agg")  # headless: never needs a display

try:
    import tomllib  # Python >= 3.11
except ImportError:  # pragma: no cover - Debian 12 has 3.11
    tomllib = None

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
except ImportError as e:  # one clear line, the C++ side checks this too
    sys.exit(f"hemocosim plot: error: {e.name} is not installed (Debian: apt-get install python3-matplotlib python3-numpy)")

UM = 1e-6
PER_UL = 1e-9  # 1/m^3 -> 1/ul
PAPER_TIMES = [0.0, 0.5, 1.0, 2.0]  # s, the paper's profile snapshots


def fail(msg):
    sys.exit(f"hemocosim plot: error: {msg}")


class Run:
    """One analysed run directory: its analysis, its profiles and its scene."""

    def __init__(self, path):
        self.path = path.rstrip("/") or path
        self.name = os.path.basename(os.path.abspath(self.path))
        for f in ("analysis.json", "profiles.csv"):
            if not os.path.isfile(os.path.join(path, f)):
                fail(f"{os.path.join(path, f)}: missing (run `hemocosim analyze {path}` first)")
        with open(os.path.join(path, "analysis.json")) as f:
            self.a = json.load(f)
        self.scene = {}
        scene_path = os.path.join(path, "scene.toml")
        if tomllib is not None and os.path.isfile(scene_path):
            with open(scene_path, "rb") as f:
                self.scene = tomllib.load(f)
        self.mean = None  # (t0, t1, r_mid_over_R, rbc, plt, rbc_fraction)
        self.frames = []
        self.surface = bool(self.get("vessel", "surface"))
        if self.surface:
            return  # no tube: no radial profiles
        frames = {}
        with open(os.path.join(path, "profiles.csv")) as f:
            rows = list(csv.DictReader(f))
        if not rows:
            fail(f"{os.path.join(path, 'profiles.csv')}: no profiles (no snapshots?)")
        blocks = {}
        for row in rows:
            key = (float(row["t_start_s"]), float(row["t_end_s"]))
            blocks.setdefault(key, []).append(row)
        first = next(iter(blocks.values()))
        self.r_in = np.array([float(r["r_inner_m"]) for r in first])
        self.r_out = np.array([float(r["r_outer_m"]) for r in first])
        for (t0, t1), block in blocks.items():
            x = np.array([float(r["r_mid_over_R"]) for r in block])
            rbc = np.array([float(r["rbc_per_m3"]) for r in block])
            plt_ = np.array([float(r["platelet_per_m3"]) for r in block])
            if t1 > t0:
                phi = np.array([float(r["rbc_volume_fraction"] or "nan") for r in block])
                self.mean = (t0, t1, x, rbc, plt_, phi)
            else:
                frames[t0] = (x, rbc, plt_)
        self.frames = sorted(frames.items())  # [(t, (x, rbc, plt))]

    def scene_value(self, dotted):
        node = self.scene
        for part in dotted.split("."):
            if not isinstance(node, dict) or part not in node:
                return None
            node = node[part]
        return node

    def get(self, *path):
        node = self.a
        for p in path:
            if node is None:
                return None
            node = node.get(p) if isinstance(node, dict) else None
        return node


def num(v):
    return float("nan") if v is None else float(v)


def pick_frames(frames):
    """The snapshots nearest the paper's t = 0, 0.5, 1, 2 s, or 0, 1/4, 1/2, 1 of a shorter run."""
    if not frames:
        return []
    times = [t for t, _ in frames]
    t0, t1 = times[0], times[-1]
    targets = PAPER_TIMES if t1 - t0 >= PAPER_TIMES[-1] * 0.99 else [t0 + f * (t1 - t0) for f in (0, 0.25, 0.5, 1)]
    chosen = []
    for target in targets:
        i = min(range(len(times)), key=lambda k: abs(times[k] - target))
        if i not in chosen:
            chosen.append(i)
    return [frames[i] for i in sorted(chosen)]


def time_label(t):
    return f"t = {t:.3g} s"


def cfl_edge_over_R(run):
    delta = run.get("cfl", "edge", "thickness_m")
    radius = run.get("vessel", "radius_m")
    if delta is None or not radius:
        return None
    return 1 - delta / radius


# Few cells in many bins make a profile of noise: the figure merges neighbouring bins (number
# densities weighted by annulus volume, so the merged profile is exact) until a bin holds about
# this many cells of a snapshot on average. A calibration-size run keeps analyze's bins.
# At least MIN_BINS bins are kept, however few the cells.
CELLS_PER_BIN = 15
MIN_BINS = 10


def merge_factor(count, bins):
    if not count or count <= 0:
        return 1
    k = int(math.ceil(bins / max(count / CELLS_PER_BIN, 1)))
    return max(1, min(k, bins // MIN_BINS))


def rebin(run, density, k):
    """(r/R at the merged bins' middles, merged densities) for groups of k bins."""
    if k <= 1:
        return (run.r_in + run.r_out) / 2 / run.r_out[-1], density
    vol = run.r_out**2 - run.r_in**2  # proportional to the annulus volume
    xs, ns = [], []
    for s in range(0, len(density), k):
        e = min(s + k, len(density))
        xs.append((run.r_in[s] + run.r_out[e - 1]) / 2 / run.r_out[-1])
        ns.append(np.sum(density[s:e] * vol[s:e]) / np.sum(vol[s:e]))
    return np.array(xs), np.array(ns)


def plot_profiles(run, out):
    chosen = pick_frames(run.frames)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    colours = plt.cm.viridis(np.linspace(0, 0.9, max(len(chosen), 1)))
    counts = (run.get("window", "mean_rbc_count"), run.get("window", "mean_platelet_count"))
    for ax, idx, title, count in ((axes[0], 1, "RBC", counts[0]), (axes[1], 2, "platelets", counts[1])):
        k = merge_factor(count, len(run.r_in))
        for colour, (t, data) in zip(colours, chosen):
            x, n = rebin(run, data[idx], k)
            ax.plot(x, n * PER_UL, "-o", ms=2.5, lw=1.2, color=colour, label=time_label(t))
        if run.mean is not None:
            t0, t1 = run.mean[0], run.mean[1]
            x, n = rebin(run, run.mean[idx + 2], k)
            ax.plot(x, n * PER_UL, "k--", lw=1.2, label=f"mean over {t0:.3g}..{t1:.3g} s")
        nb = len(range(0, len(run.r_in), k))
        title += f" ({nb} bins" + (f", {k} of analyze's merged" if k > 1 else "") + ")"
        edge = cfl_edge_over_R(run)
        if edge is not None:
            ax.axvline(edge, color="tab:red", ls=":", lw=1, label="RBC core edge (edge method)")
        ax.set_xlabel("r / R")
        ax.set_ylabel("number density (1/µl)")
        ax.set_title(title)
        ax.set_xlim(0, 1)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.suptitle(f"{run.name}: radial number density")
    fig.savefig(out, dpi=120)
    plt.close(fig)


def msd_points(run):
    pts = run.get("diffusion", "msd") or []
    lag = np.array([num(p.get("lag_s")) for p in pts])
    msd = np.array([num(p.get("msd_m2")) for p in pts])
    ok = np.isfinite(lag) & np.isfinite(msd)
    return lag[ok], msd[ok]


def d_label(run):
    d = run.get("diffusion", "D_m2_s")
    if d is None:
        return "no D (no MSD point in the fit window)"
    end = num(run.get("diffusion", "window_end_s"))
    n = run.get("diffusion", "points")
    return f"D = {d:.3g} m²/s (MSD = 2Dt over [0, {end:.3g}] s, {n} points)"


def plot_msd(run, out):
    lag, msd = msd_points(run)
    fig, ax = plt.subplots(figsize=(6, 4), constrained_layout=True)
    ax.plot(lag, msd / UM**2, "o", ms=3, label="platelets, radial MSD")
    d = run.get("diffusion", "D_m2_s")
    if d is not None and len(lag):
        end = num(run.get("diffusion", "window_end_s"))
        t = np.linspace(0, end, 50)
        ax.plot(t, 2 * d * t / UM**2, "-", color="tab:red", label=d_label(run))
        ax.axvspan(0, end, color="tab:red", alpha=0.06)
    else:
        ax.text(0.05, 0.9, d_label(run), transform=ax.transAxes)
    ax.set_xlabel("lag t (s)")
    ax.set_ylabel("MSD of r (µm²)")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"{run.name}: platelet radial MSD")
    fig.savefig(out, dpi=120)
    plt.close(fig)


def balance_points(run):
    series = run.get("momentum_balance", "over_time") or {}
    t = np.array([num(v) for v in series.get("time_s", [])])
    ratio = np.array([num(v) for v in series.get("ratio", [])])
    ok = np.isfinite(t) & np.isfinite(ratio)
    return t[ok], ratio[ok]


def plot_balance(run, out):
    t, ratio = balance_points(run)
    mesh = num(run.get("momentum_balance", "mesh_ratio"))
    tol = num(run.get("momentum_balance", "tolerance"))
    fig, ax = plt.subplots(figsize=(6, 4), constrained_layout=True)
    if math.isfinite(mesh) and math.isfinite(tol):
        ax.axhspan(mesh * (1 - tol), 1 + tol, color="tab:green", alpha=0.12,
                   label=f"holds: [{mesh * (1 - tol):.3f}, {1 + tol:.3f}]")
        ax.axhline(mesh, color="tab:green", lw=1, ls="--", label=f"exact balance on this mesh ({mesh:.3f})")
    ax.axhline(1, color="k", lw=0.8, ls=":")
    ax.plot(t, ratio, "-", lw=1.2, color="tab:blue", label="τ_w / τ_w,imposed")
    t0, t1 = num(run.get("momentum_balance", "window_start_s")), num(run.get("momentum_balance", "window_end_s"))
    mean = num(run.get("momentum_balance", "ratio"))
    if math.isfinite(mean):
        ax.plot([t0, t1], [mean, mean], "-", lw=2, color="tab:red", label=f"window mean {mean:.3f}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("τ_w / τ_w,imposed")
    ax.set_xlim(left=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"{run.name}: momentum balance, wall shear stress over d ΔP / (4 l)")
    fig.savefig(out, dpi=120)
    plt.close(fig)


def plot_axial(run, out):
    ax_ = run.get("axial")
    z = np.array([num(v) for v in ax_["z_m"]]) * 1e6
    R = np.array([num(v) for v in ax_["radius_m"]]) * 1e6
    cfl = np.array([num(v) for v in ax_["cfl_m"]]) * 1e6
    fig, axes = plt.subplots(4, 1, figsize=(7, 9), sharex=True, constrained_layout=True)
    axes[0].plot(z, R, "k-", lw=1.5, label="wall R(z)")
    axes[0].plot(z, R - cfl, "o-", color="tab:red", ms=3, label="RBC core edge R - δ")
    axes[0].set_ylabel("r (µm)")
    axes[0].set_ylim(bottom=0)
    axes[0].legend(fontsize=8)
    axes[1].plot(z, [num(v) for v in ax_["hematocrit"]], "o-", color="tab:red", ms=3)
    axes[1].set_ylabel("hematocrit")
    axes[2].plot(z, [num(v) * 1e-6 for v in ax_["platelet_near_wall_per_m2"]], "o-", color="tab:blue", ms=3)
    axes[2].set_ylabel("platelets near wall\n(1/mm²)")
    axes[3].plot(z, [num(v) * 1e-6 for v in ax_["wall_contact_rate_per_m2_s"]], "o-", color="tab:blue", ms=3)
    axes[3].set_ylabel("wall arrivals\n(1/(mm² s))")
    axes[3].set_xlabel("z (µm)")
    for a in axes:
        a.grid(alpha=0.3)
    axes[0].set_title(f"{run.name}: along the vessel ({run.get('vessel', 'shape')})")
    fig.savefig(out, dpi=120)
    plt.close(fig)


# The species of an outlet's shares (analysis.json "branches", "shares_over_time"), as drawn.
SPECIES = (("blood_fraction", "blood", "-", "s"), ("rbc_fraction", "RBC", "--", "o"),
           ("platelet_fraction", "platelets", ":", "^"))


def plot_phase_separation(run, out):
    over = run.get("shares_over_time") or {}
    t = (np.array([num(v) for v in over.get("start_s", [])]) + np.array([num(v) for v in over.get("end_s", [])])) / 2
    outlets = sorted(set(over.get("outlets", {})) | set(run.get("branches") or {}))
    colours = dict(zip(outlets, plt.cm.tab10(np.arange(len(outlets)))))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    for outlet in outlets:
        series = (over.get("outlets") or {}).get(outlet, {})
        for key, species, style, _ in SPECIES:
            values = np.array([num(v) for v in series.get(key, [])])
            if len(values) == len(t) and len(t):
                axes[0].plot(t * 1e3, values, style, lw=1.3, color=colours[outlet], label=f"{outlet}, {species}")
        blood = np.array([num(v) for v in series.get("blood_fraction", [])])
        for key, species, _, marker in SPECIES[1:]:
            values = np.array([num(v) for v in series.get(key, [])])
            if len(values) == len(blood) and len(blood):
                axes[1].plot(blood, values, marker, ms=3.5, alpha=0.45, color=colours[outlet], ls="none")
        mean = (run.get("branches") or {}).get(outlet)
        if mean:
            for key, species, _, marker in SPECIES[1:]:
                axes[1].plot(num(mean.get("blood_fraction")), num(mean.get(key)), marker, ms=10, mec="k",
                             color=colours[outlet], ls="none", label=f"{outlet}, {species} (window mean)")
    axes[0].set_xlabel("t (ms), each interval's middle")
    axes[0].set_ylabel("share of what leaves through the outlets")
    axes[0].set_ylim(0, 1)
    axes[0].set_title("each outlet's shares over the run")
    axes[1].plot([0, 1], [0, 1], "k-", lw=0.8, label="no separation")
    axes[1].set_xlim(0, 1)
    axes[1].set_ylim(0, 1)
    axes[1].set_aspect("equal")
    axes[1].set_xlabel("blood flow fraction")
    axes[1].set_ylabel("flux fraction (RBC: o, platelets: ^)")
    axes[1].set_title("phase separation: small points per interval")
    for a in axes:
        a.grid(alpha=0.3)
        if a.get_legend_handles_labels()[0]:
            a.legend(fontsize=7)
    fig.suptitle(f"{run.name}: flux fractions at the outlets ({run.get('vessel', 'shape')})")
    fig.savefig(out, dpi=120)
    plt.close(fig)


def plot_branches(run, out):
    branches = run.get("per_branch") or {}
    names = list(branches)
    # Along the vessel from the inlet: the parent from its inlet, a daughter from the junction.
    parent_length = num((branches.get("parent") or {}).get("axis_length_m"))
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), constrained_layout=True,
                             gridspec_kw={"width_ratios": [2, 1, 1]})
    for i, name in enumerate(names):
        b = branches[name]
        cfl = b.get("cfl") or {}
        st = cfl.get("stations") or {}
        offset = 0 if name == "parent" else parent_length
        s = (np.array([num(v) for v in st.get("s_m", [])]) + offset) / UM
        delta = np.array([num(v) for v in st.get("thickness_m", [])]) / UM
        colour = plt.cm.tab10(i)
        axes[0].plot(s, delta, "-o", ms=4, color=colour, label=f"{name} (R = {num(b.get('radius_m')) / UM:.1f} µm)")
        whole = num(cfl.get("thickness_m"))
        if math.isfinite(whole):
            span = (np.array([num(cfl.get("span_start_m")), num(cfl.get("span_end_m"))]) + offset) / UM
            axes[0].plot(span, [whole / UM] * 2, "--", lw=1, color=colour)
    axes[0].set_xlabel("distance along the branch's axis (µm; a daughter's from the junction at the parent's end)")
    axes[0].set_ylabel("cell-free layer δ (µm)")
    axes[0].set_ylim(bottom=0)
    axes[0].set_title("δ per slice of each branch's own sections (dashed: over the branch)")
    x = np.arange(len(names))
    hd = [num(branches[n].get("discharge_hematocrit")) for n in names]
    axes[1].bar(x, hd, color=[plt.cm.tab10(i) for i in x])
    axes[1].set_ylabel("discharge hematocrit H_D")
    axes[1].set_title("H_D per branch")
    rate = [num(branches[n].get("platelets_per_s")) for n in names]
    axes[2].bar(x, rate, color=[plt.cm.tab10(i) for i in x])
    for xi, n in zip(x, names):
        density = num(branches[n].get("discharge_platelet_density_per_m3"))
        if math.isfinite(density):
            axes[2].annotate(f"{density * PER_UL:.3g}/µl", (xi, 0), xytext=(0, 3), textcoords="offset points",
                             ha="center", fontsize=7)
    axes[2].set_ylabel("platelets per second")
    axes[2].set_title("platelet flux per branch")
    for a in axes[1:]:
        a.set_xticks(x)
        a.set_xticklabels([f"{n}\n({branches[n].get('end')})" for n in names], fontsize=8)
    for a in axes:
        a.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{run.name}: along each branch (window {num(run.get('window', 'start_s')):.3g}.."
                 f"{num(run.get('window', 'end_s')):.3g} s)")
    fig.savefig(out, dpi=120)
    plt.close(fig)


def flatten(table, prefix=""):
    out = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def guess_key(runs):
    """The one scene key (outside [run]) whose value differs between the runs, if there is one."""
    flat = [flatten(r.scene) for r in runs]
    keys = set().union(*flat)
    differing = sorted(k for k in keys if not k.startswith("run.") and len({repr(f.get(k)) for f in flat}) > 1)
    return differing[0] if len(differing) == 1 else None


def sweep_axis(runs, key, labels):
    """x positions, tick labels and the axis title of the sweep figure."""
    values = [r.scene_value(key) for r in runs] if key else [None] * len(runs)
    numeric = key is not None and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    if numeric:
        return [float(v) for v in values], None, key
    ticks = labels or [str(v) if v is not None else r.name for v, r in zip(values, runs)]
    return list(range(len(runs))), ticks, key or "run"


def sweep_panels(runs):
    """The sweep figure's panels as analysis.json declares them ("observables", from
    postprocess/analysis/observable_table.cpp): [(y-axis title, scientific, [observable, ...])]."""
    declared = runs[0].get("observables")
    if not declared:
        fail(f"{runs[0].path}/analysis.json declares no observables (written by an older hemocosim): "
             "run `hemocosim analyze` on it again")
    panels = {}
    for o in declared:
        if o.get("sweep_panel"):
            panels.setdefault(o["sweep_panel"], []).append(o)
    out = []
    for title, members in panels.items():
        unit = members[0].get("shown_unit")
        out.append((f"{title} ({unit})" if unit else title,
                    any(m.get("shown_style") == "scientific" for m in members), members))
    return out


def plot_sweep(runs, key, labels, out, xlabel=None):
    x, ticks, title = sweep_axis(runs, key, labels)
    title = xlabel or title
    order = sorted(range(len(runs)), key=lambda i: x[i])
    xs = [x[i] for i in order]
    panels = sweep_panels(runs)
    fig, axes = plt.subplots(1, len(panels), figsize=(14 * len(panels) / 3, 4), constrained_layout=True, squeeze=False)
    for ax, (ylabel, scientific, members) in zip(axes[0], panels):
        for o in members:
            ys = [num(runs[i].get(*o["path"].split("."))) / o.get("shown_scale", 1) for i in order]
            ax.plot(xs, ys, "-o", ms=4, label=o.get("sweep_series") or o["label"])
        ax.set_xlabel(title)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if ticks is not None:
            ax.set_xticks(xs)
            ax.set_xticklabels([ticks[i] for i in order], rotation=20)
        if len(members) > 1:
            ax.legend(fontsize=8)
        if scientific:
            ax.ticklabel_format(axis="y", style="sci", scilimits=(0, 0))
        else:
            ax.ticklabel_format(axis="y", useOffset=False)
    fig.suptitle(f"observables against {title} ({len(runs)} runs)")
    fig.savefig(out, dpi=120)
    plt.close(fig)


def run_labels(runs, key, labels):
    if labels:
        return labels
    if key:
        return [f"{key.split('.')[-1]} = {r.scene_value(key)}" for r in runs]
    return [r.name for r in runs]


def plot_compare_profiles(runs, names, out):
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for run, name in zip(runs, names):
        if run.mean is not None:
            x, rbc, plt_ = run.mean[2], run.mean[3], run.mean[4]
            suffix = f" ({run.mean[0]:.3g}..{run.mean[1]:.3g} s)"
        elif run.frames:
            t, (x, rbc, plt_) = run.frames[-1]
            suffix = f" (t = {t:.3g} s)"
        else:
            continue
        # Normalised by the species' mean density so that runs of other sizes compare.
        counts = (run.get("window", "mean_rbc_count"), run.get("window", "mean_platelet_count"))
        for ax, n, count in ((axes[0], rbc, counts[0]), (axes[1], plt_, counts[1])):
            vol = run.r_out**2 - run.r_in**2
            mean = np.sum(n * vol) / np.sum(vol) if np.sum(vol) > 0 else 0
            xm, nm = rebin(run, n, merge_factor(count, len(run.r_in)))
            ax.plot(xm, nm / mean if mean > 0 else nm * 0, "-", lw=1.3, label=name + suffix)
    for ax, title in zip(axes, ("RBC", "platelets")):
        ax.set_xlabel("r / R")
        ax.set_ylabel("n / n̄ (window mean)")
        ax.set_title(title)
        ax.set_xlim(0, 1)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7)
    fig.suptitle("radial number density, normalised by the mean over the vessel")
    fig.savefig(out, dpi=120)
    plt.close(fig)


def plot_compare_msd(runs, names, out):
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    for run, name in zip(runs, names):
        lag, msd = msd_points(run)
        d = run.get("diffusion", "D_m2_s")
        label = name + (f": D = {d:.3g} m²/s" if d is not None else ": no D")
        ax.plot(lag, msd / UM**2, "-o", ms=2.5, lw=1, label=label)
    ax.set_xlabel("lag t (s)")
    ax.set_ylabel("MSD of r (µm²)")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title("platelet radial MSD")
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description="Paper-style figures of analysed hemocosim runs (PNG)")
    p.add_argument("runs", nargs="+", help="run directories holding analysis.json and profiles.csv")
    p.add_argument("--out", required=True, help="directory for the PNG files")
    p.add_argument("--key", help="the swept scene key, dotted (default: the one key that differs)")
    p.add_argument("--labels", help="comma-separated names of the runs, in order")
    p.add_argument("--xlabel", help="title of the swept axis (default: the key)")
    args = p.parse_args()

    for d in args.runs:
        if not os.path.isdir(d):
            fail(f"{d}: no such run directory")
    runs = [Run(d) for d in args.runs]
    labels = args.labels.split(",") if args.labels else None
    if labels and len(labels) != len(runs):
        fail(f"--labels names {len(labels)} runs, {len(runs)} given")
    os.makedirs(args.out, exist_ok=True)

    # Per-run file names from the directory names, numbered when two runs share one.
    names = [r.name for r in runs]
    stems = [f"{i + 1:02d}-{n}" if names.count(n) > 1 else n for i, n in enumerate(names)]
    written = []
    for run, stem in zip(runs, stems):
        if run.surface:
            figures = (("phase_separation", plot_phase_separation, run.get("branches") or run.get("shares_over_time")),
                       ("branches", plot_branches, run.get("per_branch")))
        else:
            figures = (("profiles", plot_profiles, True), ("msd", plot_msd, True),
                       ("balance", plot_balance, len(balance_points(run)[0])),  # the fluid reported tau_w
                       ("axial", plot_axial, run.get("axial") is not None))  # a vessel that narrows
        for kind, draw, drawn in figures:
            if not drawn:
                continue
            path = os.path.join(args.out, f"{stem}_{kind}.png")
            draw(run, path)
            written.append(path)
    if len(runs) > 1 and not any(r.surface for r in runs):
        key = args.key or guess_key(runs)
        names = run_labels(runs, key, labels)
        for fname, draw in (("sweep.png", lambda o: plot_sweep(runs, key, labels, o, args.xlabel)),
                            ("compare_profiles.png", lambda o: plot_compare_profiles(runs, names, o)),
                            ("compare_msd.png", lambda o: plot_compare_msd(runs, names, o))):
            path = os.path.join(args.out, fname)
            draw(path)
            written.append(path)
    for w in written:
        print(w)


if __name__ == "__main__":
    main()
