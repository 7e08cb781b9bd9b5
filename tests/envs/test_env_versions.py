"""The registered versions and tiers (spine_gym.envs.ids): -v1 is -v0 with the measured tracking
errors appended to the observation and the reward divided by 10; the tiers only change the task
distribution; every id passes Gymnasium's and SB3's checkers and its vector env equals its single env."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from repo import ROOT
from stable_baselines3.common.env_checker import check_env as sb3_check_env

from spine_gym.envs import BENCHMARK_IDS, ENV_SPECS, base_id, family_of, tier_of
from spine_gym.envs.ids import V1_REWARD_DIVISOR, markdown_table

V1_IDS = [i for i, s in ENV_SPECS.items() if s.version == 1]
V2_IDS = [i for i, s in ENV_SPECS.items() if s.version == 2]
SHORT = {"episode_duration": 3.0}
TASK_ENTRY = {"SmaSpine": "angle_deg", "SmaSpine3D": "tip_bending_deg", "SmaSpineChain": "tip_position_mm"}


def _actions(env, n, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, (n, *env.action_space.shape)).astype(np.float32)


def test_every_family_has_v0_and_v1_v2_with_two_tiers():
    for fam in ("SmaSpine", "SmaSpine3D", "SmaSpineChain"):
        ids = {i for i in ENV_SPECS if family_of(i) == fam}
        tiers = {f"{fam}{t}-v{v}" for t in ("", "Easy", "Hard") for v in (1, 2)}
        assert ids == {f"{fam}-v0", *tiers}
        assert all(base_id(i) == f"{fam}-v0" for i in ids)
        assert all(i in gym.registry for i in ids)
    assert set(BENCHMARK_IDS) == {i for i in V1_IDS if tier_of(i) != "default"}
    assert all(f"``{i}``" in markdown_table() for i in ENV_SPECS)
    with pytest.raises(ValueError, match="unknown spine_gym env id"):
        base_id("SmaSpine-v7")


@pytest.mark.parametrize("env_id", V1_IDS + V2_IDS)
def test_v1_and_v2_ids_pass_the_checkers_with_warnings_as_errors(env_id):
    envs = []
    for _ in range(2):
        if ENV_SPECS[env_id].version == 1:
            with pytest.warns(DeprecationWarning, match="out of date"):  # gymnasium: a -v2 exists
                envs.append(gym.make(env_id, **SHORT).unwrapped)
        else:
            envs.append(gym.make(env_id, **SHORT).unwrapped)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(envs[0])
        sb3_check_env(envs[1], warn=True)


@pytest.mark.parametrize("family", ["SmaSpine", "SmaSpine3D", "SmaSpineChain"])
def test_v1_is_v0_plus_measured_errors_and_a_tenth_of_the_reward(family):
    """Same seed, same actions: the -v0 observation is the head of the -v1 one, the -v1 reward is
    the -v0 reward / 10, the infos agree; the appended entries are target − measured tracked entry
    and preview − measured (the observed target, preview and reading, so noise and delay count)."""
    kw = {**SHORT, "sensor_noise": {"angle": 0.5, "temperature": 1.0}, "sensor_delay": 2}
    e0 = gym.make(f"{family}-v0", **kw).unwrapped
    e1 = gym.make(f"{family}-v1", **kw).unwrapped
    o0, _ = e0.reset(seed=5)
    o1, _ = e1.reset(seed=5)
    n0 = o0.shape[0]
    t = e1.table
    task, target = (
        t.obs_index(TASK_ENTRY[family]),
        t.obs_index([e.key for e in t.entries if e.source == "target"][0]),
    )
    preview = t.obs_index([e.key for e in t.entries if e.source == "preview"][0])
    err, perr = t.obs_index("measured_error"), t.obs_index("measured_preview_error")
    assert err.start == n0 and perr.stop == o1.shape[0]
    for a in _actions(e0, 25, seed=1):
        o0, r0, *_, i0 = e0.step(a)
        o1, r1, *_, i1 = e1.step(a)
        assert np.array_equal(o1[:n0], o0)
        assert r1 == pytest.approx(r0 / V1_REWARD_DIVISOR, rel=1e-12, abs=1e-15)
        assert i1.keys() == i0.keys()
        for k in i0:
            if not k.startswith("reward"):
                assert np.array_equal(i0[k], i1[k]), k
        np.testing.assert_allclose(o1[err], o1[target] - o1[task], atol=1e-4)
        np.testing.assert_allclose(o1[perr], o1[preview] - o1[task], atol=1e-4)


@pytest.mark.parametrize("env_id", V2_IDS)
def test_make_and_make_vec_of_the_newest_ids_do_not_warn(env_id):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        gym.make(env_id).close()
        gym.make_vec(env_id, num_envs=2).close()
    assert [str(x.message) for x in w] == []


@pytest.mark.parametrize("env_id", V1_IDS)
def test_vector_env_rows_equal_single_envs(env_id):
    venv = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **SHORT)
    singles = [gym.make(env_id, **SHORT).unwrapped for _ in range(2)]
    obs, _ = venv.reset(seed=11)
    for i, env in enumerate(singles):
        assert np.array_equal(obs[i], env.reset(seed=11 + i)[0])
    for a in _actions(singles[0], 12, seed=2).reshape(12, 1, -1).repeat(2, axis=1):
        obs, rew, *_ = venv.step(a)
        for i, env in enumerate(singles):
            o, r, *_ = env.step(a[i])
            assert np.array_equal(obs[i], o) and rew[i] == r
    venv.close()


@pytest.mark.parametrize("env_id", V1_IDS)
def test_seeds_are_reproducible_bit_for_bit(env_id):
    runs = []
    for _ in range(2):
        env = gym.make(env_id, **SHORT).unwrapped
        obs = [env.reset(seed=3)[0]]
        obs += [env.step(a)[0] for a in _actions(env, 10, seed=4)]
        runs.append(np.stack(obs))
    assert np.array_equal(*runs)


def test_tiers_change_only_the_task_distribution():
    for fam in ("SmaSpine", "SmaSpine3D", "SmaSpineChain"):
        easy, default, hard = (ENV_SPECS[f"{fam}{t}-v1"].kwargs for t in ("Easy", "", "Hard"))
        shared = {"observe_errors", "error_scale", "energy_weight"}
        assert {k: easy[k] for k in shared} == {k: default[k] for k in shared} == {k: hard[k] for k in shared}
        assert easy["payload_range"] is None and easy["tip_force_range"] is None
        assert hard["domain_randomization"] is True and hard["sensor_delay"] == 1
        env = gym.make(f"{fam}Hard-v1").unwrapped
        assert env.config.domain_randomization and env.config.sensor_delay == 1
        assert gym.make(f"{fam}Hard-v1", sensor_delay=0).unwrapped.config.sensor_delay == 0  # overridable


def test_observe_errors_must_be_a_bool():
    with pytest.raises(ValueError, match="observe_errors"):
        gym.make("SmaSpine-v1", observe_errors="yes")


def test_the_docs_list_every_id_as_registered():
    docs = (ROOT / "docs" / "envs.md").read_text()
    assert markdown_table() in docs
