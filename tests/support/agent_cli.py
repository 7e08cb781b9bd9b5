"""The ``python -m spine_gym.agents.*`` command lines as the agents' tests run them: one torch thread, this
tree's ``spine_gym`` first on the path, and a tiny episode budget for smoke runs."""

import os
import subprocess
import sys

from repo import ROOT

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}

# a training command's options for a smoke run on SmaSpine-v0 (the runs' folders are named after it):
# 3-s episodes, one evaluation episode, quiet
TINY = ["--env", "SmaSpine-v0", "--env-kwargs", "episode_duration:3.0", "--eval-episodes", "1", "-v", "0"]


def run_cli(*args, cwd=ROOT, timeout=240):
    """Run ``python *args`` and return the finished process; fail with the tail of its output if it failed."""
    proc = subprocess.run(
        [sys.executable, *args], cwd=cwd, env=ENV, capture_output=True, text=True, timeout=timeout
    )
    assert proc.returncode == 0, f"{args} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc
