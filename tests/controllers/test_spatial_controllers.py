"""Spatial baselines (spine_gym.controllers.spatial) on SmaSpine3D-v0 and SmaSpineChain-v0.

Checked against the spec, not the code's output: heating wire j bends its module toward its
azimuth ψ_j (SPATIAL.md §3), so a command along +x must heat wire 0 only, +y wire 1, and so on;
the chain's references put the arcs' tip on the target (spine_gym.kinematics, IK(FK(x)) = x);
in closed loop on the envs the PID holds a constant 3-D target better than the open-loop step.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import spine_gym  # noqa: F401 - registers the envs
from spine_gym import SpineLayout
from spine_gym.controllers.spatial import (
    SpatialBangBangController,
    SpatialPIDController,
    SpatialSignals,
    SpatialStepController,
)
from spine_gym.kinematics import arc_chain_tip

SEED = SpineLayout()
SIG3D = SpatialSignals(
    SEED, "tip_bending", bending=[0, 1], target=[2, 3], temperature=[4, 5, 6, 7], v_max=5.0
)


def _obs3d(bend=(0.0, 0.0), target=(0.0, 0.0), temps=(293.0,) * 4):
    return np.array([*bend, *target, *temps], dtype=np.float64)


@pytest.mark.parametrize(
    "target, wire",
    [((10.0, 0.0), 0), ((0.0, 10.0), 1), ((-10.0, 0.0), 2), ((0.0, -10.0), 3)],
)
def test_a_command_along_an_axis_heats_the_wire_of_that_azimuth(target, wire):
    pid = SpatialPIDController(SIG3D, kp=0.2, ki=0.0, bias=0.0)
    a, _ = pid.predict(_obs3d(target=target))
    volts = (a + 1.0) / 2.0 * 5.0
    assert volts[wire] == pytest.approx(2.0, abs=1e-6)  # kp * 10 deg
    assert np.delete(volts, wire) == pytest.approx(0.0, abs=1e-6)
    relay = SpatialBangBangController(SIG3D, v_on=3.0, band=1.0, v_hold=0.5)
    v = (relay.predict(_obs3d(target=target))[0] + 1.0) * 2.5
    assert v[wire] == pytest.approx(3.0, abs=1e-6)
    assert v[(wire + 2) % 4] == pytest.approx(0.0, abs=1e-6)  # the antagonist is off
    assert v[(wire + 1) % 4] == pytest.approx(0.5, abs=1e-6)  # the other axis holds


def test_diagonal_target_splits_over_two_wires_and_the_guard_cuts_hot_wires():
    pid = SpatialPIDController(SIG3D, kp=0.2, ki=0.0, bias=0.3, temperature_limit=380.0)
    v = (pid.predict(_obs3d(target=(10.0, 10.0)))[0] + 1.0) * 2.5
    assert v == pytest.approx([2.3, 2.3, 0.3, 0.3], abs=1e-6)
    v = (pid.predict(_obs3d(target=(10.0, 10.0), temps=(390.0, 293.0, 293.0, 293.0)))[0] + 1.0) * 2.5
    assert v[0] == 0.0 and v[1] == pytest.approx(2.3, abs=1e-6)


def test_chain_reference_is_the_inverse_kinematics_of_the_target():
    chain = SpineLayout.chain(2)
    sig = SpatialSignals(
        chain, "tip_position", bending=[0, 1, 2, 3], target=[4, 5, 6], temperature=list(range(7, 15)),
        v_max=5.0 * chain.voltage_scale,
    )  # fmt: skip
    pid = SpatialPIDController(sig)
    lengths = [m.length for m in chain.modules]
    rng = np.random.default_rng(0)
    for _ in range(5):
        mag, az = np.radians(rng.uniform(0, 20, 2)), rng.uniform(0, 2 * np.pi, 2)
        x_mm = 1000.0 * arc_chain_tip(np.stack([mag * np.cos(az), mag * np.sin(az)], 1), lengths)[0]
        obs = np.concatenate([np.zeros(4), x_mm, np.full(8, 293.0)])
        ref = pid.reference(obs)[0]
        assert 1000.0 * arc_chain_tip(np.radians(ref), lengths)[0] == pytest.approx(x_mm, abs=1e-6)
    # wires of the shorter modules get their scaled full scale (SPATIAL.md §6)
    a, _ = SpatialBangBangController(sig, v_on=5.0).predict(
        np.concatenate([np.zeros(4), x_mm, np.full(8, 293.0)])
    )
    assert np.all(a <= 1.0) and np.max((a + 1.0) / 2.0 * 5.0 * chain.voltage_scale) == pytest.approx(2.5)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"bending": [0]}, ["bending", "2"]),
        ({"temperature": [4, 5]}, ["temperature", "4"]),
        ({"task": "angle"}, ["task", "tip_bending"]),
        ({"v_max": -1.0}, ["v_max", "(0, 8]"]),  # the env's range (spine_gym.envs.drive)
    ],
)
def test_bad_signals_raise(kwargs, words):
    base = {"layout": SEED, "task": "tip_bending", "bending": [0, 1], "target": [2, 3], "temperature": [4, 5, 6, 7],
            "v_max": 5.0}  # fmt: skip
    with pytest.raises(ValueError) as exc:
        SpatialSignals(**(base | kwargs))
    for w in words:
        assert w in str(exc.value)


def test_bad_observations_and_gains_raise():
    pid = SpatialPIDController(SIG3D)
    with pytest.raises(ValueError, match="d >= 8"):
        pid.predict(np.zeros(5))
    with pytest.raises(ValueError, match="finite"):
        pid.predict(_obs3d(target=(np.nan, 0.0)))
    with pytest.raises(ValueError, match=r"kp must be in \[0, 1000\]"):
        SpatialPIDController(SIG3D, kp=-1.0)
    with pytest.raises(ValueError, match="preview > 0 needs"):
        SpatialPIDController(SIG3D, preview=0.5)


# --------------------------------------------------------------------------- on the envs
def _rollout(env, ctrl, target, seconds):
    from spine_gym.envs.loads import LoadSchedule
    from spine_gym.envs.targets_spatial import BendTarget

    obs, _ = env.reset(seed=0, options={"target": BendTarget.polar(*target), "loads": LoadSchedule(dim=3)})
    ctrl.reset()
    errs = []
    for _ in range(int(round(seconds / env.unwrapped.control_period))):
        obs, _, term, trunc, info = env.step(ctrl.predict(obs)[0])
        errs.append(np.linalg.norm(np.asarray(info["tip_bending_deg"]) - np.asarray(info["target_deg"])))
        assert not term
    return float(np.sqrt(np.mean(np.square(errs[len(errs) // 2 :]))))


def test_pid_holds_a_constant_3d_target_better_than_the_step_drive():
    env = gym.make("SmaSpine3D-v0", episode_duration=40.0)
    pid = SpatialPIDController.from_env(env, kp=0.3, ki=0.03, bias=0.5, temperature_limit=418.0)
    step = SpatialStepController.from_env(env)
    target = (30.0, 60.0)  # 30 deg toward azimuth 60 deg: between wires 0 and 1
    e_pid, e_step = _rollout(env, pid, target, 40.0), _rollout(env, step, target, 40.0)
    assert e_pid < 0.5 * e_step and e_pid < 3.0
    env.close()


def test_chain_controllers_run_on_the_chain_env():
    env = gym.make("SmaSpineChain-v0", episode_duration=5.0)
    for cls in (SpatialStepController, SpatialBangBangController, SpatialPIDController):
        ctrl = cls.from_env(env)
        obs, _ = env.reset(seed=1)
        for _ in range(10):
            a, _ = ctrl.predict(obs)
            assert a.shape == env.action_space.shape and np.all(np.abs(a) <= 1.0)
            obs, *_ = env.step(a)
    env.close()
