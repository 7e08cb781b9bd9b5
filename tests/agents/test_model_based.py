"""``sbx_mbpo`` (spine_gym.agents.model_based): the ensemble learns a known system, the observation's
parts are what their names say on the real envs, model rollouts keep them consistent, the mixed batches
hold the stated share of real rows, and bad settings are refused. (Training, saving, loading, evaluating
and export parity: ``test_jax_learners.py``, parametrised over the JAX learners.)"""

from __future__ import annotations

import gymnasium as gym
import jax
import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

from spine_gym.agents.model_based import (
    MBPO,
    DynamicsEnsemble,
    MixedReplayBuffer,
    exogenous_continuation,
    observation_roles,
)
from spine_gym.agents.runtime import make_env


def _linear_system(rng, n):
    a = np.array([[0.9, 0.2, 0.0], [-0.1, 0.8, 0.3], [0.0, 0.1, 0.95]])
    b = np.array([[0.5, 0.0], [0.0, 1.0], [0.3, -0.4]])
    x = rng.normal(0, 1, (n, 3))
    u = rng.uniform(-1, 1, (n, 2))
    nxt = x @ a.T + u @ b.T + rng.normal(0, 0.01, (n, 3))
    reward = -np.abs(x[:, :1]) - 0.1 * (u**2).sum(1, keepdims=True)
    return np.concatenate([x, u], 1), np.concatenate([nxt - x, reward], 1)


def test_the_ensemble_learns_a_linear_system():
    rng = np.random.default_rng(0)
    x, y = _linear_system(rng, 4000)
    x_test, y_test = _linear_system(rng, 1000)
    model = DynamicsEnsemble(5, 4, n_members=3, hidden=(64, 64), lr=3e-3, key=jax.random.PRNGKey(0))
    model.fit(x, y, steps=1, batch_size=64, rng=rng)  # statistics set, one step: barely trained

    def error(m):  # MSE per output in units of its standard deviation
        return float(np.mean(((m.predict_mean(x_test) - y_test) / y_test.std(0)) ** 2))

    before = error(model)
    model.fit(x, y, steps=1500, batch_size=128, rng=rng)
    assert before > 0.3
    assert error(model) < 0.02, error(model)
    _, logvar = model.predict(x_test)
    assert logvar.shape == (3, 1000, 4)


@pytest.mark.parametrize("env_id", ["SmaSpineEasy-v2", "SmaSpine3DEasy-v2"])
def test_the_observation_roles_match_the_env(env_id):
    env = gym.make(env_id)
    names = env.unwrapped.observation_names
    roles = observation_roles(names, len(names))
    learned = {names[i] for i in roles.learned}
    assert not any(n.startswith(("target", "preview", "error", "previous_action")) for n in learned)
    assert {names[i] for i in roles.exogenous} == {n for n in names if n.startswith(("target", "preview_x", "preview_y"))}
    assert {names[i] for i in roles.diff_obs} == {n for n in names if "error" in n}  # 2 planar, 4 spatial
    env.reset(seed=3)
    for _ in range(5):
        action = env.action_space.sample()
        obs, *_ = env.step(action)
        np.testing.assert_allclose(obs[roles.action_obs], action[roles.action_src], atol=1e-6)
        np.testing.assert_allclose(obs[roles.diff_obs], obs[roles.diff_plus] - obs[roles.diff_minus], atol=1e-4)
    assert len(roles.learned) + len(roles.exogenous) + len(roles.action_obs) + len(roles.diff_obs) == len(names)


def test_unknown_names_are_all_learnt():
    roles = observation_roles(("angle", "target"), 5)  # an observation wrapper added entries
    assert list(roles.learned) == list(range(5)) and len(roles.exogenous) == 0


def _buffer(n_rows=6, n_envs=2, obs_dim=3):
    space = gym.spaces.Box(-np.inf, np.inf, (obs_dim,), np.float32)
    rb = MixedReplayBuffer(20, space, gym.spaces.Box(-1, 1, (1,), np.float32), n_envs=n_envs, real_ratio=0.25)
    for t in range(n_rows):
        obs = np.full((n_envs, obs_dim), t, np.float32) + np.arange(n_envs)[:, None] * 100
        done = np.array([t == 2, False])
        rb.add(obs, obs + 1, np.zeros((n_envs, 1)), np.zeros(n_envs), done, [{}] * n_envs)
    return rb


def test_the_exogenous_continuation_stops_at_an_episode_end_and_the_buffer_end():
    rb = _buffer()
    values, valid = exogenous_continuation(rb, np.array([1, 1, 4]), np.array([0, 1, 1]), np.array([0]), 3)
    # env 0 from row 1: next obs of rows 1, 2 (its episode ends at row 2), then not valid
    assert valid[:, 0].tolist() == [True, True, False] and values[:2, 0, 0].tolist() == [2, 3]
    assert valid[:, 1].tolist() == [True, True, True] and values[:, 1, 0].tolist() == [102, 103, 104]
    # env 1 from row 4: rows 4, 5 stored, row 6 not yet
    assert valid[:, 2].tolist() == [True, True, False]


def test_a_mixed_batch_holds_the_real_share():
    rb = _buffer()
    assert np.all(rb.sample(40).observations.numpy() < 1000)  # no model rows yet: all real
    marker = np.full((50, 3), 1000.0, np.float32)
    rb.add_model(marker, np.zeros((50, 1)), marker, np.zeros(50), capacity=80)
    batch = rb.sample(400)
    is_model = batch.observations.numpy()[:, 0] == 1000
    assert is_model.sum() == 300 and np.all(batch.dones.numpy()[is_model] == 0)


def test_training_fills_the_model_buffer_with_consistent_transitions():
    venv = VecNormalize(DummyVecEnv([lambda: make_env({"episode_duration": 3.0}, env_id="SmaSpineEasy-v2")] * 2))
    model = MBPO(
        "MlpPolicy", venv, seed=0, learning_starts=64, batch_size=32, policy_kwargs={"net_arch": [16, 16]},
        model_train_freq=128, model_train_steps=20, rollout_batch_size=32, rollout_horizon=2, model_hidden=[32],
    )  # fmt: skip
    model.learn(400)
    assert len(model.model_history) >= 2 and np.isfinite(model.model_history[-1]["fresh_error"])
    roles = model._roles
    assert len(roles.exogenous) == 2  # the names were read from the env
    d, n = model.replay_buffer.model_data, model.replay_buffer.model_size
    assert n > 0
    nxt = d["next_obs"][:n]
    np.testing.assert_allclose(nxt[:, roles.diff_obs], nxt[:, roles.diff_plus] - nxt[:, roles.diff_minus], atol=1e-4)
    np.testing.assert_allclose(nxt[:, roles.action_obs], d["actions"][:n][:, roles.action_src], atol=1e-6)


@pytest.mark.parametrize(
    "setting, value",
    [("real_ratio", 1.5), ("rollout_horizon", 0), ("n_members", 2.5), ("model_hidden", []), ("model_lr", 0)],
)
def test_bad_settings_are_refused(setting, value):
    venv = DummyVecEnv([lambda: make_env({"episode_duration": 3.0})])
    with pytest.raises(ValueError, match=setting):
        MBPO("MlpPolicy", venv, **{setting: value})
