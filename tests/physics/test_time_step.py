"""The coupled time step of MODEL.md §6.5: its Jacobian pieces against finite differences of the
spec's own functions, its invariants, and its options."""

import numpy as np
import pytest

from spine_gym import ModelParams, SolverOptions, simulate
from spine_gym.physics import columns as L
from spine_gym.physics import sma
from spine_gym.physics.planar import columns as PL
from spine_gym.physics.planar.composite import composite
from spine_gym.physics.planar.integrate import advance
from spine_gym.physics.planar.mechanics import stress_sensitivity

KP = ModelParams().to_kernel()


@pytest.mark.parametrize(
    "T, sigma",
    [(293.0, 148.8e6), (343.0, 9.8e6), (383.0, 300.8e6), (383.0, 448.5e6), (401.9, 428e6)],
)
def test_rate_slopes_are_the_derivatives_of_the_rates(T, sigma):
    # §3.3–3.4: p = τ⁻¹ exp(−λ ΔG(σ, T)); the slopes are checked against central differences of p
    out = np.empty(12)
    sma.rates_and_slopes(sigma, T, KP, out)
    np.testing.assert_array_equal(out[:4], sma.rates(sigma, T, KP))
    ds, dT = 1e2, 1e-4  # [Pa], [K]: far below the ~0.7 MPa / ~0.1 K e-fold widths of the rates
    d_sig = (np.array(sma.rates(sigma + ds, T, KP)) - np.array(sma.rates(sigma - ds, T, KP))) / (2 * ds)
    d_T = (np.array(sma.rates(sigma, T + dT, KP)) - np.array(sma.rates(sigma, T - dT, KP))) / (2 * dT)
    scale_s = np.abs(d_sig).max()
    scale_t = np.abs(d_T).max()
    assert scale_s > 0 and scale_t > 0  # each case has a live rate
    np.testing.assert_allclose(out[4:8], d_sig, rtol=1e-3, atol=1e-6 * scale_s)
    np.testing.assert_allclose(out[8:12], d_T, rtol=2e-2, atol=1e-3 * scale_t)


def test_stress_sensitivity_matches_re_solved_composite():
    # §5.2: dσ/dx of the equilibrium, predicted with the Newton sensitivity, against two composite
    # solves of a bent, transforming state (right wire partly austenitic, left one stretched)
    r = simulate(12.0, 3.2, 0.0)
    st = r.final_state.copy()
    n = ModelParams().n_seg
    ks = SolverOptions().to_kernel()
    vf = np.zeros((n, 2))
    work, saved = np.empty(n), np.empty(n)
    sens = np.empty((2, 4))
    dth = st[PL.X_HEAD : PL.X_HEAD + n]
    s = st[PL.X_HEAD + n :]
    xs = st[[PL.X_PR, PL.X_MR, PL.X_PL, PL.X_ML]]
    stress_sensitivity(dth, s, st[PL.X_SR], st[PL.X_SL], *xs, KP, sens)
    assert st[PL.X_SR] > 1e8 and st[PL.X_SL] > 1e8
    fd = np.empty((2, 4))
    h = 1e-7
    for j, idx in enumerate((PL.X_PR, PL.X_MR, PL.X_PL, PL.X_ML)):
        got = []
        for sgn in (1, -1):
            trial = st.copy()
            trial[idx] += sgn * h
            assert composite(trial, vf, KP, ks, work, saved, False)[0] == L.OK
            got.append(trial[[PL.X_SR, PL.X_SL]])
        fd[:, j] = (got[0] - got[1]) / (2 * h)
    # the secant sensitivity and the small-angle slopes make it a Jacobian to ~1 %, not exact
    np.testing.assert_allclose(sens, fd, rtol=0.02, atol=0.02 * np.abs(fd).max())


def test_coupled_step_takes_about_one_sub_step_per_output_step_where_frozen_takes_many():
    # the stiff stress → rate feedback is damped by the step, not resolved: §10.2 at 8–12 s, where the
    # antagonist detwins through its unstable austenite (rate 1/τ), needs h = 0.1 ms frozen
    # (stepped to every 10-ms output; with dense output it takes far fewer:
    # tests/physics/test_dense_output.py)
    vr = 3.2
    coupled = simulate(12.0, vr, 0.0, solver=SolverOptions(dense_output=False))
    frozen = simulate(12.0, vr, 0.0, solver=SolverOptions(scheme="frozen"))
    assert coupled.substeps < 1.05 * 1200 < 0.2 * frozen.substeps
    assert np.abs(coupled.angle_deg - frozen.angle_deg).max() < 0.5


def test_error_control_rejects_and_shortens_steps_at_the_onset():
    # a tight tolerance at the onset of the transformation (5.5 s) needs several sub-steps per 10 ms
    loose = simulate(6.0, 3.2, 0.0)
    tight = simulate(6.0, 3.2, 0.0, solver=SolverOptions(tol_x=1e-8))
    assert tight.substeps > loose.substeps + 50
    np.testing.assert_allclose(tight.angle_deg, loose.angle_deg, atol=0.05)


def test_scheme_and_tolerance_are_validated():
    with pytest.raises(ValueError, match="scheme must be one of"):
        SolverOptions(scheme="rk4")
    with pytest.raises(ValueError, match="tol_x"):
        SolverOptions(tol_x=0.0)
    with pytest.raises(ValueError, match="tol_x"):
        SolverOptions(tol_x=0.5)
    assert SolverOptions(scheme="frozen").to_kernel()[L.S_SCHEME] == L.SCHEME_FROZEN


def test_rate_cache_never_serves_rates_of_other_constants():
    # the state caches the end-of-step rates; a copy advanced with other constants (the MPC's
    # nominal model on a randomised plant's state) must give what a cold cache gives
    n = ModelParams().n_seg
    st = simulate(9.0, 3.2, 0.0).final_state
    kp2 = ModelParams(V_L=6e-23, tau=0.012).to_kernel()
    ks = SolverOptions().to_kernel()
    vf = np.zeros((n, 2))
    warm, cold = st.copy(), st.copy()
    cold[PL.X_RCACHE : PL.X_RCACHE + PL.RCACHE_SIZE] = 0.0
    for s in (warm, cold):
        for _ in range(20):
            assert advance(s, kp2, ks, 3.2, 0.0, vf, 0.01, False)[0] == L.OK
    np.testing.assert_array_equal(warm, cold)
