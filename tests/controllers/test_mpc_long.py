"""The long-horizon MPC against its spec: settings, bounds, warm start, cost terms, predictor, registry."""

import gymnasium as gym
import numpy as np
import pytest

import spine_gym  # noqa: F401 - registers the env ids
from spine_gym.agents.runtime import (
    ORACLE_NAMES,
    VALIDATION_SEED_BASE,
    build_controller,
    make_env,
    run_episode,
)
from spine_gym.controllers import LongHorizonMPC, LongMPCConfig
from spine_gym.controllers.mpc_long import shifted
from spine_gym.controllers.registry import baselines_for, get_spec
from spine_gym.physics.planar import columns as PL
from spine_gym.physics.planar.rollout import rollout_graded, rollout_many_serial

ENV_ID = "SmaSpineEasy-v2"
SMALL = {"horizon": 4.0, "block": 0.5, "n_samples": 8}  # a cheap planner for closed-loop tests


def _env(**kw):
    return gym.make(ENV_ID, **{"episode_duration": 10.0, **kw}).unwrapped


def _ctrl(env, **settings):
    return LongHorizonMPC(env.config, settings=LongMPCConfig(**{**SMALL, **settings}))


# ---------------------------------------------------------------- settings
@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"horizon": 0.1}, ("horizon", "[0.2, 60]")),
        ({"horizon": 61.0}, ("horizon", "[0.2, 60]")),
        ({"horizon": 15.0, "block": 20.0}, ("block", "[0.1, 10]")),
        ({"horizon": 2.0, "block": 4.0}, ("block", "horizon = 2")),
        ({"horizon": 15.0, "block": 2.0}, ("horizon", "whole number of blocks")),
        ({"block": 0.0}, ("block", "[0.1, 10]")),
        ({"n_samples": 3}, ("n_samples", "[4, 10000]")),
        ({"n_samples": True}, ("n_samples", "[4, 10000]")),
        ({"iterations": 0}, ("iterations", "[1, 20]")),
        ({"noise_std": 0.0}, ("noise_std", "(0, 10]")),
        ({"w_energy": -1.0}, ("w_energy", "[0, 1e+09]")),
        ({"plan_tol_x": 0.5}, ("plan_tol_x", "(0, 0.1]")),
        ({"temp_margin": float("nan")}, ("temp_margin", "[0, 100]")),
        ({"fine_steps": 101}, ("fine_steps", "[0, 100]")),
        ({"extrapolate": -1.0}, ("extrapolate", "[0, 60]")),
    ],
)
def test_settings_out_of_range_raise_one_line_naming_parameter_and_range(kwargs, words):
    with pytest.raises(ValueError) as err:
        LongMPCConfig(**kwargs)
    msg = str(err.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg


def test_block_must_be_whole_control_periods_of_the_env():
    env = _env()
    msg = r"^block must be a whole number of control periods \(0.1 s\), got 0.25$"
    with pytest.raises(ValueError, match=msg):
        LongHorizonMPC(env.config, settings=LongMPCConfig(horizon=1.0, block=0.25))
    with pytest.raises(ValueError, match="mode must be one of"):
        LongHorizonMPC(env.config, mode="oracle")
    with pytest.raises(ValueError, match="v_max comes from config"):
        LongHorizonMPC(env.config, v_max=3.0)


def test_defaults_span_the_thermal_time_constant():
    s = LongMPCConfig()
    assert s.horizon >= 10.0 and s.n_blocks == round(s.horizon / s.block)
    assert s.w_energy > 0.0


# ---------------------------------------------------------------- bounds and warm start
def test_samples_plan_and_actions_stay_in_the_envelope():
    env = _env(v_max=4.0)
    ctrl = _ctrl(env, noise_std=5.0)  # wide noise: clipping must hold
    obs, _ = env.reset(seed=VALIDATION_SEED_BASE)
    for _ in range(12):
        volts = ctrl.sample()
        assert volts.min() >= 0.0 and volts.max() <= 4.0
        action, _ = ctrl.predict(obs)
        assert np.all(np.abs(action) <= 1.0)
        assert ctrl.plan.min() >= 0.0 and ctrl.plan.max() <= 4.0
        obs, *_ = env.step(action)
    # the extremes are among the samples: all off and full drive of either wire at v_max
    targets = np.linspace(-30.0, 30.0, ctrl.plan.shape[0])
    reference = ctrl.feedforward(targets)
    volts = ctrl.sample(reference)
    assert volts.min() >= 0.0 and volts.max() <= 4.0
    assert np.array_equal(volts[0], ctrl.plan) and np.array_equal(volts[4], reference)
    assert np.all(volts[1] == 0.0)
    assert np.all(volts[2] == [4.0, 0.0]) and np.all(volts[3] == [0.0, 4.0])


def test_feedforward_drives_the_wire_that_bends_toward_the_target():
    env = _env()
    ctrl = _ctrl(env)
    ff = ctrl.feedforward(np.array([-20.0, 0.0, 10.0, 20.0]))
    assert ff[0, 0] == 0.0 and ff[0, 1] > 0.0  # negative target: the left wire
    assert np.all(ff[1] == 0.0)
    assert ff[2, 1] == 0.0 and 0.0 < ff[2, 0] < ff[3, 0] <= env.config.v_max
    assert ff[0, 1] == pytest.approx(ff[3, 0])  # the model is mirror-symmetric


def test_warm_start_is_the_previous_plan_shifted_by_one_block():
    env = _env()
    ctrl = _ctrl(env, fine_steps=0)  # block 0.5 s = 5 control periods, one rollout step per block
    assert ctrl.block_steps == 5
    improved = []
    inner = ctrl._improve

    def recording(problem, reference=None):
        inner(problem, reference)
        improved.append(ctrl.plan.copy())

    ctrl._improve = recording
    obs, _ = env.reset(seed=VALIDATION_SEED_BASE)
    lengths = []
    for k in range(11):
        lengths.append(ctrl.step_lengths()[0])
        action, _ = ctrl.predict(obs)
        obs, *_ = env.step(action)
        if (k + 1) % 5 == 0:  # block used up: the next plan starts from this one, one block on
            assert np.array_equal(ctrl.plan, shifted(improved[-1]))
            assert np.array_equal(ctrl.plan[-1], improved[-1][-1])
        else:  # inside a block the plan is kept as improved
            assert np.array_equal(ctrl.plan, improved[-1])
    assert np.allclose(lengths, [0.5, 0.4, 0.3, 0.2, 0.1, 0.5, 0.4, 0.3, 0.2, 0.1, 0.5])
    np.testing.assert_allclose(ctrl.step_lengths()[1:], 0.5)
    ctrl.reset()
    assert ctrl.step_in_block == 0 and np.all(ctrl.plan == 0.0)


def test_grid_scores_the_first_periods_one_by_one_then_once_per_block():
    env = _env()
    ctrl = _ctrl(env, fine_steps=3)  # blocks of 5 periods, 8 blocks after the current one
    dts, blocks = ctrl.grid()
    np.testing.assert_allclose(dts, [0.1, 0.1, 0.1, 0.2] + [0.5] * 8)
    assert blocks.tolist() == [0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8]
    ctrl.step_in_block = 3  # two periods left in the current block
    dts, blocks = ctrl.grid()
    np.testing.assert_allclose(dts, [0.1, 0.1, 0.1, 0.4] + [0.5] * 7)
    assert blocks.tolist() == [0, 0, 1, 1, 2, 3, 4, 5, 6, 7, 8]
    np.testing.assert_allclose(dts.sum(), 0.2 + 4.0)


# ---------------------------------------------------------------- cost
def test_cost_terms_track_energy_and_temperature_above_the_cutoff_margin():
    env = _env()
    ctrl = LongHorizonMPC(env.config, settings=LongMPCConfig(w_track=1.0, w_energy=2.0, w_temp=3.0))
    assert ctrl._t_lim == pytest.approx(env.config.thermal_cutoff - 5.0)  # -v2: below the driver's cut-off
    dts = np.array([0.5, 1.0])
    sq = np.array([[4.0, 1.0]])
    temp = np.full((1, 2, 2), 300.0)
    ok = np.zeros(1, dtype=np.int64)
    base = ctrl.cost(sq, np.array([0.0]), temp, ok, dts)
    assert base[0] == pytest.approx(4.0 * 0.5 + 1.0 * 1.0)  # time-weighted squared error
    assert ctrl.cost(sq, np.array([10.0]), temp, ok, dts)[0] == pytest.approx(base[0] + 20.0)
    hot = temp.copy()
    hot[0, 1, 0] = ctrl._t_lim + 2.0  # one wire 2 K over T_lim during the 1-s step
    assert ctrl.cost(sq, np.array([0.0]), hot, ok, dts)[0] == pytest.approx(base[0] + 3.0 * 4.0 * 1.0)
    assert ctrl.cost(sq, np.array([0.0]), temp, np.array([3]), dts)[0] >= 1e12  # failed rollout
    v1 = LongHorizonMPC(gym.make("SmaSpineEasy-v1").unwrapped.config)
    assert v1._t_lim == pytest.approx(v1.env_config.temperature_limit - 5.0)  # no cut-off: the limit


def test_energy_term_lowers_the_energy_spent():
    env = _env()
    energies = []
    for w in (0.0, 10.0):
        ctrl = _ctrl(env, w_energy=w)
        energies.append(sum(run_episode(env, ctrl, seed=VALIDATION_SEED_BASE + 1).energy_J))
    assert energies[1] < 0.9 * energies[0]


# ---------------------------------------------------------------- predictor
def test_graded_rollout_is_the_env_step_loop_on_equal_steps_and_close_on_long_ones():
    env = _env()
    env.reset(seed=VALIDATION_SEED_BASE)
    for _ in range(20):
        env.step(np.array([0.6, -1.0], dtype=np.float32))
    snap = env.snapshot()
    state0, kp = np.array(snap.state), np.array(snap.kp)  # writable, as the MPC passes them (one compile)
    n_seg, ks = env.config.params.n_seg, env.config.solver.to_kernel()
    rng = np.random.default_rng(1)
    blocks = rng.uniform(0.0, 5.0, (4, 5, 2))  # 5 one-second blocks
    fine = np.repeat(blocks, 10, axis=1)

    def out(b, h):
        return (np.empty((b, PL.state_size(n_seg))), np.empty((b, h)), np.empty((b, h, 2)),
                np.empty((b, h, 2)), np.empty(b, dtype=np.int64))  # fmt: skip

    ref = out(4, 50)
    resolve = np.zeros(50, dtype=np.bool_)
    resolve[0] = True
    loads = np.zeros((n_seg, 2))
    rollout_many_serial(state0, kp, ks, np.ascontiguousarray(fine[:, :, 0]),
                        np.ascontiguousarray(fine[:, :, 1]), np.zeros((50, n_seg, 2)), resolve,
                        0.1, 1, *ref)  # fmt: skip
    same = out(4, 50)
    rollout_graded(state0, kp, ks, np.ascontiguousarray(fine[:, :, 0]),
                   np.ascontiguousarray(fine[:, :, 1]), loads, np.full(50, 0.1), *same)  # fmt: skip
    for a, b in zip(ref[1:], same[1:], strict=True):
        assert np.array_equal(a, b)
    coarse = out(4, 5)
    rollout_graded(state0, kp, ks, np.ascontiguousarray(blocks[:, :, 0]),
                   np.ascontiguousarray(blocks[:, :, 1]), loads, np.full(5, 1.0), *coarse)  # fmt: skip
    assert np.all(coarse[4] == 0)
    assert np.degrees(np.abs(coarse[1] - ref[1][:, 9::10])).max() < 1.0
    assert np.abs(coarse[2] - ref[2][:, 9::10]).max() < 1.0


# ---------------------------------------------------------------- causality and registry
def test_estimated_mode_plans_from_the_observation_alone():
    env = _env()
    ctrl = _ctrl(env)  # no env bound: nothing but the observation to read
    obs, _ = env.reset(seed=VALIDATION_SEED_BASE)
    for _ in range(3):
        action, _ = ctrl.predict(obs)
        obs, *_ = env.step(action)
    oracle = LongHorizonMPC(env.config, "oracle_causal", settings=LongMPCConfig(**SMALL))
    with pytest.raises(ValueError, match="oracle_causal mode needs the env"):
        oracle.predict(obs)


def test_registry_entries_are_opt_in_and_unguarded_on_v2():
    env = make_env(env_id=ENV_ID)
    ctrl = build_controller("mpc_long", env)
    assert isinstance(ctrl, LongHorizonMPC) and ctrl.mode == "estimated"
    assert ctrl.temperature_limit is None  # the -v2 plant cuts hot wires itself
    assert build_controller("mpc_long_oracle_causal", env).mode == "oracle_causal"
    assert "privileged" in get_spec("mpc_long_oracle_causal").description
    assert "mpc_long" not in baselines_for(ENV_ID)
    assert not {"mpc_long", "mpc_long_oracle_causal"} & set(ORACLE_NAMES)
