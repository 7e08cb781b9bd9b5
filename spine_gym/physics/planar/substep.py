"""One sub-step of a planar spine's time integration (MODEL.md §6.1, §6.5).

:func:`_substep_coupled` (the default ``scheme``) is the linearly implicit Euler step of the
fractions with the rates at the end-of-step stress and temperature and a local error estimate
(:func:`_coupled_error`); :func:`_substep_frozen` is §6.1 as written (rates frozen at the start,
r·h <= c). Both use implicit convection and exact discrete energy bookkeeping (:func:`_apply_heat`)
and re-solve the composite module when a fraction moved (:func:`_mechanics_update`). The output
step around them is :mod:`.integrate`.
"""

from __future__ import annotations

import math

from .._jit import hot
from ..columns import (
    ERR_NONFINITE,
    ERR_TEMPERATURE,
    K_ASV,
    K_RHOC,
    K_TE,
    K_TMAX,
    METHOD_NEWTON,
    OK,
    S_C,
    S_HMAX,
    S_HMIN,
    S_METHOD,
    S_TOLX,
)
from ..coupled import (
    SECANT_MIN_DM,
    T_PER_FRACTION,
    accept_or_retry,
    copy_rows,
    first_try,
    heat_terms,
    heating_rate,
    kinetics,
    linear_system,
    quiet,
    step_rate,
)
from ..dense import last_h
from ..sma import clip_fractions, latent_heats, phase_step, rates, rates_and_slopes, resistivity
from ..stability import lu_factor, lu_solve
from .columns import (
    X_HEAD,
    X_HNEXT,
    X_ML,
    X_MR,
    X_MW,
    X_PL,
    X_PR,
    X_QCL,
    X_QCR,
    X_QJL,
    X_QJR,
    X_QLL,
    X_QLR,
    X_RCACHE,
    X_SL,
    X_SR,
    X_TL,
    X_TR,
)
from .composite import composite_in
from .mechanics import stress_sensitivity
from .work import CW_A_T, CW_B_T, CW_BACKUP, CW_LU, CW_PIV, CW_RT, CW_RT_NEW, CW_SENS, CW_VEC, CW_X0, CW_XS


@hot
def _heat(t, xp, xm, xp2, xm2, sigma, j_num, h, kp):
    """Heat balance of one wire over a sub-step (MODEL.md §6.1 d–f).

    Joule heating with the new resistivity, latent heat of the discrete Δx (exact energy
    bookkeeping), implicit convection: ρc(T' − T) = h j − h αS_V (T' − T_E) + q.

    Returns:
        (T' [K], Joule heat, convective loss, latent heat) [J/m^3] of the sub-step.
    """
    rhoc = kp[K_RHOC]
    asv = kp[K_ASV]
    t_e = kp[K_TE]
    j = j_num / resistivity(xp2, xm2, kp)
    lp, lm = latent_heats(sigma, kp)
    q = lp * (xp2 - xp) + lm * (xm2 - xm)
    t2 = (t + (h * j + h * asv * t_e + q) / rhoc) / (1.0 + h * asv / rhoc)
    return t2, h * j, h * asv * (t2 - t_e), q


@hot
def _apply_heat(state, xs, h, jr_num, jl_num, kp):
    """Advance both wires' temperatures and energy accumulators from the fractions in the state
    to ``xs`` (x₊R, x₋R, x₊L, x₋L) over h; returns OK, ERR_NONFINITE or ERR_TEMPERATURE."""
    tr2, qj, qc, ql = _heat(state[X_TR], state[X_PR], state[X_MR], xs[0], xs[1], state[X_SR], jr_num, h, kp)
    state[X_QJR] += qj
    state[X_QCR] += qc
    state[X_QLR] += ql
    tl2, qj, qc, ql = _heat(state[X_TL], state[X_PL], state[X_ML], xs[2], xs[3], state[X_SL], jl_num, h, kp)
    state[X_QJL] += qj
    state[X_QCL] += qc
    state[X_QLL] += ql
    state[X_TR] = tr2
    state[X_TL] = tl2
    if not (math.isfinite(tr2) and math.isfinite(tl2)):
        return ERR_NONFINITE
    if tr2 > kp[K_TMAX] or tl2 > kp[K_TMAX] or tr2 <= 0.0 or tl2 <= 0.0:
        return ERR_TEMPERATURE
    return OK


@hot
def _mechanics_update(state, xs, vforce, kp, ks, work, saved, mats, vecs):
    """Store the new fractions ``xs`` and re-solve the composite module if any moved (§6.1 g).

    The stresses depend on x and the shape only, so an unchanged x needs no solve. With the
    coupled Newton the secant sensitivity s = dΔθ/dM is refreshed from the two converged shapes
    (same loads). Unchecked: a failure is still classified; the step's end is checked by the caller.

    Returns:
        (status, shape passes, whether a solve ran); ``saved`` holds the starting shape.
    """
    if xs[0] == state[X_PR] and xs[1] == state[X_MR] and xs[2] == state[X_PL] and xs[3] == state[X_ML]:
        return OK, 0, False
    state[X_PR] = xs[0]
    state[X_MR] = xs[1]
    state[X_PL] = xs[2]
    state[X_ML] = xs[3]
    m_old = state[X_MW]
    st, p = composite_in(state, vforce, kp, ks, work, saved, False, mats, vecs)  # saved ← starting shape
    if st != OK or int(ks[S_METHOD]) != METHOD_NEWTON:
        return st, p, True
    n = work.shape[0]
    dm = state[X_MW] - m_old
    if abs(dm) > SECANT_MIN_DM:
        dth = state[X_HEAD : X_HEAD + n]
        s = state[X_HEAD + n : X_HEAD + 2 * n]
        for i in range(n):
            s[i] = (dth[i] - saved[i]) / dm
    return OK, p, True


@hot
def _substep_frozen(state, kp, ks, jr_num, jl_num, vforce, rem, dt, work, saved, xs, mats, vecs):
    """One sub-step of MODEL.md §6.1 as written: rates frozen at its start, r·h <= c, implicit Euler.

    Returns:
        (status, h taken, shape passes, whether the mechanics were solved).
    """
    ppA_r, pAp_r, pmA_r, pAm_r = rates(state[X_SR], state[X_TR], kp)  # a. once per sub-step
    ppA_l, pAp_l, pmA_l, pAm_l = rates(state[X_SL], state[X_TL], kp)
    xpr = state[X_PR]
    xmr = state[X_MR]
    xpl = state[X_PL]
    xml = state[X_ML]
    r = max(step_rate(xpr, xmr, ppA_r, pAp_r, pmA_r, pAm_r), step_rate(xpl, xml, ppA_l, pAp_l, pmA_l, pAm_l))
    h = rem  # b. step size
    if r * h > ks[S_C]:
        h = min(max(ks[S_C] / r, ks[S_HMIN]), rem)
    h = last_h(rem, dt, min(h, ks[S_HMAX]))
    xs[0], xs[1] = phase_step(xpr, xmr, h, ppA_r, pAp_r, pmA_r, pAm_r)  # c.
    xs[2], xs[3] = phase_step(xpl, xml, h, ppA_l, pAp_l, pmA_l, pAm_l)
    st = _apply_heat(state, xs, h, jr_num, jl_num, kp)  # d.–f.
    if st != OK:
        return st, h, 0, False
    st, p, solved = _mechanics_update(state, xs, vforce, kp, ks, work, saved, mats, vecs)  # g.
    return st, h, p, solved


@hot
def _predict_coupled(state, kp, h, jr_num, jl_num, cw):
    """Linearly implicit Euler step of the fractions over h into cw[CW_XS]; cw[CW_LU], cw[CW_PIV] keep
    the LU factors of its matrix (the identity's for a :func:`.coupled.quiet` step) for the error
    estimate's solve (:func:`_coupled_error`).

    Returns False if the matrix is singular.
    """
    n = (state.shape[0] - X_HEAD) // 2
    dth = state[X_HEAD : X_HEAD + n]
    s = state[X_HEAD + n : X_HEAD + 2 * n]
    x0 = cw[CW_X0]
    x0[0] = state[X_PR]
    x0[1] = state[X_MR]
    x0[2] = state[X_PL]
    x0[3] = state[X_ML]
    if quiet(x0, cw[CW_RT], h):
        for w in range(2):
            i = 2 * w
            r = cw[CW_RT][w]
            cw[CW_XS][i], cw[CW_XS][i + 1] = phase_step(x0[i], x0[i + 1], h, r[0], r[1], r[2], r[3])
        for i in range(4):
            for j in range(4):
                cw[CW_LU][i, j] = 1.0 if i == j else 0.0
            cw[CW_PIV][i] = i
        return True
    stress_sensitivity(dth, s, state[X_SR], state[X_SL], x0[0], x0[1], x0[2], x0[3], kp, cw[CW_SENS])
    for w in range(2):
        j_num = jr_num if w == 0 else jl_num
        t = state[X_TR] if w == 0 else state[X_TL]
        sig = state[X_SR] if w == 0 else state[X_SL]
        a_t, b_p, b_m = heat_terms(t, sig, x0[2 * w], x0[2 * w + 1], j_num, h, kp)
        cw[CW_A_T][w] = a_t
        cw[CW_B_T][w, 0] = b_p
        cw[CW_B_T][w, 1] = b_m
    linear_system(x0, cw[CW_RT], cw[CW_SENS], h, cw[CW_A_T], cw[CW_B_T], cw[CW_LU], cw[CW_VEC])
    if not lu_factor(cw[CW_LU], cw[CW_PIV]):
        return False
    lu_solve(cw[CW_LU], cw[CW_PIV], cw[CW_VEC])
    for w in range(2):
        i = 2 * w
        cw[CW_XS][i], cw[CW_XS][i + 1] = clip_fractions(x0[i] + cw[CW_VEC][i], x0[i + 1] + cw[CW_VEC][i + 1])
    return True


@hot
def _coupled_error(state, h, jr_num, jl_num, kp, cw):
    """Local error estimate of the coupled step, in units of the fractions (see :func:`_substep_coupled`).

    The larger of (i) the Newton correction (I − hJ)⁻¹ (h F₁ − Δx) that the linearisation missed,
    (ii) the implicit Euler truncation error ½ h |F₁ − F₀| of each fraction and (iii) that of each
    temperature, ½ h |Ṫ₁ − Ṫ₀|, divided by ``T_PER_FRACTION``. cw[CW_X0]/cw[CW_RT] hold the start, the
    state and cw[CW_XS]/cw[CW_RT_NEW] the end of the step.
    """
    trunc = 0.0
    for w in range(2):
        i = 2 * w
        f0p, f0m = kinetics(cw[CW_X0][i], cw[CW_X0][i + 1], cw[CW_RT][w])
        f1p, f1m = kinetics(cw[CW_XS][i], cw[CW_XS][i + 1], cw[CW_RT_NEW][w])
        trunc = max(trunc, 0.5 * h * abs(f1p - f0p), 0.5 * h * abs(f1m - f0m))
        j_num = jr_num if w == 0 else jl_num
        t1 = state[X_TR] if w == 0 else state[X_TL]
        sig1 = state[X_SR] if w == 0 else state[X_SL]
        t0 = cw[CW_BACKUP][X_TR] if w == 0 else cw[CW_BACKUP][X_TL]
        sig0 = cw[CW_BACKUP][X_SR] if w == 0 else cw[CW_BACKUP][X_SL]
        d0 = heating_rate(t0, cw[CW_X0][i], cw[CW_X0][i + 1], f0p, f0m, sig0, j_num, kp)
        d1 = heating_rate(t1, cw[CW_XS][i], cw[CW_XS][i + 1], f1p, f1m, sig1, j_num, kp)
        trunc = max(trunc, 0.5 * h * abs(d1 - d0) / T_PER_FRACTION)
        cw[CW_VEC][i] = h * f1p - (cw[CW_XS][i] - cw[CW_X0][i])
        cw[CW_VEC][i + 1] = h * f1m - (cw[CW_XS][i + 1] - cw[CW_X0][i + 1])
    lu_solve(cw[CW_LU], cw[CW_PIV], cw[CW_VEC])  # the step's own factors (the same elimination)
    e = 0.0
    for i in range(4):
        e = max(e, abs(cw[CW_VEC][i]))
    return max(e, trunc)


@hot
def _substep_coupled(state, kp, ks, jr_num, jl_num, vforce, rem, dt, work, saved, cw, mats, vecs):
    """One accepted sub-step of the coupled scheme (the default ``scheme``).

    The step is the linearly implicit Euler step of :func:`.coupled.linear_system`: the rates are taken at
    the end-of-step stress and temperature, predicted through the composite equilibrium's
    sensitivity, so the stiff stress → rate feedback (transforming 0.1 % of a constrained wire
    moves its stress by MPa, §6.2) is damped instead of resolved. The step size comes from a local
    error estimate: the residual of the exact implicit Euler equations at the new state (what the
    linearisation missed) plus the implicit Euler truncation error ½ h (F₁ − F₀), both filtered by
    the step's own matrix (I − hJ)⁻¹ so that fast modes at their quasi-steady state do not count
    (Shampine's filter). A step whose error exceeds ``tol_x`` is rejected and retried smaller
    (down to ``h_min``); the next step is proposed as h · 0.9 (tol/err)^½ and kept in the state.
    The rates at the end of an accepted step are the next step's (cw[CW_RT]), so they are computed
    once per sub-step.

    Returns:
        (status, h taken, shape passes, whether the mechanics were solved).
    """
    n = work.shape[0]
    dth = state[X_HEAD : X_HEAD + n]
    tol = ks[S_TOLX]
    h_min = ks[S_HMIN]
    h = first_try(state[X_HNEXT], rem, ks[S_HMAX])
    for i in range(X_RCACHE):
        cw[CW_BACKUP][i] = state[i]
    passes = 0
    while True:
        hh = last_h(rem, dt, h)
        if not _predict_coupled(state, kp, hh, jr_num, jl_num, cw):
            return ERR_NONFINITE, hh, passes, False
        st = _apply_heat(state, cw[CW_XS], hh, jr_num, jl_num, kp)
        solved = False
        if st == OK:
            st, p, solved = _mechanics_update(state, cw[CW_XS], vforce, kp, ks, work, saved, mats, vecs)
            passes += p
        if st != OK:
            return st, hh, passes, solved
        rates_and_slopes(state[X_SR], state[X_TR], kp, cw[CW_RT_NEW][0])
        rates_and_slopes(state[X_SL], state[X_TL], kp, cw[CW_RT_NEW][1])
        err = _coupled_error(state, hh, jr_num, jl_num, kp, cw) / tol
        accepted, h = accept_or_retry(err, hh, h, h_min)
        if accepted:
            copy_rows(cw[CW_RT], cw[CW_RT_NEW])
            state[X_HNEXT] = h
            return OK, hh, passes, solved
        for i in range(X_RCACHE):  # rejected: back to the start of the sub-step
            state[i] = cw[CW_BACKUP][i]
        if solved:
            for i in range(n):
                dth[i] = saved[i]
