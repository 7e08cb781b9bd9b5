"""Baseline controllers (spine_gym.controllers): steady-state map, predict interface, logic, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from spine_gym import simulate
from spine_gym.controllers import (
    BangBangController,
    PIDController,
    PIDGains,
    StepVoltageController,
    action_to_volts,
    steady_state_map,
    volts_to_action,
)


def obs(angle=0.0, target=0.0, tr=293.0, tl=293.0, extra=(0.0, 0.0)):
    return np.array([angle, target, tr, tl, *extra], dtype=np.float32)


@pytest.fixture(scope="module")
def ss_map():
    return steady_state_map()


# --------------------------------------------------------------------------- steady-state map
def test_map_is_monotone_cached_and_saturates(ss_map):
    assert ss_map is steady_state_map()  # computed once per argument set
    assert np.all(np.diff(ss_map.angle_deg) >= 0.0)
    assert ss_map.angle_deg[0] == 0.0
    # 3.2 V reaches ~51 deg after 60 s (MODEL.md §10.4); the map's 120 s settle is a bit further
    assert 50.0 < np.interp(3.2, ss_map.voltage, ss_map.angle_deg) < 57.0
    with pytest.raises(ValueError):
        ss_map.angle_deg[0] = 1.0  # read-only


def test_map_inverse_reproduces_the_angle(ss_map):
    """The voltage the map gives for 30 deg holds the spine near 30 deg in a fresh simulation."""
    v = float(ss_map.voltage_for(30.0))
    res = simulate(ss_map.settle_time, v, 0.0, dt=0.05)
    assert abs(res.angle_deg[-1] - 30.0) < 1.5
    assert ss_map.voltage_for(0.0) == 0.0
    assert ss_map.voltage_for(-30.0) == pytest.approx(v)  # mirror symmetry
    assert ss_map.voltage_for(500.0) <= ss_map.voltage[-1]


def test_action_conversion_round_trip():
    v = np.array([0.0, 1.25, 5.0])
    assert np.allclose(action_to_volts(volts_to_action(v, 5.0), 5.0), v, atol=1e-6)
    assert volts_to_action([0.0, 5.0], 5.0).tolist() == [-1.0, 1.0]
    assert volts_to_action([9.0], 5.0)[0] == 1.0  # clipped


# --------------------------------------------------------------------------- step voltage
def test_step_voltage_is_open_loop_and_picks_the_side(ss_map):
    c = StepVoltageController(ss_map=ss_map)
    a_pos, _ = c.predict(obs(angle=0.0, target=25.0))
    a_pos2, _ = c.predict(obs(angle=40.0, target=25.0))  # the angle is ignored
    assert np.array_equal(a_pos, a_pos2)
    v = action_to_volts(a_pos, 5.0)
    assert v[0] == pytest.approx(float(ss_map.voltage_for(25.0)), abs=1e-5) and v[1] == 0.0
    v_neg = action_to_volts(c.predict(obs(target=-25.0))[0], 5.0)
    assert v_neg[1] == pytest.approx(v[0], abs=1e-5) and v_neg[0] == 0.0
    assert np.allclose(action_to_volts(c.predict(obs(target=0.0))[0], 5.0), 0.0)


# --------------------------------------------------------------------------- bang-bang
def test_bang_bang_relay_with_hysteresis():
    c = BangBangController(v_on=3.0, band=2.0, release=0.5)
    v = lambda a: action_to_volts(a, 5.0)  # noqa: E731
    assert np.allclose(v(c(obs(angle=0.0, target=10.0))), [3.0, 0.0])  # e = 10 > band: right on
    assert np.allclose(v(c(obs(angle=9.0, target=10.0))), [3.0, 0.0])  # inside the band: keep heating
    assert np.allclose(v(c(obs(angle=10.3, target=10.0))), [3.0, 0.0])  # e = -0.3 > -release: still on
    assert np.allclose(v(c(obs(angle=10.6, target=10.0))), [0.0, 0.0])  # e = -0.6 < -release: off
    assert np.allclose(v(c(obs(angle=11.0, target=10.0))), [0.0, 0.0])  # inside the band: stay off
    assert np.allclose(v(c(obs(angle=12.5, target=10.0))), [0.0, 3.0])  # e < -band: left on
    c.reset()
    assert np.allclose(v(c(obs(angle=11.0, target=10.0))), [0.0, 0.0])  # fresh memory: off


# --------------------------------------------------------------------------- PID
def test_pid_splits_the_signed_output_between_the_wires():
    c = PIDController(kp=0.2, ki=0.0, bias=0.3)
    v = action_to_volts(c.predict(obs(angle=0.0, target=10.0))[0], 5.0)
    assert v == pytest.approx([0.2 * 10 + 0.3, 0.3], abs=1e-5)
    c.reset()
    v = action_to_volts(c.predict(obs(angle=10.0, target=0.0))[0], 5.0)
    assert v == pytest.approx([0.3, 0.2 * 10 + 0.3], abs=1e-5)


def test_pid_preview_blends_the_look_ahead_target_into_the_reference():
    """r = (1 - preview) target + preview obs[preview_index]: with preview = 1 only the look-ahead counts."""
    c = PIDController(kp=0.2, ki=0.0, bias=0.0, preview=1.0)
    v = action_to_volts(c.predict(obs(angle=0.0, target=0.0, extra=(0.0, 10.0)))[0], 5.0)
    assert v == pytest.approx([0.2 * 10, 0.0], abs=1e-5)
    half = PIDController(kp=0.2, ki=0.0, bias=0.0, preview=0.5)
    v = action_to_volts(half.predict(obs(angle=0.0, target=0.0, extra=(0.0, 10.0)))[0], 5.0)
    assert v == pytest.approx([0.2 * 5, 0.0], abs=1e-5)
    with pytest.raises(ValueError, match="preview"):
        PIDController(preview=0.5).predict(obs()[:5])  # no look-ahead entry in a 5-entry observation


def test_pid_anti_windup_bounds_the_integrator():
    """A long saturated error must not wind the integrator up beyond what the wires can apply."""
    c = PIDController(kp=1.0, ki=1.0, kaw=2.0)
    for _ in range(500):
        a, mem = c.predict(obs(angle=0.0, target=80.0))
    assert np.allclose(action_to_volts(a, 5.0), [5.0, 0.0])
    assert mem[0, 0] < 5.0  # back-calculation holds I near u_sat - kp e (< v_max)
    # once the error flips, the output leaves saturation within a few steps (no windup)
    steps = 0
    while action_to_volts(c(obs(angle=90.0, target=80.0)), 5.0)[1] == 0.0:
        steps += 1
        assert steps < 10
    w = PIDController(kp=1.0, ki=1.0, kaw=0.0)  # without anti-windup the integrator runs away
    for _ in range(500):
        _, mem_w = w.predict(obs(angle=0.0, target=80.0))
    assert mem_w[0, 0] > 100 * mem[0, 0]


def test_pid_derivative_acts_on_measurement_only():
    c = PIDController(kp=0.0, ki=0.0, kd=1.0, tau_d=0.0, bias=0.0)
    c(obs(angle=0.0, target=0.0))
    a = c(obs(angle=0.0, target=30.0))  # target step: no derivative kick
    assert np.allclose(action_to_volts(a, 5.0), 0.0)
    a = c(obs(angle=-0.2, target=30.0))  # angle falling at 2 deg/s -> push right
    assert action_to_volts(a, 5.0)[0] == pytest.approx(2.0, abs=1e-5)


def test_explicit_state_matches_internal_memory_and_batches():
    rng = np.random.default_rng(0)
    seq = [
        obs(angle=a, target=t)
        for a, t in zip(rng.uniform(-20, 20, 30), rng.uniform(-30, 30, 30), strict=True)
    ]
    for make in (lambda: PIDController(kp=0.3, ki=0.1, kd=0.2), lambda: BangBangController(band=1.0)):
        internal, explicit = make(), make()
        state = None
        batch_ctrl = make()
        bstate = None
        for k, o in enumerate(seq):
            a1 = internal(o)
            a2, state = explicit.predict(o, state=state, episode_start=np.array([k == 0]))
            ab, bstate = batch_ctrl.predict(
                np.stack([o, o]), state=bstate, episode_start=np.array([k == 0] * 2)
            )
            assert np.array_equal(a1, a2) and np.array_equal(ab[0], a1) and np.array_equal(ab[1], a1)
        # episode_start resets one row only
        a_reset, _ = batch_ctrl.predict(
            np.stack([seq[0], seq[0]]), state=bstate, episode_start=np.array([True, False])
        )
        fresh = make().predict(seq[0])[0]
        assert np.array_equal(a_reset[0], fresh)


def test_pid_closed_loop_reaches_a_step():
    """Closed loop on the simulator (0.1 s period): a tuned-scale PID gets within 2 deg of 25 deg."""
    c = PIDController(kp=0.3, ki=0.05, bias=0.3)
    res = simulate(0.1, 0.0, 0.0)
    angles = []
    for _ in range(400):
        o = obs(
            angle=res.angle_deg[-1], target=25.0, tr=res.temperature_right[-1], tl=res.temperature_left[-1]
        )
        v = action_to_volts(c(o), 5.0)
        res = simulate(0.1, v[0], v[1], state=res.final_state)
        angles.append(res.angle_deg[-1])
    assert abs(np.mean(angles[-50:]) - 25.0) < 2.0


def test_temperature_guard_switches_a_hot_wire_off():
    c = PIDController(kp=1.0, temperature_limit=400.0)
    v = action_to_volts(c(obs(angle=0.0, target=30.0, tr=401.0)), 5.0)
    assert v[0] == 0.0
    v = action_to_volts(c(obs(angle=0.0, target=30.0, tr=399.0)), 5.0)
    assert v[0] > 0.0


def test_from_gains_round_trip():
    g = PIDGains(kp=0.5, ki=0.02, kd=0.1, tau_d=0.5, bias=0.2, kaw=1.5, feedforward=0.0)
    c = PIDController.from_gains(g)
    assert c.gains == g
    with pytest.raises(ValueError, match="unknown PID gain"):
        PIDController.from_gains({"kp": 1.0, "kq": 2.0})


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "factory",
    [lambda: StepVoltageController(), lambda: BangBangController(), lambda: PIDController()],
    ids=["step", "bang_bang", "pid"],
)
def test_bad_observations_raise_clear_errors(factory):
    c = factory()
    with pytest.raises(ValueError, match="finite"):
        c.predict(obs(angle=np.nan))
    with pytest.raises(ValueError, match="finite"):
        c.predict(obs(tr=np.inf))
    with pytest.raises(ValueError, match="shape"):
        c.predict(np.zeros(3))
    with pytest.raises(ValueError, match="shape"):
        c.predict(np.zeros((2, 2, 5)))
    with pytest.raises(ValueError, match="numeric"):
        c.predict("angle")
    with pytest.raises(ValueError, match="episode_start"):
        c.predict(np.zeros((2, 5)), episode_start=np.array([True]))
    if c.state_size:
        with pytest.raises(ValueError, match="state"):
            c.predict(np.zeros((2, 5)), state=np.zeros((3, c.state_size)))


@pytest.mark.parametrize(
    "factory, match",
    [
        (lambda: PIDController(kp=-1.0), "kp"),
        (lambda: PIDController(ki=np.nan), "ki"),
        (lambda: PIDController(bias=6.0), "bias"),
        (lambda: PIDController(feedforward=2.0), "feedforward"),
        (lambda: PIDController(preview=1.5), "preview"),
        (lambda: PIDController(preview=0.5, preview_index=2), "preview_index"),
        (lambda: BangBangController(v_on=0.0), "v_on"),
        (lambda: BangBangController(band=1.0, release=-2.0), "release"),
        (lambda: BangBangController(v_on=6.0), "v_on"),
        (lambda: StepVoltageController(v_max=0.0), "v_max"),
        (lambda: PIDController(v_max=9.0), r"v_max must be in \(0, 8\]"),  # the env's one range
        (lambda: steady_state_map(v_max=20.0), r"v_max must be in \(0, 8\]"),
        (lambda: StepVoltageController(ss_map="map"), "ss_map"),
        (lambda: PIDController(dt=-0.1), "dt"),
        (lambda: PIDController(temperature_limit=10.0), "temperature_limit"),
        (lambda: steady_state_map(n_points=2), "n_points"),
    ],
)
def test_bad_constructor_arguments_name_the_parameter(factory, match):
    with pytest.raises(ValueError, match=match):
        factory()


def test_the_base_controller_reads_no_observation_entry_each_geometry_says_where():
    """BaseController knows no observation index: a controller that does not say where its
    readings are cannot predict; the planar ones read SmaSpine-v0's table."""
    import inspect

    from spine_gym.controllers import PlanarController, base
    from spine_gym.envs.planar import planar_obs_index

    class Unplaced(base.BaseController):
        def _volts(self, obs, mem):
            return np.zeros((obs.shape[0], 2))

    with pytest.raises(NotImplementedError):
        Unplaced().predict(obs())
    assert "obs_index" not in inspect.getsource(base) and "OBS_" not in inspect.getsource(base)
    for cls in (StepVoltageController, BangBangController, PIDController):
        assert issubclass(cls, PlanarController)
    hot = obs(tr=500.0, tl=293.0, target=10.0)
    assert planar_obs_index("temperature") == 2
    volts = action_to_volts(BangBangController(temperature_limit=400.0).predict(hot)[0], 5.0)
    assert volts[0] == 0.0  # the guard read the right wire's temperature at index 2
