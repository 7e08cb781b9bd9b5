"""spine_gym.kinematics: arc forward kinematics against the model (SPATIAL.md §7.4) and the inverse
kinematics the chain controllers use (IK(FK(x)) = x)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spine_gym import ModelParams, SpineLayout, simulate
from spine_gym.kinematics import arc_chain_ik, arc_chain_tip

L2 = np.array([0.2275, 0.2275])  # the default two-module chain's module lengths [m]


def test_single_arc_closed_form():
    """A module bent by Θ toward β is a circular arc of radius L/Θ in the vertical plane of β."""
    length, theta, beta = 0.455, math.radians(70.0), math.radians(30.0)
    pos, frame = arc_chain_tip([[theta * math.cos(beta), theta * math.sin(beta)]], [length])
    rho = length / theta
    assert pos == pytest.approx(
        [
            rho * (1 - math.cos(theta)) * math.cos(beta),
            rho * (1 - math.cos(theta)) * math.sin(beta),
            rho * math.sin(theta),
        ],
        abs=1e-15,
    )
    tangent = frame[:, 2]
    assert tangent == pytest.approx(
        [math.sin(theta) * math.cos(beta), math.sin(theta) * math.sin(beta), math.cos(theta)], abs=1e-15
    )
    assert frame.T @ frame == pytest.approx(np.eye(3), abs=1e-14)
    straight, _ = arc_chain_tip(np.zeros((2, 2)), L2)
    assert straight == pytest.approx([0.0, 0.0, L2.sum()], abs=1e-15)


def test_forward_kinematics_matches_the_model():
    """SPATIAL.md §7.4: gravity off, no tip load, the wire moment is constant over each module, so
    each module of the model is an arc and the tip is the composition of the arcs of the model's
    own module bending vectors."""
    layout = SpineLayout.chain(2, ModelParams().replace(g=0.0))
    volts = 3.4 * layout.voltage_scale * np.array([1.0, 0.9, 0.0, 0.0, 0.0, 0.0, 1.0, 0.95])
    r = simulate(20.0, volts, layout=layout)
    lengths = [m.length for m in layout.modules]
    for k in (r.at(12.0), r.at(16.0), len(r) - 1):
        bends = np.radians(r.module_bending_deg[k])
        assert np.linalg.norm(bends[0]) > math.radians(5.0) and np.linalg.norm(bends[1]) > math.radians(5.0)
        pos, frame = arc_chain_tip(bends, lengths)
        assert pos == pytest.approx(r.tip_position[k], abs=1e-9)
        assert frame.T == pytest.approx(r.tip_frame[k], abs=1e-9)  # model rows d1, d2, t


@pytest.mark.parametrize("n_modules", [1, 2, 3])
def test_ik_of_fk_is_the_identity_on_positions(n_modules):
    rng = np.random.default_rng(n_modules)
    lengths = np.full(n_modules, 0.455 / n_modules)
    for _ in range(20):
        if n_modules != 2:  # one arc, or three: configurations of the documented family (linear bends)
            p, q, phi = np.radians(rng.uniform(-20, 20)), np.radians(rng.uniform(-10, 10)), rng.uniform(-3, 3)
            theta = p + q * (np.arange(n_modules) - 0.5 * (n_modules - 1))
            bends = np.stack([theta * np.cos(phi), theta * np.sin(phi)], axis=1)
        else:  # two modules: any per-module directions (outside the family too), within 20 deg each
            mag, az = np.radians(rng.uniform(0, 20, n_modules)), rng.uniform(0, 2 * np.pi, n_modules)
            bends = np.stack([mag * np.cos(az), mag * np.sin(az)], axis=1)
        x, _ = arc_chain_tip(bends, lengths)
        ik = arc_chain_ik(x, lengths)
        assert ik.error < 1e-9, (bends, ik)
        assert arc_chain_tip(ik.bending, lengths)[0] == pytest.approx(x, abs=1e-9)
        phi = math.atan2(x[1], x[0])  # the documented family: every module in the target's vertical plane
        for b in ik.bending:
            assert b[0] * math.sin(phi) - b[1] * math.cos(phi) == pytest.approx(0.0, abs=1e-12)


def test_ik_of_an_unreachable_target_returns_the_closest_arc():
    ik = arc_chain_ik([0.0, 0.0, 0.6], L2)  # farther than the spine's length
    assert ik.error == pytest.approx(0.6 - L2.sum(), abs=1e-6)


@pytest.mark.parametrize(
    "call, words",
    [
        (lambda: arc_chain_ik([0.1, 0.0], L2), ["target", "(3,)"]),
        (lambda: arc_chain_ik([0.1, np.nan, 0.4], L2), ["target", "finite"]),
        (lambda: arc_chain_ik([0.1, 0.0, 0.4], [0.2, -0.2]), ["lengths", "> 0"]),
        (lambda: arc_chain_ik([0.1, 0.0, 0.4], L2, max_iter=0), ["max_iter", ">= 1"]),
        (lambda: arc_chain_tip(np.zeros((2, 3)), L2), ["bending", "(n_modules, 2)"]),
        (lambda: arc_chain_tip(np.zeros((2, 2)), [0.2]), ["lengths", "(2,)"]),
    ],
)
def test_bad_arguments_raise(call, words):
    with pytest.raises(ValueError) as exc:
        call()
    for w in words:
        assert w in str(exc.value)
