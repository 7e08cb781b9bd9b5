"""``spine_gym.agents.train --resume`` after a ``kill -9``: the run goes on from its newest checkpoint with the
``VecNormalize`` statistics, the step counter (and the learning-rate schedule on it) and, for an
energy-budgeted run, the Lagrange multiplier of that checkpoint.

Each variant trains the same tiny PPO run twice: once to the end (U) and once killed with SIGKILL as
soon as a checkpoint of step >= ``KILL_AFTER`` is on disk (K). K resumed from its newest checkpoint must end with the weights
of U resumed from its checkpoint of the same step; K's checkpoint must be U's (the killed run was the
same run up to the kill).
"""

from __future__ import annotations

import io
import json
import os
import pickle
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch
from repo import ROOT

from spine_gym.agents.checkpoints import checkpoint_steps, latest_checkpoint

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
N = 1024  # env steps of the run: 512 vector steps of 2 envs, 32 rollouts of 16 steps
N_ENVS = 2
RUN = [
    "-m", "spine_gym.agents.train", "--algo", "ppo", "--env", "SmaSpine-v0", "-n", str(N), "--n-envs", str(N_ENVS), "--seed", "5",
    "--eval-freq", "0", "--save-freq", "64", "--no-tensorboard", "-v", "0",
    "--env-kwargs", "episode_duration:2.0",
    "-params", "n_steps:16", "batch_size:32", "n_epochs:2", "learning_rate:lin_0.001",
]  # fmt: skip
KILL_AFTER = 192  # the dual step has moved λ by then (rollout ends at 64, 96, ...; episodes of 20 steps)
BUDGET = ["energy_budget:20.0", "budget_window:0", "lagrangian_init:0.5"]  # λ moves every rollout


def _cli(args: list[str], folder: Path | None = None) -> subprocess.CompletedProcess:
    extra = ["-f", str(folder)] if folder else []
    proc = subprocess.run(
        [sys.executable, *args, *extra], cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=240
    )
    assert proc.returncode == 0, f"{args} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


def _written(run: Path, min_step: int) -> bool:
    ckpt = latest_checkpoint(run)
    return ckpt is not None and checkpoint_steps(ckpt) >= min_step


def _kill_after_checkpoint(args: list[str], folder: Path, min_step: int) -> Path:
    """Start the run, SIGKILL it once a checkpoint of ``min_step`` or later exists; returns the run
    folder."""
    run = folder / "ppo" / "SmaSpine-v0_1"
    proc = subprocess.Popen(
        [sys.executable, *args, "-f", str(folder)],
        cwd=ROOT,
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 180
        while not _written(run, min_step) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL, f"the run ended by itself ({proc.returncode}) before the kill"
    assert not (run / "model.zip").exists()
    return run


def _tensors(model_zip: Path) -> dict[str, torch.Tensor]:
    """Policy weights and optimiser state of an SB3 model file."""
    with zipfile.ZipFile(model_zip) as z:
        policy = torch.load(io.BytesIO(z.read("policy.pth")), weights_only=True)
        opt = torch.load(io.BytesIO(z.read("policy.optimizer.pth")), weights_only=True)
    out = dict(policy)
    for k, state in opt["state"].items():
        out.update({f"adam{k}.{name}": v for name, v in state.items() if torch.is_tensor(v)})
    return out


def _same_tensors(a: Path, b: Path) -> bool:
    ta, tb = _tensors(a), _tensors(b)
    return ta.keys() == tb.keys() and all(torch.equal(ta[k], tb[k]) for k in ta)


def _model_data(model_zip: Path) -> dict:
    with zipfile.ZipFile(model_zip) as z:
        return json.loads(z.read("data"))


def _obs_rms(pkl: Path):
    with open(pkl, "rb") as f:
        return pickle.load(f).obs_rms


@pytest.mark.parametrize("budgeted", [False, True], ids=["plain", "budgeted"])
def test_resume_after_kill_continues_the_run(tmp_path, budgeted):
    args = [*RUN, *BUDGET] if budgeted else RUN
    _cli(args, tmp_path / "u")
    u = tmp_path / "u" / "ppo" / "SmaSpine-v0_1"
    k = _kill_after_checkpoint(args, tmp_path / "k", KILL_AFTER)
    ckpt_k = latest_checkpoint(k)
    step = checkpoint_steps(ckpt_k)

    _cli(["-m", "spine_gym.agents.train", "--resume", str(k)])  # K from its newest checkpoint
    meta_k = json.loads((k / "meta.json").read_text())
    assert meta_k["resumes"][-1]["checkpoint"] == str(ckpt_k)
    ckpt_u = u / "checkpoints" / ckpt_k.name
    assert _same_tensors(ckpt_k, ckpt_u)  # the killed run was U up to its checkpoint
    _cli(["-m", "spine_gym.agents.train", "--resume", str(ckpt_u)])  # U again from the same checkpoint (overwrites U)
    meta_u = json.loads((u / "meta.json").read_text())

    # the weights after the resume: the same from either checkpoint, and trained on from it
    assert _same_tensors(k / "model.zip", u / "model.zip")
    assert not _same_tensors(k / "model.zip", ckpt_k)
    # the step counter and the schedule on it: the run ends at N with the learning rate at its end
    data = _model_data(k / "model.zip")
    assert data["num_timesteps"] == N == meta_k["total_timesteps"] == meta_u["total_timesteps"]
    assert data["_current_progress_remaining"] == 0.0
    assert meta_k["resumes"][-1]["start_step"] == step > 0
    # VecNormalize: the checkpoint's statistics plus the resumed steps (N_ENVS for the reset)
    rms_ckpt = _obs_rms(k / "checkpoints" / f"rl_model_vecnormalize_{step}_steps.pkl")
    rms_end = _obs_rms(k / "vecnormalize.pkl")
    assert rms_end.count == pytest.approx(rms_ckpt.count + N_ENVS + (N - step), abs=1e-6)
    assert np.array_equal(rms_end.mean, _obs_rms(u / "vecnormalize.pkl").mean)

    if budgeted:
        saved = json.loads((k / "checkpoints" / f"rl_model_lagrangian_{step}_steps.json").read_text())
        assert saved == json.loads((u / "checkpoints" / f"rl_model_lagrangian_{step}_steps.json").read_text())
        assert saved["lam"] != 0.5  # the dual step moved it before the checkpoint
        assert meta_k["resumes"][-1]["lagrangian_start"] == saved["lam"]
        assert meta_k["lagrangian_final"] == meta_u["lagrangian_final"] != saved["lam"]
        assert json.loads((k / "lagrangian.json").read_text())["lam"] == meta_k["lagrangian_final"]
    else:
        assert not list(k.glob("**/*lagrangian*"))


def test_resume_rejects_what_is_not_a_run(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "spine_gym.agents.train", "--resume", str(tmp_path)],
        cwd=ROOT,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode != 0 and "no checkpoint in" in proc.stderr
