"""spine_gym.agents.lagrangian: the energy-budget reward, the dual step, and a training run that uses them."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from agent_cli import TINY, run_cli

from spine_gym.agents.lagrangian import EnergyBudgetVecEnv, EnergyRelabelReplayBuffer, LagrangianCallback, dual_step
from spine_gym.agents.runtime import build_controller, make_env, validation_scores
from spine_gym.agents.training import energy_budget
from spine_gym.agents.vec_env import make_vec_env

torch.set_num_threads(1)
KW = {"episode_duration": 2.0}


def _budget_env(lam0: float) -> tuple[EnergyBudgetVecEnv, float]:
    e_ref = make_env(KW).config.energy_reference
    return EnergyBudgetVecEnv(make_vec_env(n_envs=2, seed=7, env_kwargs=KW), 100.0, e_ref, lam0=lam0), e_ref


def test_budget_reward_is_the_env_reward_with_lambda_as_energy_weight():
    """SmaSpineEnv docstring: r = −|e| / 10° − w · E / E_ref; with λ = w = 0.5 (the env's default)
    the wrapper's reward is the env's, with λ = 2 the energy term is four times larger. The
    episode energies it records are the sums of info["energy_J"] over each 20-step episode."""
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (20, 2, 2)).astype(np.float32)
    runs = {}
    for lam in (0.5, 2.0):
        env, e_ref = _budget_env(lam)
        env.reset()
        rec, total = [], np.zeros(2)
        for a in actions:
            env.step_async(a)
            _, r, dones, infos = env.step_wait()
            e = np.array([i["energy_J"] for i in infos])
            err = np.array([i["tracking_error_deg"] for i in infos])
            total += e
            np.testing.assert_allclose(r, -np.abs(err) / 10.0 - lam * e / e_ref, rtol=1e-5, atol=1e-6)
            rec.append((r, e))
        assert dones.all() and list(env.finished) == pytest.approx(list(total), rel=1e-12)
        assert env.energy_ratio() == pytest.approx(total.mean() / 100.0)
        runs[lam] = rec
        env.close()
    for (r05, e), (r2, _) in zip(runs[0.5], runs[2.0], strict=True):  # same seeds, same actions
        np.testing.assert_allclose(r2 - r05, -1.5 * e / e_ref, rtol=1e-5, atol=1e-6)
    assert sum(float(e.sum()) for _, e in runs[0.5]) > 0.0


def test_budget_reward_is_the_env_reward_with_its_energy_weight_replaced_cost_kept():
    """r = r_env − r_energy − λ · E / E_ref: the env's reward with the weight of its energy term
    replaced by λ; every other term stays, the temperature cost (cost_weight · cost) among them.
    A twin env with the same seeds and actions gives r_env. The default λ0 is the env's own
    energy weight (0.05 on a -v1 id), so the wrapped reward starts as the env's."""
    kw = {**KW, "temperature_limit": 330.0, "cost_weight": 0.02}
    e_ref = make_env(kw).config.energy_reference
    lam = 1.3
    wrapped = EnergyBudgetVecEnv(make_vec_env(n_envs=2, seed=3, env_kwargs=kw), 100.0, e_ref, lam0=lam)
    twin = make_vec_env(n_envs=2, seed=3, env_kwargs=kw)
    wrapped.reset(), twin.reset()
    costs = 0.0
    for _ in range(15):
        a = np.ones((2, 2), dtype=np.float32)  # both wires at v_max: hot wires, cost > 0
        wrapped.step_async(a), twin.step_async(a)
        _, r, _, infos = wrapped.step_wait()
        _, r_env, _, twin_infos = twin.step_wait()
        e = np.array([i["energy_J"] for i in infos])
        cost = np.array([i["cost"] for i in infos])
        r_energy = -0.5 * e / e_ref  # the -v0 default energy weight of KW's env
        np.testing.assert_allclose([i["energy_J"] for i in twin_infos], e)
        np.testing.assert_allclose(r, r_env - r_energy - lam * e / e_ref, rtol=1e-5, atol=1e-6)
        track = np.array([i["reward_tracking"] for i in infos])
        np.testing.assert_allclose(r, track - 0.02 * cost - lam * e / e_ref, rtol=1e-5, atol=1e-6)
        costs += cost.sum()
    assert costs > 0.0  # the cost term was exercised
    wrapped.close(), twin.close()
    v1 = EnergyBudgetVecEnv(make_vec_env(n_envs=1, seed=0, env_id="SmaSpine-v1", env_kwargs=KW), 100.0, e_ref)
    assert v1.lam == 0.05
    v1.close()


def test_dual_step_raises_lambda_over_budget_lowers_it_under_and_clips():
    assert dual_step(1.0, 1.2, 0.5, (0.02, 20.0)) == pytest.approx(np.exp(0.1))
    assert dual_step(1.0, 0.8, 0.5, (0.02, 20.0)) == pytest.approx(np.exp(-0.1))
    assert dual_step(1.0, 1.0, 0.5, (0.02, 20.0)) == 1.0
    assert dual_step(19.0, 3.0, 0.5, (0.02, 20.0)) == 20.0
    assert dual_step(0.03, 0.0, 0.5, (0.02, 20.0)) == 0.02


def test_budget_arguments_are_validated():
    env, e_ref = _budget_env(0.5)
    with pytest.raises(ValueError, match="energy_budget must be a finite number > 0 J"):
        EnergyBudgetVecEnv(env.venv, 0.0, e_ref)
    with pytest.raises(ValueError, match=r"lagrangian_init must be in \[0, 100\]"):
        EnergyBudgetVecEnv(env.venv, 100.0, e_ref, lam0=-1.0)
    with pytest.raises(ValueError, match=r"lagrangian_lr must be in \(0, 10\]"):
        LagrangianCallback(env, eta=0.0)
    with pytest.raises(ValueError, match="energy_budget must be 'pid' or a number"):
        energy_budget("lots", KW, 1)
    env.close()


def test_the_relabel_buffer_replays_each_reward_with_the_multiplier_of_now():
    """A transition collected under λ = 0.5 (r = r_rest − 0.5 · E / E_ref) is sampled after the dual
    step moved λ to 2 as r_rest − 2 · E / E_ref, and as collected while λ stays."""
    env, e_ref = _budget_env(0.5)
    buf = EnergyRelabelReplayBuffer(64, env.observation_space, env.action_space, n_envs=2, energy_ref=e_ref)
    buf.lam = env.lam
    obs = env.reset()
    rng = np.random.default_rng(1)
    rewards, energies = [], []
    for _ in range(8):
        env.step_async(rng.uniform(-1, 1, (2, 2)).astype(np.float32))
        nxt, r, dones, infos = env.step_wait()
        buf.add(obs, nxt, rng.uniform(-1, 1, (2, 2)), r, dones, infos)
        rewards.append(r)
        energies.append([i["energy_J"] for i in infos])
        obs = nxt
    rewards, energies = np.array(rewards), np.array(energies)
    assert energies.sum() > 0.0
    for lam in (0.5, 2.0):
        buf.lam = lam
        expected = rewards - (lam - 0.5) * energies / e_ref
        np.random.seed(3)
        got = buf.sample(200).rewards.numpy().ravel()
        np.random.seed(3)
        idx = np.random.randint(0, 8, 200)
        envs = np.random.randint(0, 2, 200)
        np.testing.assert_allclose(got, expected[idx, envs], rtol=1e-5, atol=1e-6)
    with pytest.raises(ValueError, match="energy_ref must be a finite number > 0 J"):
        EnergyRelabelReplayBuffer(8, env.observation_space, env.action_space, energy_ref=0.0)
    env.close()


def test_pid_budget_is_the_pids_validation_energy_and_a_training_run_records_it(tmp_path):
    budget = energy_budget("pid", {"episode_duration": 3.0}, 2)
    assert budget > 0.0
    run_cli(
        "-m", "spine_gym.agents.train", "--algo", "ppo", "-n", "256", "--n-envs", "2", "-f", str(tmp_path),
        "--eval-freq", "0", "--save-freq", "0", *TINY,
        "-params", "n_steps:64", "batch_size:64", "n_epochs:1", "energy_budget:pid", "budget_episodes:2",
        "residual:pid", "residual_scale:0.5",
    )  # fmt: skip
    meta = json.loads((tmp_path / "ppo" / "SmaSpine-v0_1" / "meta.json").read_text())
    assert meta["energy_budget_J"] == pytest.approx(budget, rel=1e-12)
    assert 0.02 <= meta["lagrangian_final"] <= 20.0 and meta["residual"]["kind"] == "pid"


def test_a_pid_budget_is_measured_on_the_runs_own_env_id():
    """The spatial ids' budget is the spatial PID's energy on their validation episodes, not the
    planar spine's."""
    kw = {"episode_duration": 3.0}
    for env_id in ("SmaSpine3D-v1", "SmaSpineChain-v1"):
        pid = build_controller("pid", make_env(kw, env_id=env_id))
        expected = validation_scores(pid, 2, kw, env_id)[1]
        assert energy_budget("pid", kw, 2, 0.9, env_id=env_id) == pytest.approx(0.9 * expected, rel=1e-12)
    assert energy_budget("pid", kw, 2, env_id="SmaSpineChain-v1") != energy_budget("pid", kw, 2)
