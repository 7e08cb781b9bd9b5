"""The wire driver's thermal cut-off of the ``-v2`` ids (``thermal_cutoff``, ``step_kernels.cut_hot_wires``).

Spec (``spine_gym/envs/ids.py``, the env classes' Arguments): a wire whose true temperature at the
start of a control period is at or above ``thermal_cutoff`` [K] gets 0 V for that period, whatever
the action; below it, the commanded voltage. The commanded action is kept (it is the observation's
previous action); ``info["voltage"]``, the power and the energy are those delivered. The ``-v2``
ids set 418 K (the temperature limit 423 K − 5 K); the protection is the plant's, so it is the same
for every controller and the registry's controllers bring no guard of their own there.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import spine_gym  # noqa: F401 - registers the ids
from spine_gym.agents.runtime import build_controller, controller_for
from spine_gym.controllers.registry import GUARD_MARGIN_K
from spine_gym.envs import ENV_SPECS
from spine_gym.envs.ids import CUTOFF_MARGIN_K, TEMPERATURE_LIMIT_K
from spine_gym.envs.drive import action_to_volts
from spine_gym.envs.step_kernels import cut_hot_wires

FAMILIES = ("SmaSpine", "SmaSpine3D", "SmaSpineChain")
V2_IDS = [i for i, s in ENV_SPECS.items() if s.version == 2]
CUTOFF = TEMPERATURE_LIMIT_K - CUTOFF_MARGIN_K


def _make(env_id: str, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a -v1 id is out of date (a -v2 exists)
        return gym.make(env_id, **kwargs).unwrapped


def _temps(info) -> np.ndarray:
    return np.asarray(info["temperature"], dtype=float).ravel()


def _volts(info) -> np.ndarray:
    return np.asarray(info["voltage"], dtype=float).ravel()


def _previous_action(env, obs) -> np.ndarray:
    idx = [i for i, n in enumerate(env.observation_names) if n.startswith("previous_action")]
    return obs[idx]


def _full_volts(env) -> np.ndarray:
    """(W,) each wire's voltage at action +1 (``v_max``; a chain's shorter wires a share of it)."""
    return np.broadcast_to(action_to_volts(1.0, env.config.volt_coef), env.action_space.shape)


def _full_voltage_run(env_id: str, seconds: float = 60.0):
    """Every wire commanded to ``v_max`` for ``seconds``: per step (temperature at its start,
    delivered volts, temperature at its end, the observation's previous action)."""
    env = _make(env_id)
    _, info = env.reset(seed=0)
    action = np.ones(env.action_space.shape, dtype=np.float32)
    rows = []
    for _ in range(round(seconds / env.config.control_period)):
        before = _temps(info)
        obs, _, terminated, truncated, info = env.step(action)
        rows.append((before, _volts(info), _temps(info), _previous_action(env, obs)))
        assert not terminated
    return env, rows


def test_the_v2_ids_set_the_cutoff_and_the_others_none():
    for env_id, spec in ENV_SPECS.items():
        expected = CUTOFF if spec.version == 2 else None
        assert spec.kwargs.get("thermal_cutoff") == expected
        assert _make(env_id).config.thermal_cutoff == expected
    assert CUTOFF == 418.0


def test_the_kernel_cuts_a_wire_at_and_above_the_cutoff_only():
    probe = np.array([[1.0, 417.999, 418.0], [2.0, 418.5, 300.0], [3.0, 500.0, 500.0]])
    volts = np.full((3, 2), 4.0)
    cut_hot_wires(np.array([0, 1], dtype=np.int64), volts, probe, 1, 418.0)
    # row 0: below / at; row 1: above / below; row 2 is not stepped (not among the rows)
    np.testing.assert_array_equal(volts, [[4.0, 0.0], [0.0, 4.0], [4.0, 4.0]])
    cut_hot_wires(np.arange(3, dtype=np.int64), volts, probe, 1, np.inf)  # no cut-off: nothing changes
    np.testing.assert_array_equal(volts, [[4.0, 0.0], [0.0, 4.0], [4.0, 4.0]])


@pytest.mark.parametrize("family", FAMILIES)
def test_full_voltage_is_cut_at_the_cutoff_and_the_command_kept(family):
    env, rows = _full_voltage_run(f"{family}Easy-v2")
    n_cut = 0
    for before, volts, _after, previous_action in rows:
        hot = before >= CUTOFF
        np.testing.assert_array_equal(volts, np.where(hot, 0.0, _full_volts(env)))
        np.testing.assert_array_equal(previous_action, 1.0)  # the commanded action, not the delivered
        n_cut += int(hot.sum())
    assert n_cut > 0  # the cut-off acted


@pytest.mark.parametrize("family", FAMILIES)
def test_a_cut_step_delivers_no_power_or_energy(family):
    """With the cut-off 0.5 K above ambient: the first step (wires at ambient) delivers full voltage,
    the next ones (every wire above the cut-off) no voltage, power or energy."""
    env = _make(f"{family}Easy-v2", thermal_cutoff=293.5)
    assert env.config.params.T_E == 293.0
    _, info = env.reset(seed=0)
    action = np.ones(env.action_space.shape, dtype=np.float32)
    _, _, _, _, info = env.step(action)
    assert np.all(_volts(info) == _full_volts(env)) and float(info["energy_J"]) > 0.0
    for _ in range(3):
        assert np.all(_temps(info) >= 293.5)
        _, _, _, _, info = env.step(action)
        assert np.all(_volts(info) == 0.0)
        assert float(info["energy_J"]) == 0.0
        assert np.all(np.asarray(info["power_W"]) == 0.0)


@pytest.mark.parametrize("family", FAMILIES)
def test_full_voltage_for_a_minute_stays_below_the_limit_on_v2_only(family):
    _, rows_v2 = _full_voltage_run(f"{family}-v2")
    _, rows_v1 = _full_voltage_run(f"{family}-v1")
    peak_v2 = max(after.max() for _, _, after, _ in rows_v2)
    peak_v1 = max(after.max() for _, _, after, _ in rows_v1)
    assert CUTOFF <= peak_v2 < TEMPERATURE_LIMIT_K
    assert peak_v1 > TEMPERATURE_LIMIT_K


def test_registry_controllers_bring_no_guard_on_v2_and_theirs_on_v1():
    for family in FAMILIES:
        for version, guard in ((2, None), (1, TEMPERATURE_LIMIT_K - GUARD_MARGIN_K)):
            env_id = f"{family}-v{version}"
            assert build_controller("pid", _make(env_id)).temperature_limit == guard
            assert controller_for("pid", env_id).temperature_limit == guard


def _held_run(env, policy, target: float, steps: int = 600):
    """(temperature at the start, action, delivered volts) of each step of ``policy`` on ``env``."""
    obs, info = env.reset(seed=0, options={"target": target})
    out = []
    for _ in range(steps):
        before = _temps(info)
        action = np.asarray(policy(obs), dtype=np.float32)
        obs, _, _, _, info = env.step(action)
        out.append((before, action, _volts(info)))
    return out


def test_the_cutoff_acts_alike_for_the_pid_and_a_constant_policy():
    """On ``SmaSpine-v2`` the PID (no guard of its own) held at a 55° target drives its wire into the
    cut-off as a constant full-voltage policy does: both get 0 V on every wire at or above it,
    while asking for more."""
    env = _make("SmaSpine-v2")
    pid = build_controller("pid", env)
    full = np.ones(env.action_space.shape, dtype=np.float32)
    for policy in (pid, lambda obs: full):
        asked_while_hot = 0
        for before, action, volts in _held_run(env, policy, target=55.0):
            hot = before >= CUTOFF
            assert np.all(volts[hot] == 0.0)
            np.testing.assert_array_equal(volts[~hot], action_to_volts(action, env.config.volt_coef)[~hot])
            asked_while_hot += int(np.sum(hot & (action > -1.0)))
        assert asked_while_hot > 0


def test_a_cutoff_outside_its_range_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"thermal_cutoff must be in \(293, 423\], got 500"):
        _make("SmaSpine-v2", thermal_cutoff=500.0)
    with pytest.raises(ValueError, match=r"thermal_cutoff must be in \(293, 423\], got 293"):
        _make("SmaSpine3D-v2", thermal_cutoff=293.0)
    with pytest.raises(ValueError, match=r"thermal_cutoff must be in \(293, 400\]"):
        _make("SmaSpineChain-v2", temperature_limit=400.0)  # the -v2 cut-off is above this limit
    with pytest.raises(ValueError, match="thermal_cutoff must be a real number"):
        _make("SmaSpine-v2", thermal_cutoff="hot")
    assert _make("SmaSpine-v2", thermal_cutoff=423.0).config.thermal_cutoff == 423.0  # the limit itself
    assert _make("SmaSpine-v2", thermal_cutoff=None).config.thermal_cutoff is None  # switched off


@pytest.mark.parametrize("env_id", V2_IDS)
def test_vector_env_rows_equal_single_envs_with_the_cutoff_acting(env_id):
    kw = {"episode_duration": 6.0, "thermal_cutoff": 320.0}  # acts within the steps below
    venv = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **kw)
    singles = [_make(env_id, **kw) for _ in range(2)]
    obs, _ = venv.reset(seed=11)
    for i, env in enumerate(singles):
        assert np.array_equal(obs[i], env.reset(seed=11 + i)[0])
    actions = np.random.default_rng(2).uniform(0.0, 1.0, (40, 2, *singles[0].action_space.shape))
    n_cut = 0
    for a in actions.astype(np.float32):
        obs, rew, _, _, infos = venv.step(a)
        for i, env in enumerate(singles):
            o, r, _, _, info = env.step(a[i])
            assert np.array_equal(obs[i], o) and rew[i] == r
            assert np.array_equal(np.asarray(infos["voltage"][i]).ravel(), _volts(info))
            n_cut += int(np.sum(_volts(info) == 0.0))
    assert n_cut > 0
    venv.close()
