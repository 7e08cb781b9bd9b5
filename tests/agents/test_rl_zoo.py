"""RL Zoo on ``SmaSpine-v0`` with the README's commands: ``rl_zoo3.train`` with
``--gym-packages spine_gym --conf-file spine_gym/agents/hyperparams/ppo.yml`` trains a few hundred steps,
``rl_zoo3.enjoy`` replays the saved model with its ``VecNormalize`` statistics, and
``spine_gym.agents.evaluate``'s loader reads the RL Zoo run folder with those statistics.

rl_zoo3 (and ``requests``, which its ``enjoy`` imports without declaring it) come with the ``rl``
extra; CI fails if this file is skipped.
"""

from __future__ import annotations

import os
import pickle
import re
import subprocess
import sys

import numpy as np
import pytest
import yaml
from repo import ROOT

pytest.importorskip("rl_zoo3", reason="rl_zoo3 is not installed (it comes with the rl extra)")
pytest.importorskip("requests", reason="requests is not installed (rl_zoo3.enjoy needs it; rl extra)")

from spine_gym.agents.runtime import load_policy  # noqa: E402
from spine_gym.envs import ENV_ID  # noqa: E402

ZOO = ["--algo", "ppo", "--env", ENV_ID, "--gym-packages", "spine_gym"]


def _zoo(module: str, *args: str) -> str:
    r = subprocess.run(
        [sys.executable, "-m", f"rl_zoo3.{module}", *ZOO, *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "OMP_NUM_THREADS": "1"},
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return r.stdout


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    logs = tmp_path_factory.mktemp("zoo")
    # 2 envs x 64 steps per update, 256 steps: two PPO updates
    _zoo(
        "train", "--conf-file", "spine_gym/agents/hyperparams/ppo.yml", "-n", "256",
        "--hyperparams", "n_envs:2", "n_steps:64", "batch_size:64", "n_epochs:1",
        "-f", str(logs), "--seed", "0", "--eval-freq", "-1",
    )  # fmt: skip
    return logs, logs / "ppo" / f"{ENV_ID}_1"


def test_train_uses_the_project_hyperparameters(run):
    _, folder = run
    assert (folder / f"{ENV_ID}.zip").exists() and (folder / ENV_ID / "vecnormalize.pkl").exists()
    config = dict(yaml.load((folder / ENV_ID / "config.yml").read_text(), Loader=yaml.UnsafeLoader))
    ours = yaml.safe_load((ROOT / "spine_gym" / "agents" / "hyperparams" / "ppo.yml").read_text())[ENV_ID]
    for key in ("gamma", "gae_lambda", "learning_rate", "normalize", "policy_kwargs"):
        assert config[key] == ours[key], key
    assert config["n_envs"] == 2 and config["n_steps"] == 64  # the command-line overrides


def test_enjoy_replays_whole_episodes(run):
    logs, _ = run
    # 10-s episodes (100 steps, the env truncates itself); 250 steps = two whole episodes
    out = _zoo(
        "enjoy", "-f", str(logs), "-n", "250", "--no-render", "--deterministic",
        "--env-kwargs", "episode_duration:10.0",
    )  # fmt: skip
    lengths = [int(x) for x in re.findall(r"^Episode Length (\d+)$", out, re.M)]
    rewards = [float(x) for x in re.findall(r"^Episode Reward: (\S+)$", out, re.M)]
    assert lengths == [100, 100]
    # reward per step is -|e|/10 deg - 0.5 E/E_ref <= 0: an episode's return is finite and <= 0
    assert len(rewards) == 2 and all(np.isfinite(r) and r <= 0 for r in rewards)
    assert "Loading running average" in out  # VecNormalize statistics were applied


def test_agents_loader_reads_an_rl_zoo_run(run):
    _, folder = run
    policy = load_policy(folder)
    with open(folder / ENV_ID / "vecnormalize.pkl", "rb") as fh:
        stats = pickle.load(fh).obs_rms
    assert policy.obs_rms is not None and np.array_equal(policy.obs_rms.mean, stats.mean)
    action, _ = policy.predict(np.zeros((1, 10), dtype=np.float32) + 293.0)
    assert action.shape == (1, 2) and np.all(np.abs(action) <= 1.0)
