# SPDX-License-Identifier: GPL-3.0-or-later
"""What the docs' table scripts share: a run's analysis.json, made by `hemocosim analyze` when the
run has none yet."""
import json
import os
import subprocess


def analysis(run, hemocosim):
    path = os.path.join(run, "analysis.json")
    if not os.path.exists(path):
        subprocess.run([hemocosim, "analyze", run], check=True, stdout=subprocess.DEVNULL)
    with open(path) as f:
        return json.load(f)
