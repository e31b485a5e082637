#!/usr/bin/env python3
"""deploy/slurm on a real one-machine Slurm (Debian's slurm-wlm, deploy/slurm/setup-local.sh):

1. `sbatch deploy/slurm/hemocosim.sbatch` runs a scene end to end;
2. the same scene in a second job, requeued (`scontrol requeue`) in the middle of its run,
   stops after its step with a checkpoint, and the requeued job resumes from it and finishes;
3. the same scene with `--launcher slurm` and two particle ranks: each node runs as a job step
   of its own (srun, PMIx), seen by Slurm while the run goes, and the run finishes with the
   particles of the first job at the start.

The resumed run equals the uninterrupted one: bit for bit up to the step it stopped at, and to
round-off after it (the stop's checkpoint rebuilds the particles' neighbour lists, which the
uninterrupted run did not do at that step; docs/design.md, "Checkpoint, restart, swap").

Usage: check_slurm.py HEMOCOSIM SOURCE_DIR WORK_DIR. Exit 77 (skipped) when not root.
"""
import os
import re
import shutil
import subprocess
import sys
import time

import h5py
import numpy as np

SKIP = 77


def sh(*args, **kw):
    return subprocess.run(list(args), check=True, capture_output=True, text=True, **kw).stdout


def job_state(job):
    out = subprocess.run(["scontrol", "show", "job", job], capture_output=True, text=True).stdout
    m = re.search(r"JobState=(\S+)", out)
    return m.group(1) if m else "UNKNOWN"


def wait_for(what, predicate, timeout_s):
    t0 = time.time()
    while time.time() - t0 < timeout_s:
        if predicate():
            return
        time.sleep(0.5)
    raise SystemExit(f"check_slurm: timed out after {timeout_s} s waiting for {what}")


def last_metrics_step(run_dir):
    try:
        with open(os.path.join(run_dir, "metrics.csv")) as f:
            rows = f.read().splitlines()[1:]
        return max((int(r.split(",", 1)[0]) for r in rows if r), default=0)
    except (FileNotFoundError, ValueError):
        return 0


def snapshots(path):
    with h5py.File(path, "r") as f:
        return {k: {d: f["snapshots"][k][d][...] for d in ("id", "position", "velocity", "orientation")}
                for k in f["snapshots"]}


def main():
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    hemocosim, src, work = map(os.path.abspath, sys.argv[1:])
    if os.geteuid() != 0:
        print("check_slurm: skipped: setting up Slurm needs root")
        return SKIP
    sh(os.path.join(src, "deploy", "slurm", "setup-local.sh"))
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    shutil.copy(os.path.join(src, "tests", "deploy", "slurm.toml"), work)
    sbatch = os.path.join(src, "deploy", "slurm", "hemocosim.sbatch")
    env = dict(os.environ, HEMOCOSIM=hemocosim)

    def submit(run, *options, run_options=()):
        return sh("sbatch", "--parsable", "--output", f"{run}.out", *options, sbatch, "slurm.toml", run, *run_options,
                  cwd=work, env=env).strip()

    # 1. End to end.
    whole = submit("whole")
    wait_for(f"job {whole} to end", lambda: job_state(whole) in ("COMPLETED", "FAILED", "CANCELLED", "TIMEOUT"), 600)
    out = open(os.path.join(work, "whole.out")).read()
    assert job_state(whole) == "COMPLETED", f"job {whole}: {job_state(whole)}\n{out}"
    assert os.path.exists(os.path.join(work, "whole", "finished")), out

    # 2. Requeued part-way, resumed.
    part = submit("requeued")
    run_dir = os.path.join(work, "requeued")
    wait_for("the requeued job's run to pass step 1200", lambda: last_metrics_step(run_dir) > 1200, 600)
    sh("scontrol", "requeue", part)
    wait_for(f"job {part} to be pending again", lambda: job_state(part) == "PENDING", 120)
    out = open(os.path.join(work, "requeued.out")).read()
    m = re.search(r"interrupted after step (\d+); its last checkpoint is step (\d+)", out)
    assert m and m.group(1) == m.group(2), f"the coordinator did not stop with a checkpoint:\n{out}"
    stopped = int(m.group(1))
    assert 1200 < stopped < 3000, out
    # Slurm holds a requeued job back for a while (its BeginTime); start it now.
    sh("scontrol", "update", f"jobid={part}", "StartTime=now")
    wait_for(f"job {part} to end", lambda: job_state(part) in ("COMPLETED", "FAILED", "CANCELLED", "TIMEOUT"), 600)
    out = open(os.path.join(work, "requeued.out")).read()
    assert job_state(part) == "COMPLETED", f"job {part}: {job_state(part)}\n{out}"
    assert f"resumes from step {stopped}" in out, out
    assert "start 1 on" in out, out  # SLURM_RESTART_COUNT = 1: the requeued job did the rest
    assert os.path.exists(os.path.join(run_dir, "finished")), out

    # 3. The nodes as job steps of their own.
    stepped = submit("steps", "--ntasks=2", "--cpus-per-task=1", run_options=("--launcher", "slurm",
                                                                             "--np-particles", "2"))
    steps_seen = {}

    def note_steps():
        out = subprocess.run(["squeue", "--steps", "--noheader", "--jobs", stepped, "--format", "%i %j %A"],
                             capture_output=True, text=True).stdout
        for line in out.splitlines():
            step, name, tasks = line.split()
            if not step.endswith(".batch"):
                steps_seen[name] = int(tasks)
        return job_state(stepped) in ("COMPLETED", "FAILED", "CANCELLED", "TIMEOUT")

    wait_for(f"job {stepped} to end", note_steps, 600)
    out = open(os.path.join(work, "steps.out")).read()
    assert job_state(stepped) == "COMPLETED", f"job {stepped}: {job_state(stepped)}\n{out}"
    assert os.path.exists(os.path.join(work, "steps", "finished")), out
    steps_seen.pop("sh", None)  # the start-up check that the node sees the run directory, if caught
    assert steps_seen == {"hemocosim-fluid-solver": 1, "hemocosim-particles": 2}, steps_seen
    log = open(os.path.join(work, "steps", "particles.log")).read()
    assert "node as a Slurm job step on" in log, log[:2000]

    a = snapshots(os.path.join(work, "whole", "particles.h5"))
    s = snapshots(os.path.join(work, "steps", "particles.h5"))
    assert sorted(s) == sorted(a), (sorted(a), sorted(s))
    first = min(a)
    for d in ("id", "position", "velocity", "orientation"):
        assert np.array_equal(a[first][d], s[first][d]), f"the steps job's first snapshot differs in {d}"
    b = snapshots(os.path.join(run_dir, "particles.h5"))
    # The stop writes a snapshot of its step too.
    assert len(a) == 13 and set(b) == set(a) | {f"{stopped:08d}"}, (sorted(a), sorted(b))
    worst = 0.0
    for k in sorted(a):
        same_ids = np.array_equal(a[k]["id"], b[k]["id"])
        assert same_ids, f"snapshot {k}: particle ids differ"
        if int(k) <= stopped:
            for d in ("position", "velocity", "orientation"):
                assert np.array_equal(a[k][d], b[k][d]), f"snapshot {k} (before the stop) differs in {d}"
        else:
            dx = np.abs(a[k]["position"] - b[k]["position"]).max()
            dv = np.abs(a[k]["velocity"] - b[k]["velocity"]).max() / np.abs(a[k]["velocity"]).max()
            worst = max(worst, dv)
            # Round-off, with room: measured 3e-16 m and 1.3e-11 relative after 2,000 steps.
            assert dx < 1e-12 and dv < 1e-8, f"snapshot {k}: |dx| {dx:.3g} m, |dv|/|v| {dv:.3g}"
    print(f"check_slurm: ok: job {whole} end to end; job {part} stopped at step {stopped} on requeue and "
          f"resumed; equal to the uninterrupted run bit for bit to the stop, after it to {worst:.2g} of |v|; "
          f"job {stepped} ran its nodes as job steps {steps_seen}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
