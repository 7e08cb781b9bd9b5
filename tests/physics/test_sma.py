"""MAS wire kernels against MODEL.md §3 and the §10.1 unit vectors, plus NumPy references."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spine_gym.params import ModelParams
from spine_gym.physics import sma

KP = ModelParams().to_kernel()
P = ModelParams()

# MODEL.md §10.1 landscape table: T, σ_A [MPa], σ_M [MPa], ε_A, ε_M, Δβ [J/m^3]
LANDSCAPE = [
    (293, 0.0, -150.0, 0.0, 0.047000, 3.97500e6),
    (333, 80.000, -70.000, 0.001143, 0.050200, -1.93000e5),
    (343, 159.156, 9.156, 0.002274, 0.053366, -4.47900e6),
    (383, 450.196, 300.196, 0.006431, 0.065008, -2.16230e7),
    (423, 710.000, 560.000, 0.010143, 0.075400, -3.87670e7),
]


@pytest.mark.parametrize("T, sa, sm, ea, em, db", LANDSCAPE)
def test_landscape_matches_table(T, sa, sm, ea, em, db):
    sig_A, sig_M, eps_A, eps_M, dbeta = sma.landscape(float(T), KP)
    assert sig_A / 1e6 == pytest.approx(sa, abs=2e-3)
    assert sig_M / 1e6 == pytest.approx(sm, abs=2e-3)
    assert eps_A == pytest.approx(ea, abs=1e-6)
    assert eps_M == pytest.approx(em, abs=1e-6)
    assert dbeta == pytest.approx(db, rel=1e-4)


def test_clausius_clapeyron_slope_about_7_mpa_per_k():
    s1 = sma.landscape(360.0, KP)[0]
    s2 = sma.landscape(361.0, KP)[0]
    assert 6.0e6 < s2 - s1 < 8.0e6


# MODEL.md §10.1 rates table (τ = 0.01 s, V_L = 5e-23 m^3): (T, σ [MPa], index, value)
# index: 0 p+A, 1 pA+, 2 p-A, 3 pA-
RATES = [
    (293, 148.5, 2, 0.73496, {1: 100.0}),
    (293, 149.5, 2, 57.932, {1: 100.0}),
    (343, 9.5, 0, 78.830, {2: 100.0}),
    (343, 10.5, 0, 2.6519, {2: 100.0}),
    (383, 300.5, 0, 82.865, {2: 100.0}),
    (383, 302.0, 0, 0.13294, {2: 100.0}),
    (383, 448.0, 1, 9.8049e-3, {2: 100.0}),
    (383, 449.0, 1, 6.4697, {2: 100.0}),
]


@pytest.mark.parametrize("T, s, idx, value, others", RATES)
def test_rates_match_table(T, s, idx, value, others):
    p = sma.rates(s * 1e6, float(T), KP)
    assert p[idx] == pytest.approx(value, rel=2e-4)
    for j, v in others.items():
        assert p[j] == pytest.approx(v, rel=1e-9)
    for j in range(4):
        if j != idx and j not in others:
            assert p[j] < 1e-300  # "≈ 0" in the table (the 700 clamp gives 9.86e-303)


def test_latent_heat_vectors():
    assert sma.latent_heats(0.0, KP) == pytest.approx((1.42531e8, 1.42531e8), rel=1e-5)
    lp, lm = sma.latent_heats(300e6, KP)
    assert lp == pytest.approx(1.59588e8, rel=1e-5)
    assert lm == pytest.approx(1.27788e8, rel=1e-5)


def test_latent_heat_at_equilibrium_close_to_handbook():
    # §3.8: at phase equilibrium L equals TΔη ≈ 23 kJ/kg against the handbook 24.2 kJ/kg [L3]
    T = 343.0
    per_kg = T * P.delta_eta / P.rho
    assert 20e3 < per_kg < 26e3
    lp, _ = sma.latent_heats(sma.landscape(T, KP)[1], KP)
    assert abs(lp / P.rho - 24.2e3) / 24.2e3 < 0.15


def _numpy_psi(eps, T):
    """Independent NumPy form of §3.2 with the a, b, c polynomial coefficients."""
    sa, sm, ea, em, db = sma.landscape(T, KP)
    a = -P.dsigma / (2 * (em - ea))
    b = ea * (P.E_A - 2 * a)
    c = db + ea**2 * (a - 0.5 * P.E_A)
    u = np.abs(eps)
    return np.where(
        u <= ea,
        0.5 * P.E_A * u**2 + db,
        np.where(u < em, a * u**2 + b * u + c, 0.5 * P.E_M * (u - P.eps_T) ** 2),
    )


@pytest.mark.parametrize("T", [293.0, 333.0, 343.0, 383.0, 423.0])
def test_helmholtz_equals_polynomial_form_and_is_c1(T):
    sa, sm, ea, em, db = sma.landscape(T, KP)
    eps = np.linspace(-0.09, 0.09, 2001)
    mine = np.array([sma.helmholtz(e, P.E_A, P.E_M, P.eps_T, P.dsigma, sa, ea, em, db) for e in eps])
    np.testing.assert_allclose(mine, _numpy_psi(eps, T), rtol=1e-9, atol=1e-3)
    # value and slope continuity at ±ε_A, ±ε_M (stress = dψ/dε: σ_A at ε_A, σ_M at ε_M)
    h = 1e-9
    for e0, s_expected in ((ea, sa), (em, sm)):
        if e0 <= 0:
            continue
        f = lambda e: sma.helmholtz(e, P.E_A, P.E_M, P.eps_T, P.dsigma, sa, ea, em, db)  # noqa: E731
        left = (f(e0) - f(e0 - h)) / h
        right = (f(e0 + h) - f(e0)) / h
        assert f(e0 - 1e-15) == pytest.approx(f(e0 + 1e-15), rel=1e-9, abs=1e-3)
        assert left == pytest.approx(s_expected, rel=1e-3, abs=2e5)
        assert right == pytest.approx(s_expected, rel=1e-3, abs=2e5)


@settings(max_examples=300, deadline=None)
@given(st.floats(-1.2e9, 1.2e9), st.floats(200.0, 600.0))
def test_barriers_nonnegative_and_rates_bounded(sigma, T):
    g = sma.barriers(sigma, T, KP)
    assert all(x >= 0.0 and math.isfinite(x) for x in g)
    p = sma.rates(sigma, T, KP)
    assert all(0.0 <= x <= 1.0 / P.tau for x in p)


def test_barrier_vanishes_past_instability():
    # above σ_A(T) austenite is unstable: ΔG_A+ = 0 ⇒ p_A+ = 1/τ; below σ_M(T) M+ is unstable
    T = 383.0
    sa, sm, *_ = sma.landscape(T, KP)
    assert sma.barriers(sa + 1e6, T, KP)[1] == 0.0
    assert sma.barriers(sm - 1e6, T, KP)[0] == 0.0


def test_constitutive_law_and_slack():
    # §3.6 with pure M+: σ = E_M (ε − ε_T); slack clamps compression to zero
    assert sma.stress(0.063, 1.0, 0.0, KP) == pytest.approx(P.E_M * 0.010)
    assert sma.stress(0.040, 1.0, 0.0, KP) == 0.0
    # pure austenite: σ = E_A ε
    assert sma.stress(0.005, 0.0, 0.0, KP) == pytest.approx(P.E_A * 0.005)
    # initial state §3.10: zero stress at the pre-strain
    assert sma.stress(P.eps0, P.x_plus0, 1 - P.x_plus0, KP) == pytest.approx(0.0, abs=1e-3)


def test_resistivity_mixing():
    assert sma.resistivity(0.0, 0.0, KP) == pytest.approx(P.lam_A)
    assert sma.resistivity(0.5, 0.5, KP) == pytest.approx(P.lam_M)
    assert sma.resistivity(0.25, 0.25, KP) == pytest.approx(0.5 * (P.lam_A + P.lam_M))
    # §8: R = λ L0 / A_w: 1.874 Ω martensite, 2.343 Ω austenite
    assert sma.resistivity(1.0, 0.0, KP) * P.L0 / P.wire_area == pytest.approx(1.874, abs=1e-3)
    assert sma.resistivity(0.0, 0.0, KP) * P.L0 / P.wire_area == pytest.approx(2.343, abs=1e-3)


@settings(max_examples=300, deadline=None)
@given(
    st.floats(0, 1),
    st.floats(0, 1),
    st.floats(1e-6, 10.0),
    st.floats(0, 100),
    st.floats(0, 100),
    st.floats(0, 100),
    st.floats(0, 100),
)
def test_phase_step_is_implicit_euler_and_keeps_fractions(xp, xm, h, ppA, pAp, pmA, pAm):
    if xp + xm > 1.0:
        xp, xm = xp / (xp + xm), xm / (xp + xm)
    new_p, new_m = sma.phase_step(xp, xm, h, ppA, pAp, pmA, pAm)
    assert 0.0 <= new_p <= 1.0 and 0.0 <= new_m <= 1.0 and new_p + new_m <= 1.0 + 1e-12
    # NumPy reference: (I − hK) x' = x + h b
    A = np.array([[1 + h * (ppA + pAp), h * pAp], [h * pAm, 1 + h * (pmA + pAm)]])
    ref = np.linalg.solve(A, [xp + h * pAp, xm + h * pAm])
    np.testing.assert_allclose([new_p, new_m], np.clip(ref, 0, 1), atol=1e-9)
