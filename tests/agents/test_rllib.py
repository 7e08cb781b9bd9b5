"""Bounded smoke of the RLlib example (``python -m spine_gym.agents.rllib_ppo``): PPO with two env runners on a
local Ray cluster, each stepping the native ``SmaSpineVectorEnv``; a checkpoint, a restore that
continues the run, and a score of the checkpoint by ``spine_gym.agents.evaluation``.

Runs where ``ray[rllib]`` is installed (``.ci/run`` builds ``.venv-rllib`` with RLlib's pinned
gymnasium and fails if these tests are skipped there); skipped in the main venv.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from repo import ROOT

pytest.importorskip("ray.rllib", reason="ray[rllib] is not installed (it runs in .venv-rllib, see .ci/run)")

from spine_gym.agents.rllib_ppo import FrozenObsNorm, RLlibPolicy, build_config, observation_stats  # noqa: E402
from spine_gym.agents.scenarios import get_suite  # noqa: E402
from spine_gym.envs import OBS_NAMES  # noqa: E402

SMOKE = ["--env-runners", "2", "--envs-per-runner", "2", "--rollout-fragment-length", "32",
         "--num-epochs", "1", "--num-cpus", "2", "--suite", "quick"]  # fmt: skip
BATCH = 2 * 2 * 32  # env steps per iteration


def _run(*args):
    r = subprocess.run(
        [sys.executable, "-m", "spine_gym.agents.rllib_ppo", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "OMP_NUM_THREADS": "1", "RAY_DISABLE_USAGE_STATS": "1"},
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return r


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("rllib")
    _run(*SMOKE, "--iterations", "2", "--no-eval", "--out", str(base / "a"))
    _run(*SMOKE, "--restore", str(base / "a" / "checkpoint"), "--iterations", "1", "--out", str(base / "b"))
    return [json.loads((base / x / "result.json").read_text()) for x in "ab"]


def test_each_runner_steps_the_native_vector_env(runs):
    for r in runs:
        assert r["runner_envs"] == ["SmaSpineVectorEnv", "SmaSpineVectorEnv"]
    assert [h["env_steps"] for h in runs[0]["history"]] == [BATCH, 2 * BATCH]


def test_restore_continues_the_run(runs):
    restored = runs[1]
    # the restored algorithm goes on from iteration 3 and the saved step count, not from scratch
    assert restored["history"] == [{**restored["history"][0], "iteration": 3, "env_steps": 3 * BATCH}]
    # the normalisation statistics travel with the checkpoints: those measured before training
    mean, std = observation_stats(seed=0)
    for r in runs:
        norm = RLlibPolicy.from_checkpoint(r["checkpoint"]).obs_norm
        assert np.allclose(norm.mean, mean) and np.allclose(norm.std, std)
    # and they are those of real observations: wire temperatures at or above the 293 K ambient
    t = OBS_NAMES.index("temperature_right")
    assert 293.0 <= mean[t] < 450.0 and std[t] > 1.0


def test_checkpoint_is_scored_by_agents_evaluate(runs):
    rows = runs[1]["evaluation"]
    assert len(rows) == len(get_suite("quick"))
    assert all(math.isfinite(r["rmse_deg"]) and r["energy_J"] > 0 for r in rows)


def test_predict_matches_the_sb3_interface(runs):
    policy = RLlibPolicy.from_checkpoint(runs[0]["checkpoint"])
    obs = np.array([[0.0, 10.0, 300.0, 300.0, 0.0, 10.0, 0.0, 0.0, 3.5, 3.5]] * 3, dtype=np.float32)
    act, state = policy.predict(obs, deterministic=True)
    assert act.shape == (3, 2) and act.dtype == np.float32 and state is None
    assert np.all(act >= -1.0) and np.all(act <= 1.0)
    assert np.allclose(act[0], act[1], atol=1e-6)  # deterministic: the same observation, the same action
    single, _ = policy.predict(obs[0])
    assert single.shape == (2,) and np.allclose(single, act[0], atol=1e-6)
    with pytest.raises(ValueError, match="finite"):
        policy.predict(np.full(10, np.nan, dtype=np.float32))


def test_build_config_rejects_bad_arguments():
    with pytest.raises(ValueError, match="vectorize must be one of"):
        build_config(vectorize="async")
    with pytest.raises(ValueError, match="envs_per_runner must be an integer >= 1, got 0"):
        build_config(envs_per_runner=0)
    with pytest.raises(ValueError, match="std > 0"):
        FrozenObsNorm(mean=[0.0, 1.0], std=[1.0, 0.0])
    cfg = build_config(env_runners=1, envs_per_runner=4, rollout_fragment_length=16)
    assert cfg.gym_env_vectorize_mode == "vector_entry_point" and cfg.env_config == {"parallel": False}
    assert cfg.train_batch_size_per_learner == 64
