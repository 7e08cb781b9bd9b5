"""Sliding-mode controller (spine_gym.controllers.sliding_mode) against its specification.

The surface s = ė + λ|e|^γ sign(e) and the reaching law u = ff + Î + k_s s + K̂ sat(s/φ) are
checked on hand-computed values; the boundary layer, the adaptive gain's bounds and monotonicity,
the voltage clip and the thermal guard on their definitions; closed loop on SmaSpineEasy-v1 and
through the controller registry of every family on short episodes.
"""

from __future__ import annotations

import numpy as np
import pytest

import spine_gym  # noqa: F401 - registers the envs
from spine_gym.controllers.registry import GUARD_MARGIN_K, get_spec, load_tuned
from spine_gym.agents.runtime import build_controller, env_temperature_limit, make_env
from spine_gym.controllers import (
    PIDController,
    SlidingModeController,
    SMCGains,
    SpatialSlidingModeController,
    action_to_volts,
)
from spine_gym.controllers.sliding_mode import adapt_gain, boundary_layer, sliding_surface
from spine_gym.controllers.spatial import SpatialSignals
from spine_gym.envs.loads import LoadSchedule
from spine_gym.layout import SpineLayout

# a bare law: u = k_s s (no feedforward, estimate, switching term or bias), raw rate
BARE = dict(k_s=1.0, k_i=0.0, k_min=0.0, k_max=0.0, bias=0.0, feedforward=0.0, preview=0.0, tau_d=0.0)


def obs(angle=0.0, target=0.0, tr=293.0, tl=293.0, extra=(0.0, 0.0)):
    return np.array([angle, target, tr, tl, *extra], dtype=np.float64)


def volts(ctrl, o, v_max=5.0):
    return action_to_volts(ctrl(o), v_max)


# --------------------------------------------------------------------------- surface
@pytest.mark.parametrize(
    "e, e_dot, lam, gamma, expected",
    [
        (4.0, -1.0, 0.5, 0.5, 0.0),  # -1 + 0.5 * 2: on the surface
        (-9.0, 2.0, 1.0, 0.5, -1.0),  # 2 - 3
        (2.0, 0.0, 3.0, 1.0, 6.0),  # linear surface: lam * e
        (-2.0, 1.0, 3.0, 1.0, -5.0),
        (0.0, 0.7, 5.0, 0.3, 0.7),  # e = 0: s = e_dot (no singularity at 0)
        (8.0, 0.0, 1.0, 1.0 / 3.0, 2.0),  # 8^(1/3)
    ],
)
def test_surface_values_by_hand(e, e_dot, lam, gamma, expected):
    assert sliding_surface(e, e_dot, lam, gamma) == pytest.approx(expected, abs=1e-12)


def test_surface_in_the_controller_uses_the_measured_rate_and_picks_the_wire_by_its_sign():
    """u = k_s s with s = -dΘ/dt + λ sig(e)^γ: heat right while s > 0, left once the angle moves
    fast enough toward the target that s < 0 (braking before the target)."""
    c = SlidingModeController(lam=0.5, gamma=0.5, **BARE)
    assert volts(c, obs(angle=0.0, target=4.0)) == pytest.approx([1.0, 0.0], abs=1e-5)  # 0.5 * sqrt(4)
    # Θ: 0 -> 0.2 deg in 0.1 s: ė = -2 deg/s, e = 3.8: s = -2 + 0.5 sqrt(3.8) < 0
    s = -2.0 + 0.5 * np.sqrt(3.8)
    assert volts(c, obs(angle=0.2, target=4.0)) == pytest.approx([0.0, -s], abs=1e-5)
    c.reset()
    assert volts(c, obs(angle=10.0, target=1.0)) == pytest.approx([0.0, 1.5], abs=1e-5)  # e = -9
    c.reset()
    c(obs(angle=0.0, target=0.0))
    assert volts(c, obs(angle=0.0, target=30.0)) == pytest.approx([0.5 * np.sqrt(30.0), 0.0], abs=1e-5)
    # no derivative kick: the target step enters through λ sig(e)^γ only


# --------------------------------------------------------------------------- boundary layer
def test_boundary_layer_is_continuous_and_saturates_outside_phi():
    phi = 1.5
    s = np.linspace(-10.0, 10.0, 20_001)
    sat = boundary_layer(s, phi)
    assert np.max(np.abs(np.diff(sat))) <= np.diff(s)[0] / phi + 1e-12  # Lipschitz 1/phi: continuous
    assert np.all(sat[s >= phi] == 1.0) and np.all(sat[s <= -phi] == -1.0)
    inside = np.abs(s) < phi
    assert sat[inside] == pytest.approx(s[inside] / phi)


def test_switching_term_in_the_controller_is_k_sat_s_over_phi():
    """With k_s = 0 and a fixed gain K (k_min = k_max), u = K sat(s / φ)."""
    law = {**BARE, "k_s": 0.0, "k_min": 2.0, "k_max": 2.0}
    for e, expected in ((0.5, 2.0 * 0.5 / 1.0), (-0.25, -0.5), (3.0, 2.0), (-40.0, -2.0)):
        c = SlidingModeController(lam=1.0, gamma=1.0, phi=1.0, **law)
        v = volts(c, obs(angle=0.0, target=e))
        assert v == pytest.approx([max(expected, 0.0), max(-expected, 0.0)], abs=1e-5)


# --------------------------------------------------------------------------- adaptive gain
def test_adaptive_gain_grows_outside_the_layer_leaks_inside_and_stays_bounded():
    g = SMCGains(phi=1.0, k_min=0.5, k_max=3.0, rho=0.2, sigma=1.0)
    k, history = np.array([0.5]), []
    for _ in range(200):  # |s| = 4 > φ: + ρ |s| dt per period until k_max
        k = adapt_gain(k, np.array([4.0]), g, 0.1)
        history.append(k[0])
    assert np.all(np.diff(history) >= 0.0) and history[0] == pytest.approx(0.5 + 0.2 * 4.0 * 0.1)
    assert max(history) == 3.0
    leaked = adapt_gain(k, np.array([0.5]), g, 0.1)  # inside: exponential leak toward k_min
    assert leaked[0] == pytest.approx(0.5 + 2.5 * np.exp(-0.1))
    for _ in range(500):
        k = adapt_gain(k, np.array([-0.3]), g, 0.1)
    assert k[0] == pytest.approx(0.5, abs=1e-9) and k[0] >= 0.5


def test_controller_gain_memory_rises_with_a_persistent_error():
    c = SlidingModeController(lam=1.0, gamma=1.0, phi=1.0, k_min=0.1, k_max=1.0, rho=0.05, k_i=0.0)
    gains = []
    for _ in range(100):
        _, mem = c.predict(obs(angle=0.0, target=20.0))
        gains.append(mem[0, 3])
    assert gains[0] > 0.1 and np.all(np.diff(gains) >= 0.0) and gains[-1] == 1.0


# --------------------------------------------------------------------------- output
def test_voltages_are_split_by_sign_and_clipped_to_0_vmax():
    c = SlidingModeController(lam=10.0, gamma=1.0, k_s=5.0, bias=0.4, feedforward=0.0, preview=0.0, v_max=6.0)
    v = action_to_volts(c(obs(angle=0.0, target=60.0)), 6.0)
    assert v == pytest.approx([6.0, 0.4], abs=1e-5)  # u_sat = v_max - bias, plus bias
    c.reset()
    v = action_to_volts(c(obs(angle=60.0, target=-60.0)), 6.0)
    assert v == pytest.approx([0.4, 6.0], abs=1e-5)
    rng = np.random.default_rng(1)
    batch = np.stack([obs(angle=a, target=t) for a, t in rng.uniform(-90, 90, (200, 2))])
    a, _ = SlidingModeController(k_s=2.0, v_max=6.0).predict(batch)
    assert np.all((a >= -1.0) & (a <= 1.0))


def test_equivalent_control_estimate_is_held_by_the_anti_windup():
    """dÎ/dt = k_i s + kaw (u_sat - u): under a saturating error Î settles where the two cancel,
    u - u_sat = k_i s / kaw, instead of integrating without bound (kaw = 0)."""
    law = {**BARE, "k_s": 0.0, "k_i": 0.5, "lam": 1.0, "gamma": 1.0}
    c = SlidingModeController(**law, kaw=2.0)
    for _ in range(500):  # e = s = 80 forever
        _, mem = c.predict(obs(angle=0.0, target=80.0))
    assert volts(c, obs(angle=0.0, target=80.0)) == pytest.approx([5.0, 0.0], abs=1e-5)
    assert mem[0, 0] == pytest.approx(5.0 + 0.5 * 80.0 / 2.0, rel=1e-6)
    w = SlidingModeController(**law, kaw=0.0)
    for _ in range(500):
        _, mem_w = w.predict(obs(angle=0.0, target=80.0))
    assert mem_w[0, 0] == pytest.approx(500 * 0.1 * 0.5 * 80.0, rel=1e-6)


def test_guard_cuts_a_wire_at_the_limit_like_the_pid():
    smc = SlidingModeController(k_s=1.0, temperature_limit=400.0)
    for ctrl in (smc, PIDController(kp=1.0, temperature_limit=400.0)):
        assert volts(ctrl, obs(angle=0.0, target=30.0, tr=400.0))[0] == 0.0  # at the limit: off
        ctrl.reset()
        assert volts(ctrl, obs(angle=0.0, target=30.0, tr=399.0))[0] > 0.0
    env = make_env(env_id="SmaSpineEasy-v1")
    limit = env_temperature_limit(env) - GUARD_MARGIN_K
    pid_limit = build_controller("pid", env).temperature_limit
    assert build_controller("smc", env).temperature_limit == limit == pid_limit
    env.close()


# --------------------------------------------------------------------------- interface
def test_single_batch_and_explicit_state_agree():
    rng = np.random.default_rng(0)
    pairs = zip(rng.uniform(-20, 20, 30), rng.uniform(-30, 30, 30), strict=True)
    seq = [obs(angle=a, target=t) for a, t in pairs]
    internal, explicit, batched = SlidingModeController(), SlidingModeController(), SlidingModeController()
    state = bstate = None
    for k, o in enumerate(seq):
        a1 = internal(o)
        a2, state = explicit.predict(o, state=state, episode_start=np.array([k == 0]))
        ab, bstate = batched.predict(np.stack([o, o]), state=bstate, episode_start=np.array([k == 0] * 2))
        assert a1.shape == (2,) and ab.shape == (2, 2) and a1.dtype == np.float32
        assert np.array_equal(a1, a2) and np.array_equal(ab[0], a1) and np.array_equal(ab[1], a1)
    first = np.stack([seq[0], seq[0]])
    a_reset, _ = batched.predict(first, state=bstate, episode_start=np.array([True, False]))
    assert np.array_equal(a_reset[0], SlidingModeController().predict(seq[0])[0])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"gamma": 0.0}, "gamma"),
        ({"gamma": 1.5}, "gamma"),
        ({"phi": 0.0}, "phi"),
        ({"k_min": 1.0, "k_max": 0.5}, "k_max"),
        ({"k_min": 6.0}, "k_min"),
        ({"lam": -1.0}, "lam"),
        ({"bias": 6.0}, "bias"),
        ({"kq": 1.0}, "unknown sliding-mode setting"),
        ({"preview": 0.5, "preview_index": 2}, "preview_index"),
    ],
)
def test_bad_settings_name_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SlidingModeController(**kwargs)


def test_bad_observations_raise():
    c = SlidingModeController()
    with pytest.raises(ValueError, match="finite"):
        c.predict(obs(angle=np.nan))
    with pytest.raises(ValueError, match="preview"):
        c.predict(obs()[:5])  # default preview > 0 needs entry 5
    with pytest.raises(ValueError, match="state"):
        c.predict(np.zeros((2, 6)), state=np.zeros((2, 3)))


# --------------------------------------------------------------------------- spatial
SIG3D = SpatialSignals(
    SpineLayout(), "tip_bending", bending=[0, 1], target=[2, 3], temperature=[4, 5, 6, 7], v_max=5.0
)


@pytest.mark.parametrize(
    "target, wire", [((4.0, 0.0), 0), ((0.0, 4.0), 1), ((-4.0, 0.0), 2), ((0.0, -4.0), 3)]
)
def test_spatial_law_per_axis_heats_the_wire_of_that_azimuth(target, wire):
    c = SpatialSlidingModeController(SIG3D, lam=0.5, gamma=0.5, **BARE, temperature_limit=380.0)
    o = np.array([0.0, 0.0, *target, 293.0, 293.0, 293.0, 293.0])
    v = action_to_volts(c.predict(o)[0], 5.0)
    assert v[wire] == pytest.approx(1.0, abs=1e-6)  # 0.5 sqrt(4), as the planar law
    assert np.delete(v, wire) == pytest.approx(0.0, abs=1e-6)
    o[4 + wire] = 380.0  # the same guard: the hot wire is cut
    c.reset()
    assert action_to_volts(c.predict(o)[0], 5.0)[wire] == 0.0


# --------------------------------------------------------------------------- closed loop
def test_tracks_a_constant_target_on_the_easy_tier():
    """Closed loop on SmaSpineEasy-v1 with the registry's settings: within 3 deg of 25 deg over the
    last 10 s of a 30-s episode without loads (a loose physical bound: the wires need seconds to
    heat, the error at rest is set by the boundary layer and the estimate)."""
    env = make_env({"episode_duration": 30.0}, env_id="SmaSpineEasy-v1")
    ctrl = build_controller("smc", env)
    o, _ = env.reset(seed=0, options={"target": 25.0, "loads": LoadSchedule()})
    angles = []
    for _ in range(int(round(30.0 / env.unwrapped.control_period))):
        o, *_ = env.step(ctrl.predict(o)[0])
        angles.append(o[0])
    assert np.sqrt(np.mean((np.asarray(angles[-100:]) - 25.0) ** 2)) < 3.0
    env.close()


@pytest.mark.parametrize("env_id", ["SmaSpine-v1", "SmaSpine3D-v1", "SmaSpineChain-v1"])
def test_registry_entry_runs_a_short_episode_on_every_family(env_id):
    env = make_env({"episode_duration": 3.0}, env_id=env_id)
    assert get_spec("smc", env_id).tuned and "smc" in load_tuned(env_id=env_id)
    ctrl = build_controller("smc", env)
    o, _ = env.reset(seed=1)
    done = False
    while not done:
        a, _ = ctrl.predict(o)
        assert a.shape == env.action_space.shape and np.all(np.abs(a) <= 1.0)
        o, _, term, trunc, _ = env.step(a)
        done = term or trunc
    env.close()
