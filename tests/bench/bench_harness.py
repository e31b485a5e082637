# What the ctest bench checks share: a fresh `hemocosim bench SUITE --out OUT --no-plot` and its
# bench.csv rows, or a FAIL line and exit 1.
# SPDX-License-Identifier: GPL-3.0-or-later
import csv
import os
import shutil
import subprocess
import sys


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def run_bench(hemocosim, suite, out):
    shutil.rmtree(out, ignore_errors=True)
    r = subprocess.run([hemocosim, "bench", suite, "--out", out, "--no-plot"], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True)
    print(r.stdout)
    if r.returncode != 0:
        fail("hemocosim bench exited with %d" % r.returncode)
    with open(os.path.join(out, "bench.csv"), newline="") as f:
        return list(csv.DictReader(f))
