"""SmaSpine3D-v0 and SmaSpineChain-v0: checkers, vector ≡ single, seeds, snapshots, fuzzing, errors,
workspace and reach tables (against SPATIAL.md and the planar model), the declarative table."""

from __future__ import annotations

import dataclasses
import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
import torch
from gymnasium.utils.env_checker import check_env
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import spine_gym  # noqa: F401  (registers the ids)
from spine_gym import ModelParams, simulate
from spine_gym.envs import BendTarget, ChainTarget, LoadSchedule, SmaSpine3DEnv, SmaSpineChainEnv
from spine_gym.envs.loads import TipForceEvent
from spine_gym.envs.planar import OBS_NAMES
from spine_gym.envs.reach import REACH_3D, REACH_CHAIN, hold
from spine_gym.envs.sb3 import make_sb3_vec_env
from spine_gym.envs.spatial import (
    ChainConfig,
    Spine3DBatch,
    Spine3DConfig,
    workspace_low_mm,
    workspace_radius_mm,
)
from spine_gym.envs.table import Entry, Table
from spine_gym.envs.targets_spatial import arc_tip_position
from spine_gym.layout import SpineLayout
from spine_gym.physics import columns as L
from spine_gym.simulate_spatial import simulate_spatial

torch.set_num_threads(1)

IDS = ["SmaSpine3D-v0", "SmaSpineChain-v0"]
SHORT = {"episode_duration": 3.0}  # 30 steps


def _actions(env_id, n, seed, size=None):
    w = 4 if env_id == "SmaSpine3D-v0" else 8
    shape = (n, w) if size is None else (n, size, w)
    return np.random.default_rng(seed).uniform(-1.0, 1.0, shape)


def _rollout(env, actions):
    out = []
    for a in actions:
        obs, r, te, tr, info = env.step(a)
        out.append((obs.copy(), r, te, tr, {k: np.copy(v) for k, v in info.items()}))
    return out


def _same(a, b):
    for (o1, r1, te1, tr1, i1), (o2, r2, te2, tr2, i2) in zip(a, b, strict=True):
        assert np.array_equal(o1, o2) and r1 == r2 and te1 == te2 and tr1 == tr2
        assert i1.keys() == i2.keys()
        for k in i1:
            assert np.array_equal(i1[k], i2[k]), k


# ---------------------------------------------------------------- checkers
@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_and_sb3_checkers_are_silent(env_id):
    # made outside the filter: gym.make warns that a -v0 id has a newer version (Gymnasium's convention)
    envs = gym.make(env_id, render_mode="rgb_array", **SHORT).unwrapped, gym.make(env_id, **SHORT).unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(envs[0])
        sb3_check_env(envs[1], warn=True)


@pytest.mark.parametrize("env_id", IDS)
def test_spaces_and_tables_agree(env_id):
    env = gym.make(env_id).unwrapped
    t = env.table
    assert env.observation_space.shape == (t.obs_dim,) == (len(env.observation_names),)
    assert env.action_space.shape == (4 * env.config.n_modules,)
    assert np.array_equal(env.observation_space.low, t.low) and np.all(t.low < t.high)
    # the docstring's observation table is the table's own rendering
    assert t.markdown_observation().replace("\n", "\n    ") in type(env).__doc__
    obs, info = env.reset(seed=1)
    assert set(info) == {*t.info_keys, "status"}
    task = t.task.key
    assert np.allclose(obs[env.obs_index(task)], info[task], atol=1e-4)  # no noise: measured = true
    assert np.array_equal(obs[env.obs_index("previous_action")], -np.ones(env.action_space.shape))


def test_planar_table_keeps_the_contract_layout():
    env = gym.make("SmaSpine-v0").unwrapped
    assert env.table.markdown_observation().replace("\n", "\n    ") in type(env).__doc__
    assert env.obs_index("previous_action") == slice(6, 8)
    assert OBS_NAMES == (
        "angle", "target", "temperature_right", "temperature_left", "angle_rate", "target_preview",
        "previous_action_right", "previous_action_left", "resistance_right", "resistance_left",
    )  # fmt: skip


class _CostObserved(Spine3DConfig):
    """SmaSpine3D-v0 with one edit of its table: the cost entry gets observation bounds."""

    def table(self) -> Table:
        t = super().table()
        entries = [dataclasses.replace(e, obs=(0.0, 1e4)) if e.key == "cost" else e for e in t.entries]
        return Table(entries, t.task.key, self.noise_sigma)


def test_adding_an_observation_entry_is_one_edit():
    base = Spine3DConfig().table()
    batch = Spine3DBatch(_CostObserved(temperature_limit=300.0), 1, parallel=False)
    t = batch.table
    assert t.obs_dim == base.obs_dim + 1 and t.obs_names[: base.obs_dim] == base.obs_names
    assert t.obs_index("cost") == slice(base.obs_dim, base.obs_dim + 1)
    assert "| ``cost`` |" in t.markdown_observation()
    rng = np.random.default_rng(0)
    batch.reset_env(0, rng)
    for _ in range(30):
        obs, _, _, _, info = batch.step(np.ones((1, 4)), [rng])
    assert info["cost"][0] > 0.0 and obs[0, t.obs_index("cost")][0] == np.float32(info["cost"][0])
    with pytest.raises(ValueError, match="source must be one of"):
        Entry("x", "nonsense", "-", "doc", ("x",))


@pytest.mark.parametrize("env_id", IDS)
def test_rewards_infos_and_observations_follow_the_documented_formulas(env_id):
    # NumPy reference of the writer, from the docstrings' formulas and the model parameters
    env = gym.make(env_id, episode_duration=6.0, cost_weight=0.01, temperature_limit=330.0).unwrapped
    cfg, p = env.config, env.config.params
    obs, info = env.reset(seed=4)
    lay = cfg.layout
    l0 = np.array([m.L0 for m in lay.modules for _ in m.wires])
    assert np.allclose(info["resistance"], p.lam_M * l0 / p.wire_area, rtol=1e-12)  # martensite at reset
    scale = lay.voltage_scale
    e_ref = np.sum(p.n_w * (cfg.v_max * scale) ** 2 / (min(p.lam_A, p.lam_M) * l0 / p.wire_area)) * 0.1
    task, d = env.table.task.key, env.table.task_dim
    tgt_key = "target_deg" if d == 2 else "target_mm"
    target = env.target_profile
    km = env._core.kms[0]
    grid = (lambda t: target(t)) if d == 2 else (lambda t: target.position(t, km))
    rng = np.random.default_rng(0)
    prev = info[task]
    for k in range(1, 41):
        a = rng.uniform(-1.3, 1.3, env.action_space.shape)
        obs, r, te, tr, info = env.step(a)
        ac = np.clip(a, -1.0, 1.0)
        assert np.allclose(info["voltage"], (ac + 1.0) / 2.0 * cfg.v_max * scale, rtol=1e-12)
        assert info["energy_J"] == pytest.approx(info["power_W"].sum() * 0.1, rel=1e-12)
        err = grid(0.1 * k) - info[task]
        assert np.allclose(info[tgt_key], grid(0.1 * k), atol=1e-9)
        assert info["reward_tracking"] == pytest.approx(-np.linalg.norm(err) / cfg.error_scale, rel=1e-12)
        assert info["reward_energy"] == pytest.approx(-0.5 * info["energy_J"] / e_ref, rel=1e-9)
        cost = np.maximum(info["temperature"] - 330.0, 0.0).sum()
        assert info["cost"] == pytest.approx(cost, rel=1e-12, abs=1e-12)
        assert r == pytest.approx(info["reward_tracking"] + info["reward_energy"] - 0.01 * cost, rel=1e-12)
        # observation: the table's entries (no noise, no delay: measured = true)
        assert np.allclose(obs[env.obs_index(task)], info[task], rtol=1e-6, atol=1e-4)
        assert np.allclose(obs[env.obs_index("temperature")], info["temperature"], rtol=1e-6)
        assert np.allclose(obs[env.obs_index("previous_action")], ac, atol=1e-7)
        rate_key = "bending_rate" if d == 2 else "tip_velocity"
        assert np.allclose(obs[env.obs_index(rate_key)], (info[task] - prev) / 0.1, rtol=1e-5, atol=1e-3)
        pv = "target_preview_deg" if d == 2 else "target_preview_mm"
        assert np.allclose(obs[env.obs_index(pv)], grid(min(0.1 * k + 1.0, 6.0)), rtol=1e-6, atol=1e-4)
        prev = info[task]
    assert info["cost"] > 0.0  # the limit was crossed: the cost term was exercised


# ---------------------------------------------------------------- vector ≡ single, seeds, snapshots
@pytest.mark.parametrize("env_id", IDS)
def test_vector_row_i_equals_single_env_seeded_seed_plus_i(env_id):
    n, seed, steps = 3, 11, 35  # past the 30-step episode: the autoreset row is compared too
    kw = {**SHORT, "sensor_noise": {"angle": 0.2, "temperature": 0.5}, "sensor_delay": 1}
    venv = gym.make_vec(env_id, num_envs=n, **kw)
    acts = _actions(env_id, steps, 0, n)
    obs_v, _ = venv.reset(seed=seed)
    rows = [venv.step(acts[k]) for k in range(steps)]
    for i in range(n):
        env = gym.make(env_id, max_episode_steps=30, **kw)
        obs, _ = env.reset(seed=seed + i)
        assert np.array_equal(obs, obs_v[i])
        tr = False
        for k in range(steps):
            if k == 30:  # truncated at 30 steps; the vector env resets this row on the next step
                assert tr
                obs, _ = env.reset()
                assert np.array_equal(obs, rows[k][0][i]) and rows[k][1][i] == 0.0
                continue
            o, r, te, tr, info = env.step(acts[k, i])
            ov, rv, tev, trv, iv = rows[k]
            assert np.array_equal(o, ov[i]) and r == rv[i] and te == tev[i] and tr == trv[i]
            assert np.array_equal(info["voltage"], iv["voltage"][i])


@pytest.mark.parametrize("env_id", IDS)
def test_seeded_rollouts_are_bit_identical_and_snapshot_restore_continues_exactly(env_id):
    kw = {**SHORT, "sensor_noise": {"temperature": 1.0}, "domain_randomization": True}
    acts = _actions(env_id, 20, 3)
    a, b = gym.make(env_id, **kw).unwrapped, gym.make(env_id, **kw).unwrapped
    a.reset(seed=5)
    b.reset(seed=5)
    _same(_rollout(a, acts), _rollout(b, acts))
    a.reset(seed=6)
    _rollout(a, acts[:8])
    snap = a.snapshot()
    first = _rollout(a, acts[8:])
    a.restore(snap)
    _same(first, _rollout(a, acts[8:]))
    c = pickle.loads(pickle.dumps(b))  # a pickled env continues as the original
    _same(_rollout(b, acts[:5]), _rollout(c, acts[:5]))
    v = gym.make_vec(env_id, num_envs=2, **kw).unwrapped
    v.reset(seed=0)
    v.restore(1, snap)  # a single env's snapshot goes into a sub-env
    assert v.snapshot(1).step_index == 8
    with pytest.raises(ValueError, match="does not fit|lacks"):
        gym.make("SmaSpine-v0").unwrapped.restore(snap)


def test_a_failed_step_is_rolled_back_and_terminates_without_nan():
    crush = LoadSchedule(tip_force_events=((1.0, math.inf, (0.0, 0.0, -8.0)),), dim=3)  # past buckling
    env = gym.make("SmaSpine3D-v0")
    env.reset(seed=0, options={"loads": crush, "target": (0.0, 0.0)})
    for _ in range(30):
        obs, r, te, tr, info = env.step(np.full(4, -1.0))
        assert np.isfinite(obs).all() and math.isfinite(r)
        if te:
            break
    assert te and info["status"] != L.OK and info["status_text"]
    assert info["time"] <= 1.1


# ---------------------------------------------------------------- fuzzing
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    env_id=st.sampled_from(IDS),
    seed=st.integers(0, 2**16),
    amp=st.sampled_from([1.0, 1e3, 1e9]),
    force=st.floats(0.0, 20.0),
    payload=st.floats(0.0, 0.3),
)
# found by this test: the spatial core returned OK with a NaN state at step 14 (its
# control.step_spine now rolls such a step back and terminates with ERR_NONFINITE)
@example(env_id="SmaSpineChain-v0", seed=65535, amp=1000.0, force=0.125, payload=0.1875)
def test_fuzz_extreme_actions_and_3d_loads_give_no_nan_and_no_crash(env_id, seed, amp, force, payload):
    env = gym.make(
        env_id, episode_duration=1.5, tip_force_range=(force, force), tip_force_count=(1, 3),
        tip_force_duration=(0.2, 1.0), payload_range=(payload, payload), v_max=8.0,
    )  # fmt: skip
    try:
        obs, _ = env.reset(seed=seed)
    except ValueError as e:  # a payload the straight chain cannot carry: the documented error
        assert "cannot be solved" in str(e)
        return
    rng = np.random.default_rng(seed)
    for _ in range(15):
        a = rng.choice([-amp, amp], size=env.action_space.shape) * rng.uniform(0, 1, env.action_space.shape)
        obs, r, te, tr, info = env.step(a)
        assert np.isfinite(obs).all() and math.isfinite(r)
        assert np.all(info["voltage"] <= 8.0 + 1e-12) and np.all(info["voltage"] >= 0.0)
        assert env.observation_space.contains(obs)
        if te or tr:
            break


# ---------------------------------------------------------------- bad arguments
@pytest.mark.parametrize(
    ("env_id", "kwargs", "match"),
    [
        ("SmaSpine3D-v0", {"target_range": (0.0, 70.0)}, r"target_range\[1\] must be in \[0, 60\]"),
        ("SmaSpine3D-v0", {"target_kinds": ("sine",)}, "target_kinds must be a non-empty subset"),
        ("SmaSpine3D-v0", {"target_period_range": (0.1, 5.0)}, r"target_period_range\[0\] must be in"),
        ("SmaSpine3D-v0", {"v_max": 9.0}, r"v_max must be in \(0, 8\]"),
        ("SmaSpine3D-v0", {"sensor_noise": {"position": 1.0, "bogus": 1}}, "sensor_noise must be None or"),
        ("SmaSpineChain-v0", {"n_modules": 0}, r"n_modules must be an integer in \[1, 100\]"),
        ("SmaSpineChain-v0", {"params": ModelParams(n_seg=60, L0=2.2)}, "load factor"),
        ("SmaSpineChain-v0", {"module_bend_limit": 40.0}, r"module_bend_limit must be in \[0, 30\]"),
    ],
)
def test_bad_arguments_raise_documented_value_errors(env_id, kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make(env_id, **kwargs)


def test_bad_actions_and_reset_options_raise_value_errors():
    env = gym.make("SmaSpine3D-v0").unwrapped
    with pytest.raises(ValueError, match="target"):
        env.reset(seed=0, options={"target": (1.0, 2.0, 3.0)})
    with pytest.raises(ValueError, match="dim = 3"):
        env.reset(seed=0, options={"loads": LoadSchedule(payload=0.01)})
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        env.step(np.zeros(2))
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([0.0, np.nan, 0.0, 0.0]))
    chain = gym.make("SmaSpineChain-v0").unwrapped
    with pytest.raises(ValueError, match=r"\(2, 2\) module bending"):
        chain.reset(seed=0, options={"target": (10.0, 0.0)})
    with pytest.raises(ValueError, match="force must have dim = 3"):
        LoadSchedule(tip_force_events=(TipForceEvent(0.0, 1.0, (1.0, 0.0)),), dim=3)
    with pytest.raises(ValueError, match=r"\|b\| <= 90"):
        BendTarget("circle", amplitude=95.0)


# ---------------------------------------------------------------- targets and workspace
def test_arc_kinematics_puts_the_tip_on_the_circle_of_the_bend():
    # SPATIAL.md §2: equal segment rotations ω = b/N make a circular arc of the module's length
    lay = SpineLayout.seed()
    km = lay.to_kernel()[2]
    for theta, beta in ((30.0, 0.0), (50.0, 120.0)):
        r = math.radians(beta)
        tip = arc_tip_position(np.array([[theta * math.cos(r), theta * math.sin(r)]]), km)
        rad = lay.length / math.radians(theta) * 1000.0
        h = rad * (1.0 - math.cos(math.radians(theta)))
        assert np.allclose(
            tip, [h * math.cos(r), h * math.sin(r), rad * math.sin(math.radians(theta))], atol=1e-9
        )


def test_bend_targets_stay_in_their_range_and_circles_keep_the_magnitude():
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 60.0, 601)
    kinds = set()
    for _ in range(60):
        tgt = BendTarget.sample(rng, 60.0, (10.0, 40.0))
        kinds.add(tgt.kind)
        mag = np.hypot(*tgt(t).T)
        assert mag.max() <= 40.0 + 1e-9
        if tgt.kind == "circle":
            assert np.allclose(mag, tgt.amplitude)
        if tgt.kind == "steps":
            assert mag.min() >= 10.0 - 1e-9
    assert kinds == {"steps", "circle", "figure8"}


def test_chain_targets_lie_in_the_documented_workspace_which_the_model_reaches():
    cfg = ChainConfig()
    km = cfg.layout.to_kernel()[2]
    rng = np.random.default_rng(1)
    t = np.linspace(0.0, 60.0, 121)
    radius, z_low = workspace_radius_mm(cfg), workspace_low_mm(cfg)
    for _ in range(40):
        tgt = ChainTarget.sample(rng, 60.0, cfg.n_modules, cfg.module_bend_limit)
        assert np.hypot(*tgt.bends(t).reshape(-1, 2).T).max() <= cfg.module_bend_limit + 1e-9
        p = tgt.position(t, km)
        assert np.hypot(p[:, 0], p[:, 1]).max() <= radius + 1e-6 and p[:, 2].min() >= z_low - 1e-6
    # the model holds every module at the bend limit (the reach row at 20°), and its tip is where
    # the arc kinematics of its own module bends puts it (gravity bends the arcs: 3.4 mm)
    lay = SpineLayout.chain(cfg.n_modules)
    rows = [r for r in REACH_CHAIN if abs(r.theta - cfg.module_bend_limit) < 0.5]
    assert {r.direction for r in rows} == {"axis", "diagonal"}
    for row in rows:  # toward a wire and between two
        theta, _ = hold(lay, row.direction, row.voltage)
        assert theta >= cfg.module_bend_limit
    row = next(r for r in rows if r.direction == "diagonal")
    res = simulate_spatial(60.0, np.tile([row.voltage, row.voltage, 0, 0], 2) * 0.5, layout=lay)
    arc = arc_tip_position(res.module_bending_deg[-1], km)
    assert np.linalg.norm(arc - 1000.0 * res.tip_position[-1]) < 5.0
    assert ChainConfig().layout.load_factor < 0.5  # the default chain stands with margin (SPATIAL.md §6)


# ---------------------------------------------------------------- the reach tables
def test_reach_table_3d_rows_are_the_model_and_the_axis_rows_the_planar_model():
    lay = SpineLayout.seed()
    for row in (r for r in REACH_3D if abs(r.theta - 40.0) < 0.5):
        theta, again = hold(lay, row.direction, row.voltage)
        assert abs(theta - row.theta) < 0.02 and abs(again.temperature - row.temperature) < 0.05
        if row.direction == "axis":  # SPATIAL.md §7.1: toward a wire = the planar pair
            planar = simulate(60.0, row.voltage, 0.0)
            assert abs(planar.angle_deg[-1] - row.theta) < 0.05
            assert abs(planar.temperature_right[-1] - row.temperature) < 0.05
        else:  # symmetric: the tip points exactly between the two wires
            assert again.tip_mm[0] == pytest.approx(again.tip_mm[1], abs=1e-6)


# ---------------------------------------------------------------- rendering, registration
def dark_blue(frame: np.ndarray) -> int:
    """Pixels near the hot end of wire 0's colour map (Blues: RGB ≈ (8, 48, 107))."""
    r, g, b = (frame[..., c].astype(int) for c in range(3))
    return int(((r < 60) & (g < 100) & (b > 80) & (b < 160)).sum())


@pytest.mark.parametrize("env_id", IDS)
def test_rgb_array_frames_show_the_state(env_id):
    env = gym.make(env_id, render_mode="rgb_array", temperature_limit=300.0, **SHORT)
    env.reset(seed=0)
    f0 = env.render()
    a = -np.ones(env.action_space.shape)
    a[0] = 1.0
    for _ in range(20):
        env.step(a)
    f1 = env.render()
    assert f0.shape == f1.shape == (480, 480, 3) and f0.dtype == np.uint8
    assert (f0 != f1).any()
    # the heated wire 0 is drawn at the dark end of its own (blue) colour map
    assert dark_blue(f1) > 20 and dark_blue(f1) > 2 * dark_blue(f0)
    env.close()


def test_ids_classes_and_sb3_adapter():
    assert isinstance(gym.make("SmaSpine3D-v0").unwrapped, SmaSpine3DEnv)
    assert isinstance(gym.make("SmaSpineChain-v0").unwrapped, SmaSpineChainEnv)
    venv = make_sb3_vec_env(2, seed=0, env_id="SmaSpineChain-v0", env_kwargs=SHORT)
    obs = venv.reset()
    assert obs.shape == (2, 40)
    for _ in range(30):
        obs, r, done, infos = venv.step(np.zeros((2, 8)))
    assert done.all() and "terminal_observation" in infos[0] and infos[0]["TimeLimit.truncated"]
    with pytest.raises(ValueError, match="env_id must be one of"):
        make_sb3_vec_env(1, env_id="SmaSpine4D-v0")
