#!/usr/bin/env python3
# ctest bench.tiny: runs `hemocosim bench tests/bench/tiny.toml` (3 very short runs of the bench
# base scene, fresh output directory) and checks bench.csv: every run finished and was measured,
# every error column is filled, the reference's own errors are 0 and its speed-up 1, the other
# runs' errors are finite and non-negative, wall time and peak memory were recorded; bench.md has
# the suite's table.
# Usage: check_bench.py HEMOCOSIM SUITE OUT_DIR
# SPDX-License-Identifier: GPL-3.0-or-later
import math
import os
import sys

from bench_harness import fail, run_bench

ERRORS = ["err_U", "err_r_platelet", "err_r_rbc", "err_D", "L1_platelet", "L1_rbc"]


def main(hemocosim, suite, out):
    rows = run_bench(hemocosim, suite, out)
    if len(rows) != 3:
        fail("expected 3 rows in bench.csv, got %d" % len(rows))
    refs = [x for x in rows if x["reference"] == "1"]
    if len(refs) != 1 or refs[0]["value"] != "10":
        fail("expected exactly one reference row, value 10")
    for row in rows:
        if row["status"] != "ok":
            fail("run %s: status %s (%s)" % (row["value"], row["status"], row["message"]))
        for k in ERRORS + ["wall_s", "particle_peak_MiB", "fluid_peak_MiB", "particle_compute_s", "D_noise"]:
            if row[k] == "" or not math.isfinite(float(row[k])) or float(row[k]) < 0:
                fail("run %s: %s = '%s' is not a finite non-negative number" % (row["value"], k, row[k]))
        if float(row["wall_s"]) <= 0 or float(row["particle_peak_MiB"]) <= 0:
            fail("run %s: no wall time or peak memory" % row["value"])
    for k in ERRORS:
        if float(refs[0][k]) != 0.0:
            fail("reference's own %s = %s, expected 0" % (k, refs[0][k]))
    if float(refs[0]["speedup"]) != 1.0:
        fail("reference's speed-up %s, expected 1" % refs[0]["speedup"])
    md = open(os.path.join(out, "bench.md")).read()
    if "## tiny" not in md or "10 (ref)" not in md:
        fail("bench.md lacks the suite's table")
    print("bench.csv: 3 runs, errors present, reference's own errors 0")


if __name__ == "__main__":
    main(*sys.argv[1:4])
