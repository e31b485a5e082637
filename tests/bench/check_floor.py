#!/usr/bin/env python3
# ctest bench.floor: runs `hemocosim bench tests/bench/floor.toml` (the DEM against bare LIGGGHTS on
# the base scene's particles in two vessel sizes, fresh output directory) and checks bench.csv:
# both runs finished; our DEM, its callback and bare LIGGGHTS have positive finite costs per
# particle-step; the bare run read every particle and built its lists; the larger vessel has more
# particles; ours rebuilt its lists in the streaming frame, bare LIGGGHTS ran once with its own
# policy and once with ours, and ours built fewer lists per 1000 DEM steps than bare LIGGGHTS's own;
# bench.md has the floor table. Then that a floor suite with a reference is refused in one line.
# Usage: check_floor.py HEMOCOSIM SUITE OUT_DIR
# SPDX-License-Identifier: GPL-3.0-or-later
import json
import math
import os
import subprocess
import sys

from bench_harness import fail, run_bench


def positive(row, key):
    v = row[key]
    if v == "" or not math.isfinite(float(v)) or float(v) <= 0:
        fail("run %s: %s = '%s' is not a positive number" % (row["value"], key, v))
    return float(v)


def main(hemocosim, suite, out):
    rows = run_bench(hemocosim, suite, out)
    if [x["value"] for x in rows] != ["50", "70"]:
        fail("expected the rows 50 and 70, got %s" % [x["value"] for x in rows])
    particles = []
    for row in rows:
        if row["status"] != "ok":
            fail("run %s: status %s (%s)" % (row["value"], row["status"], row["message"]))
        dem = positive(row, "dem_ns_per_particle_step")
        callback = positive(row, "callback_ns")
        bare = positive(row, "bare_liggghts_ns")
        positive(row, "one_run_ns")
        positive(row, "particle_peak_MiB")
        if callback >= dem:
            fail("run %s: the callback (%g ns) is not a part of the DEM (%g ns)" % (row["value"], callback, dem))
        positive(row, "dem_over_bare")
        with open(os.path.join(row["run_dir"], "dem-bench.json")) as f:
            j = json.load(f)
        particles.append(j["particles"])
        if j["bare_liggghts"]["particles"] != j["particles"]:
            fail("run %s: bare LIGGGHTS read %d of the %d particles" % (row["value"], j["bare_liggghts"]["particles"],
                                                                       j["particles"]))
        if j["bare_liggghts"]["neighbour_builds"] < 1:
            fail("run %s: bare LIGGGHTS built no neighbour list" % row["value"])
        if j["neighbour_rebuild"] != "streaming" or "bare_liggghts_streaming" not in j:
            fail("run %s: lists rebuilt by %s, bare LIGGGHTS with the streaming criterion %s" %
                 (row["value"], j["neighbour_rebuild"], "run" if "bare_liggghts_streaming" in j else "not run"))
        ours = j["intervals"]["neighbour_builds_per_1000_steps"]
        bare = j["bare_liggghts"]["neighbour_builds_per_1000_steps"]
        if not 0 < ours < bare:
            fail("run %s: %g neighbour builds per 1000 steps in the streaming frame, %g by LIGGGHTS's check" %
                 (row["value"], ours, bare))
        if j["dem_substeps"] < 1 or j["coupling_steps"] != 20:
            fail("run %s: %d coupling steps of %d DEM steps, expected 20" % (row["value"], j["coupling_steps"],
                                                                             j["dem_substeps"]))
    if not 0 < particles[0] < particles[1]:
        fail("particles %s: the 70-um vessel should hold more than the 50-um one" % particles)
    md = open(os.path.join(out, "bench.md")).read()
    if "## floor" not in md or "bare LIGGGHTS ns" not in md or "bare, streaming ns" not in md:
        fail("bench.md lacks the floor table")

    bad = os.path.join(out, "floor-with-reference.toml")
    with open(suite) as f:
        text = f.read().replace("floor = true", "floor = true\nreference = 50")
    with open(bad, "w") as f:
        f.write(text.replace('base = "../../', 'base = "' + os.path.abspath(os.path.join(os.path.dirname(suite), "../..")) + "/"))
    r = subprocess.run([hemocosim, "bench", "--check", bad], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines = [l for l in r.stderr.splitlines() if l.strip()]
    if r.returncode == 0 or len(lines) != 1 or "reference: a floor suite has none" not in lines[0]:
        fail("a floor suite with a reference: exit %d, said %r" % (r.returncode, r.stderr))
    print("bench.csv: 2 floor runs, DEM %s, bare LIGGGHTS %s ns per particle-step; reference refused" %
          ([x["dem_ns_per_particle_step"] for x in rows], [x["bare_liggghts_ns"] for x in rows]))


if __name__ == "__main__":
    main(*sys.argv[1:4])
