"""spine_gym.agents.observations: the integral-of-error observation against a NumPy reference, in training and after loading."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import torch
from agent_cli import TINY, run_cli
from studies import load_study

from spine_gym.agents.lagrangian import EnergyBudgetVecEnv
from spine_gym.agents.observations import (
    IntegralObsPolicy,
    IntegralObsVecEnv,
    IntegralSpec,
    integral_step,
    parse_tau,
)
from spine_gym.agents.residual import ResidualPolicy
from spine_gym.agents.runtime import load_policy, make_env, run_episode
from spine_gym.agents.vec_env import make_vec_env

torch.set_num_threads(1)
KW = {"episode_duration": 2.0}  # 20 control periods


def reference_integral(err: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """I_t = Σ_{k ≤ t} exp(−(t − k) dt / τ) dt e_k (the unclipped closed form of the module docstring)."""
    t = np.arange(len(err))
    w = np.exp(-(t[:, None] - t[None, :]) * dt / tau) * (t[:, None] >= t[None, :])
    return w @ (dt * err)


def test_spec_reads_the_planar_tables_angle_and_target_and_validates():
    env = make_env(KW)
    spec = IntegralSpec.from_env(env, 5.0)
    assert spec.tracked == (env.obs_index("angle_deg").start, env.obs_index("angle_deg").stop)
    assert spec.target == (env.obs_index("target_deg").start, env.obs_index("target_deg").stop)
    assert spec.dt == env.control_period and spec.size == 1
    assert IntegralSpec.from_dict(json.loads(json.dumps(spec.to_dict()))) == spec
    assert math.isinf(parse_tau("inf")) and IntegralSpec.from_env(env, "inf").decay == 1.0
    with pytest.raises(ValueError, match=r"obs_integral .* must be a number > 0 s or 'inf', got 0"):
        parse_tau(0)
    with pytest.raises(ValueError, match="obs_integral .* got 'soon'"):
        parse_tau("soon")
    with pytest.raises(ValueError, match="limit must be a finite number > 0, got -1"):
        IntegralSpec(5.0, -1.0, 0.1, (0, 1), (1, 2))
    with pytest.raises(ValueError, match="same length"):
        IntegralSpec(5.0, 10.0, 0.1, (0, 1), (1, 3))


@pytest.mark.parametrize("tau", [3.0, math.inf])
def test_integral_step_is_the_leaky_integral_and_clips(tau):
    rng = np.random.default_rng(1)
    obs = rng.normal(0, 10, (50, 3, 4))  # 50 steps of a batch of 3, angle in 0, target in 2
    spec = IntegralSpec(tau, 1e9, 0.1, (0, 1), (2, 3))
    mem, got = np.zeros((3, 1)), []
    for o in obs:
        mem = integral_step(mem, o, spec)
        got.append(mem[:, 0])
    for b in range(3):
        ref = reference_integral(obs[:, b, 2] - obs[:, b, 0], 0.1, tau)
        np.testing.assert_allclose(np.array(got)[:, b], ref, rtol=1e-12, atol=1e-9)
    clipped = IntegralSpec(tau, 2.0, 0.1, (0, 1), (2, 3))
    mem = np.zeros((1, 1))
    for _ in range(40):  # a constant error of 1 deg: dt e = 0.1 per step, clipped at 2 deg s
        mem = integral_step(mem, np.array([[0.0, 0.0, 1.0, 0.0]]), clipped)
    assert mem[0, 0] == pytest.approx(min(2.0, float(reference_integral(np.ones(40), 0.1, tau)[-1])))


def test_vec_env_appends_the_reference_integral_restarts_it_and_augments_terminal_obs():
    base = make_vec_env(n_envs=2, seed=11, env_kwargs=KW)
    spec = IntegralSpec.from_env(make_env(KW), 4.0)
    env = IntegralObsVecEnv(base, spec)
    assert env.observation_space.shape == (base.observation_space.shape[0] + 1,)
    rng = np.random.default_rng(0)
    obs = env.reset()
    raw, aug, terms = [obs[:, :-1]], [obs[:, -1]], []
    for _ in range(30):  # one episode of 20 steps, then 10 of the next
        env.step_async(rng.uniform(-1, 1, (2, 2)).astype(np.float32))
        obs, _, dones, infos = env.step_wait()
        if dones.any():
            terms = [infos[i]["terminal_observation"] for i in range(2)]
        raw.append(obs[:, :-1])
        aug.append(obs[:, -1])
    raw, aug = np.array(raw), np.array(aug)  # (31, 2, d), (31, 2): row 20 is the next episode's first
    err = raw[:, :, 1] - raw[:, :, 0]
    for b in range(2):
        np.testing.assert_allclose(aug[:20, b], reference_integral(err[:20, b], 0.1, 4.0), rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(aug[20:, b], reference_integral(err[20:, b], 0.1, 4.0), rtol=1e-5, atol=1e-5)
        last = terms[b]
        ref_last = reference_integral(np.r_[err[:20, b], last[1] - last[0]], 0.1, 4.0)[-1]
        assert last[-1] == pytest.approx(ref_last, rel=1e-5, abs=1e-5)
    env.close()


def test_budget_window_bounds_the_episodes_of_the_mean_energy():
    e_ref = make_env(KW).config.energy_reference
    env = EnergyBudgetVecEnv(make_vec_env(n_envs=2, seed=7, env_kwargs=KW), 100.0, e_ref, window=3)
    env.reset()
    for _ in range(40):  # two episodes per sub-env: 4 finished, the mean is over the last 3
        env.step_async(np.full((2, 2), 0.5, dtype=np.float32))
        env.step_wait()
    assert len(env.finished) == 3
    assert env.energy_ratio() == pytest.approx(np.mean(list(env.finished)) / 100.0)
    env.close()


class _Recorder:
    """Stands in for a SavedPolicy: records what it is asked and answers a fixed action."""

    def __init__(self):
        self.seen, self.resets = [], 0

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        self.seen.append(np.array(obs))
        return np.zeros((obs.shape[0], 2), np.float32), None

    def reset(self):
        self.resets += 1


def test_policy_keeps_the_integral_per_episode_as_the_training_wrapper_does():
    env = make_env(KW)
    spec = IntegralSpec.from_env(env, 2.0)
    inner = _Recorder()
    pol = IntegralObsPolicy(inner, spec)
    for _ in range(2):  # two episodes: the integral restarts with each
        run_episode(env, pol, seed=3)
    seen = np.concatenate(inner.seen)  # (40, d + 1): one row per step
    assert inner.resets == 2 and seen.shape == (40, env.observation_space.shape[0] + 1)
    err = seen[:20, 1] - seen[:20, 0]
    np.testing.assert_allclose(seen[:20, -1], reference_integral(err, 0.1, 2.0), rtol=1e-5, atol=1e-5)
    np.testing.assert_array_equal(seen[:20], seen[20:])
    with pytest.raises(ValueError, match="observation must have >= 2 entries"):
        pol.predict(np.zeros(1, np.float32))


def test_trained_integral_policy_round_trips_through_load_policy(tmp_path):
    """A tiny residual + integral + budget run: the folder and its checkpoint load as
    ResidualPolicy(IntegralObsPolicy(...)); the model sees [obs, PID action, integral] as in training."""
    run_cli(
        "-m", "spine_gym.agents.train", "--algo", "ppo", "-n", "128", "--n-envs", "2", "-f", str(tmp_path),
        "--eval-freq", "0", "--save-freq", "128", *TINY,
        "-params", "n_steps:64", "batch_size:64", "n_epochs:1", "obs_integral:5.0", "obs_integral_limit:50",
        "residual:pid", "energy_budget:100", "budget_window:4",
    )  # fmt: skip
    run = tmp_path / "ppo" / "SmaSpine-v0_1"
    meta = json.loads((run / "meta.json").read_text())
    assert meta["obs_integral"]["tau"] == 5.0 and meta["obs_integral"]["limit"] == 50.0
    assert meta["train_cpu_time_s"] > 0.0
    for path in (run, next((run / "checkpoints").glob("rl_model_*_steps.zip"))):
        pol = load_policy(path)
        assert isinstance(pol, ResidualPolicy) and isinstance(pol.model, IntegralObsPolicy)
        assert pol.model.model.model.observation_space.shape == (10 + 2 + 1,)
    env = make_env({"episode_duration": 3.0})
    a = run_episode(env, pol, seed=5).action
    b = run_episode(env, pol, seed=5).action
    np.testing.assert_array_equal(a, b)  # every memory (PID, integral) restarts with the episode


def test_budget_window_zero_takes_only_the_episodes_since_the_last_dual_step():
    e_ref = make_env(KW).config.energy_reference
    env = EnergyBudgetVecEnv(make_vec_env(n_envs=2, seed=7, env_kwargs=KW), 100.0, e_ref, window=0)
    env.reset()
    ratios = []
    for volts in (0.2, 0.9):  # one episode per sub-env at each drive level, a dual step after each
        for _ in range(20):
            env.step_async(np.full((2, 2), volts, dtype=np.float32))
            env.step_wait()
        assert len(env.finished) == 2
        ratios.append(env.dual_ratio())
        assert len(env.finished) == 0 and env.dual_ratio() is None
    assert ratios[1] > 2.0 * ratios[0]  # the second mean is the hot episodes' alone
    with pytest.raises(ValueError, match="budget_window must be an integer >= 0"):
        EnergyBudgetVecEnv(env.venv, 100.0, e_ref, window=-1)
    env.close()


def test_the_shipped_integral_policy_rebuilds_its_observation_and_keeps_its_preview():
    from spine_gym.agents.runtime import evaluation_env_kwargs
    from spine_gym.agents.zoo_config import POLICIES_DIR

    pol = load_policy(POLICIES_DIR / "ppo_int")
    assert isinstance(pol, IntegralObsPolicy) and pol.spec.tau == 10.0 and pol.spec.size == 1
    assert pol.model.model.observation_space.shape == (11,)
    assert evaluation_env_kwargs(pol.env_kwargs) == {"target_preview": 3.0}


def test_ceiling_rows_score_the_oracle_against_the_pid_and_a_higher_energy_weight_saves_energy(tmp_path):
    """scripts/studies/ceiling.py on one 3-s validation episode: the PID row is the reference (ratios 1), and
    the oracle's cost Σ e² + w_energy E spends less energy when w_energy is 1000× larger."""
    ceiling = load_study("ceiling")

    rows = ceiling.ceiling_rows(1, [0.01, 10.0], ["default"], duration=3.0)
    assert [r["controller"] for r in rows] == ["pid", "mpc_oracle w_energy=0.01", "mpc_oracle w_energy=10"]
    assert rows[0]["rmse_ratio"] == 1.0 and rows[0]["energy_ratio"] == 1.0
    assert rows[2]["energy_J"] < rows[1]["energy_J"]
    ceiling.plot(rows, 0.7, tmp_path / "c.png")
    assert (tmp_path / "c.png").stat().st_size > 1000


def test_ceiling_rows_sweep_the_causal_oracle_with_its_own_preview(monkeypatch):
    """--oracle mpc_oracle_causal --target-preview 3: the rows name the causal planner, which is
    built on a 3-s-preview env; the PID reference keeps the env's 1-s preview."""
    ceiling = load_study("ceiling")

    built = []
    real = ceiling.energy_weighted_oracle

    def spy(env, w, name):
        built.append((env.config.target_preview, name))
        return real(env, w, name)

    monkeypatch.setattr(ceiling, "energy_weighted_oracle", spy)
    rows = ceiling.ceiling_rows(
        1, [0.05], ["default"], duration=2.0, oracle="mpc_oracle_causal", target_preview=3.0
    )
    assert [r["controller"] for r in rows] == ["pid", "mpc_oracle_causal w_energy=0.05"]
    assert built == [(3.0, "mpc_oracle_causal")]
    assert rows[1]["rmse_deg"] > 0.0 and rows[1]["energy_J"] > 0.0
