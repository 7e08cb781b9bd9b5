"""Segmented-line bending (MODEL.md §4) against the §10.1 spine vectors and analytic limits."""

import math

import numpy as np
import pytest

from spine_gym.params import ModelParams
from spine_gym.physics import columns as L
from spine_gym.physics.planar import tube

P = ModelParams()
KP = P.to_kernel()
N = P.n_seg


def _solve(m_w, tip=(0.0, 0.0), kp=KP, tol=1e-13):
    vf = np.zeros((N, 2))
    vf[0] = tip
    d = np.zeros(N)
    status, iters = tube.solve_shape(d, m_w, vf, kp, tol, 1000)
    assert status == L.OK
    return d, iters


# MODEL.md §10.1 "Spine with a given wire moment"
@pytest.mark.parametrize(
    "m_w, tip, theta, top, bottom, lr, ll",
    [
        (0.1, 0.0, 18.9186, 1.0665, 1.8080, 0.455365, 0.464610),
        (0.1, -1.0, 43.6243, 1.2129, 5.0333, None, None),
        (0.2, 0.0, 37.4073, 2.1307, 3.5629, 0.450812, 0.469090),
    ],
)
def test_spine_with_given_moment(m_w, tip, theta, top, bottom, lr, ll):
    d, _ = _solve(m_w, (0.0, tip))
    assert math.degrees(d.sum()) == pytest.approx(theta, abs=1e-4)
    assert math.degrees(d[0]) == pytest.approx(top, abs=1e-4)
    assert math.degrees(d[-1]) == pytest.approx(bottom, abs=1e-4)
    if lr is not None:
        got_r, got_l = tube.wire_lengths(d, KP)
        assert got_r == pytest.approx(lr, abs=1e-6)
        assert got_l == pytest.approx(ll, abs=1e-6)


def test_massless_spine_is_the_analytic_constant_curvature_arc():
    kp = KP.copy()
    kp[L.K_MSEG] = 0.0
    kp[L.K_MTOP] = 0.0
    d, iters = _solve(0.2, kp=kp)
    exact = 0.2 * N * P.ls / (P.E_t * P.I_tube)  # Θ = M N ls/(E_t I)
    assert d.sum() == pytest.approx(exact, rel=1e-12)
    assert math.degrees(exact) == pytest.approx(27.2519, abs=1e-4)
    np.testing.assert_allclose(d, d[0], rtol=1e-12)  # constant curvature
    lr, ll = tube.wire_lengths(d, kp)
    assert (lr, ll) == pytest.approx((0.453316, 0.466633), abs=1e-6)
    # the tip of a circular arc of length L_b and angle Θ: x = L_b (1 − cos Θ)/Θ, y = L_b sin Θ/Θ
    lb = N * P.ls
    tx, ty = tube.tip_position(d, kp)
    assert tx == pytest.approx(lb * (1 - math.cos(exact)) / exact, rel=1e-9)
    assert ty == pytest.approx(lb * math.sin(exact) / exact, rel=1e-9)


@pytest.mark.parametrize(
    "tip, counts",
    [(0.0, [4, 7, 9, 11, 13, 15]), (-1.0, [9, 13, 17, 21, 25, 29])],
)
def test_shape_iteration_counts(tip, counts):
    # MODEL.md §10.1 stand-in for seed Table 2: start from Δθ = 0, criterion max|ΔΔθ| < tol
    got = [_solve(0.15, (0.0, tip), tol=math.radians(t))[1] for t in (0.1, 0.01, 1e-3, 1e-4, 1e-5, 1e-6)]
    assert got == counts


def test_mirror_symmetry_and_gravity_destabilises():
    d_pos, _ = _solve(0.1)
    d_neg, _ = _solve(-0.1)
    np.testing.assert_allclose(d_neg, -d_pos, atol=1e-14)
    kp = KP.copy()
    kp[L.K_G] = 0.0
    d_ng, _ = _solve(0.1, kp=kp)
    assert d_pos.sum() > d_ng.sum() * 1.3  # §8: gravity amplifies the bend ≈ 1.35×


def test_vertices_chain_and_tip_agree():
    d, _ = _solve(0.15, (0.0, -1.0))
    p = tube.vertices(d, KP)
    assert p.shape == (N + 1, 2)
    assert tuple(p[N]) == (0.0, 0.0)
    seg = np.hypot(*(p[:-1] - p[1:]).T)
    chords = np.array([tube.chord(x, P.ls) for x in d])
    np.testing.assert_allclose(seg, chords, rtol=1e-12)
    assert tube.tip_position(d, KP) == pytest.approx(tuple(p[0]), rel=1e-12)
    assert p[0, 0] > 0  # positive moment bends toward +x


def test_horizontal_tip_force_bends_toward_it():
    d, _ = _solve(0.0, (0.5, 0.0))
    assert d.sum() > 0
    d2, _ = _solve(0.0, (-0.5, 0.0))
    np.testing.assert_allclose(d2, -d, atol=1e-14)


def test_load_beyond_buckling_reports_failure_not_nan():
    vf = np.zeros((N, 2))
    vf[0] = (0.05, -60.0)  # far above the top-load critical value (§4.9)
    d = np.zeros(N)
    status, iters = tube.solve_shape(d, 0.0, vf, KP, 1e-12, 200)
    assert status == L.ERR_SHAPE


def test_chord_small_angle_branch_is_continuous():
    for x in (1e-9, -1e-9, 2e-8):
        exact = 2 * P.ls / x * math.sin(x / 2)
        assert tube.chord(x, P.ls) == pytest.approx(exact, rel=1e-15)
