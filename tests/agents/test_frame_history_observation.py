"""spine_gym.agents.observations: the frame-history observation against a NumPy reference, in training and after
loading; spine_gym.agents.train's budget_scale."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from agent_cli import TINY, run_cli

from spine_gym.agents.observations import (
    HistoryObsPolicy,
    HistoryObsVecEnv,
    HistorySpec,
    IntegralObsPolicy,
    history_features,
    history_step,
)
from spine_gym.agents.runtime import load_policy, make_env, run_episode
from spine_gym.agents.training import energy_budget
from spine_gym.agents.vec_env import make_vec_env

torch.set_num_threads(1)
KW = {"episode_duration": 2.0}  # 20 control periods


def reference_history(frames: np.ndarray, k: int) -> np.ndarray:
    """Row t: [x_{t−1}, …, x_{t−k}] with x_s = x_0 for s < 0 (the module docstring), frames (T, w)."""
    t = np.arange(len(frames))
    idx = np.clip(t[:, None] - np.arange(1, k + 1)[None, :], 0, None)  # (T, k)
    return frames[idx].reshape(len(frames), -1)


def test_spec_reads_the_angle_and_previous_action_and_validates():
    env = make_env(KW)
    spec = HistorySpec.from_env(env, 4)
    a, u = env.obs_index("angle_deg"), env.obs_index("previous_action")
    assert spec.ranges == ((a.start, a.stop), (u.start, u.stop)) and spec.width == 3 and spec.size == 12
    assert HistorySpec.from_dict(json.loads(json.dumps(spec.to_dict()))) == spec
    space = spec.space(env.observation_space)
    assert space.shape == (env.observation_space.shape[0] + 12,)
    np.testing.assert_array_equal(space.high[-3:], env.observation_space.high[[a.start, u.start, u.start + 1]])
    for bad in (0, 51, 2.5):
        with pytest.raises(ValueError, match=r"obs_history \(frames\) must be an integer in \[1, 50\], got"):
            HistorySpec.from_env(env, bad)
    with pytest.raises(ValueError, match="ranges must be index ranges"):
        HistorySpec(2, ((3, 3),), (0.0,), (1.0,))


def test_history_step_shifts_the_frames_and_fills_a_start_with_the_first():
    spec = HistorySpec(3, ((0, 1), (2, 3)), (-1.0, -1.0), (1.0, 1.0))
    rng = np.random.default_rng(0)
    obs = rng.normal(size=(12, 2, 4))  # 12 steps of 2 envs; env 1 restarts at step 7
    mem = np.zeros((2, 4 * spec.width))
    got = []
    for t in range(12):
        start = np.array([t == 0, t in (0, 7)])
        mem = history_step(mem, obs[t], spec, start)
        got.append(history_features(mem, spec))
    got = np.array(got)
    frames = obs[:, :, [0, 2]]
    np.testing.assert_array_equal(got[:, 0], reference_history(frames[:, 0], 3))
    np.testing.assert_array_equal(got[:7, 1], reference_history(frames[:7, 1], 3))
    np.testing.assert_array_equal(got[7:, 1], reference_history(frames[7:, 1], 3))


def test_vec_env_appends_the_reference_history_restarts_it_and_augments_terminal_obs():
    base = make_vec_env(n_envs=2, seed=11, env_kwargs=KW)
    spec = HistorySpec.from_env(make_env(KW), 2)
    env = HistoryObsVecEnv(base, spec)
    d = base.observation_space.shape[0]
    rng = np.random.default_rng(0)
    obs = env.reset()
    seen, terms = [obs], []
    for _ in range(30):  # one episode of 20 steps, then 10 of the next
        env.step_async(rng.uniform(-1, 1, (2, 2)).astype(np.float32))
        obs, _, dones, infos = env.step_wait()
        if dones.any():
            terms = [infos[i]["terminal_observation"] for i in range(2)]
        seen.append(obs)
    seen = np.array(seen)  # (31, 2, d + 6): row 20 is the next episode's first
    for b in range(2):
        frames = spec.frame(seen[:, b, :d].astype(np.float64))
        np.testing.assert_allclose(seen[:20, b, d:], reference_history(frames[:20], 2), rtol=1e-6)
        np.testing.assert_allclose(seen[20:, b, d:], reference_history(frames[20:], 2), rtol=1e-6)
        np.testing.assert_allclose(terms[b][d:], frames[19:17:-1].reshape(-1), rtol=1e-6)
    env.close()


class _Recorder:
    """Stands in for a SavedPolicy: records what it is asked and answers a fixed action."""

    def __init__(self):
        self.seen = []

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        self.seen.append(np.array(obs))
        return np.zeros((obs.shape[0], 2), np.float32), None


def test_policy_keeps_the_frames_per_episode_as_the_training_wrapper_does():
    env = make_env(KW)
    spec = HistorySpec.from_env(env, 3)
    inner = _Recorder()
    pol = HistoryObsPolicy(inner, spec)
    for _ in range(2):  # two episodes: the history restarts with each
        run_episode(env, pol, seed=3)
    seen = np.concatenate(inner.seen).astype(np.float64)
    d = env.observation_space.shape[0]
    assert seen.shape == (40, d + 9)
    np.testing.assert_allclose(seen[:20, d:], reference_history(spec.frame(seen[:20, :d]), 3), rtol=1e-6)
    np.testing.assert_array_equal(seen[:20], seen[20:])
    with pytest.raises(ValueError, match=f"observation must have >= {spec.min_obs} entries"):
        pol.predict(np.zeros(2, np.float32))


def test_trained_history_policy_round_trips_through_load_policy(tmp_path):
    """A tiny integral + history run: it loads as IntegralObsPolicy(HistoryObsPolicy(...)), the
    model seeing [obs, integral, history] as in training."""
    run_cli(
        "-m", "spine_gym.agents.train", "--algo", "ppo", "-n", "128", "--n-envs", "2", "-f", str(tmp_path),
        "--eval-freq", "0", "--save-freq", "0", *TINY,
        "-params", "n_steps:64", "batch_size:64", "n_epochs:1", "obs_integral:5.0", "obs_history:2",
    )  # fmt: skip
    run = tmp_path / "ppo" / "SmaSpine-v0_1"
    assert json.loads((run / "meta.json").read_text())["obs_history"]["frames"] == 2
    pol = load_policy(run)
    assert isinstance(pol, IntegralObsPolicy) and isinstance(pol.model, HistoryObsPolicy)
    assert pol.model.model.model.observation_space.shape == (10 + 1 + 6,)
    env = make_env({"episode_duration": 3.0})
    np.testing.assert_array_equal(run_episode(env, pol, seed=5).action, run_episode(env, pol, seed=5).action)


def test_budget_scale_multiplies_the_budget_and_is_validated():
    assert energy_budget(200.0, KW, 1, 0.9) == pytest.approx(180.0)
    assert energy_budget("pid", KW, 1, 0.5) == pytest.approx(0.5 * energy_budget("pid", KW, 1))
    for bad in (0.0, 2.5, float("nan"), "half"):
        with pytest.raises(ValueError, match=r"budget_scale must be a number in \(0, 2\], got"):
            energy_budget(200.0, KW, 1, bad)


def test_the_shipped_budget_policy_loads_plain_with_its_preview():
    """ppo_bud (the new default physics_dt): no integral, no history, the 3-s preview."""
    from spine_gym.agents.runtime import SavedPolicy, evaluation_env_kwargs
    from spine_gym.agents.zoo_config import POLICIES_DIR

    pol = load_policy(POLICIES_DIR / "ppo_bud")
    assert type(pol) is SavedPolicy and pol.model.observation_space.shape == (10,)
    assert evaluation_env_kwargs(pol.env_kwargs) == {"target_preview": 3.0}
    assert pol.meta["total_timesteps"] == 852464 and len(pol.meta["lineage"]) == 3
