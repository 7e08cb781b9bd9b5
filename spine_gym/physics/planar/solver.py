"""Composite constitutive/bending solve and time integration (MODEL.md §5, §6).

The composite module (§5) finds, for given phase fractions and loads, the wire moment M for which
the wire stresses computed from the strains implied by the spine shape Δθ(M) reproduce M. Its
residual g(M) = G(M) − M is strictly decreasing, so a bracketed root always exists. Three solvers:

* ``bisect`` — the seed's bisection on M (§5.2) with a full shape solve per evaluation;
* ``illinois`` — the same bracket, safeguarded regula falsi (Illinois), full shape solves;
* ``newton`` (default) — one shape pass per outer iteration, M updated by Newton with the loop gain
  dG/dM = Σ_n ∂G/∂Δθ_n · s_n, where s = dΔθ/dM is a secant sensitivity carried in the state, and
  the shape predicted by Δθ += s ΔM (MODEL.md §6.4). If it does not converge within the caps it
  falls back to ``illinois`` from the untouched starting point, so the bracket is the safeguard.

:func:`advance` integrates one output step with adaptive sub-steps, implicit Euler on the phases,
implicit convection and exact discrete energy bookkeeping (§6.1); :func:`advance_held` integrates
a span of output steps with held inputs in one go, the sub-steps crossing the output points and
the outputs inside a sub-step interpolated (dense output, §6.5, :mod:`.dense`).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import hot, jit
from ..columns import (
    ERR_BUCKLING,
    ERR_NONFINITE,
    ERR_ROOT,
    ERR_SUBSTEPS,
    ERR_TEMPERATURE,
    K_A,
    K_ASV,
    K_AW,
    K_EI,
    K_EPS0,
    K_EPST,
    K_KE,
    K_L0,
    K_LREF,
    K_LS,
    K_NSEG,
    K_NW,
    K_RHOC,
    K_TE,
    K_TMAX,
    METHOD_BISECT,
    METHOD_NEWTON,
    OK,
    RATE_KP,
    S_C,
    S_HMAX,
    S_HMIN,
    S_MAXROOT,
    S_MAXSHAPE,
    S_MAXSUB,
    S_METHOD,
    S_SCHEME,
    S_TOLM,
    S_TOLTH,
    S_TOLX,
    SCHEME_COUPLED,
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
from ..dense import interpolate, last_h, output_fraction
from ..sma import (
    clip_fractions,
    compliance,
    latent_heats,
    phase_step,
    rates,
    rates_and_slopes,
    resistivity,
    stress,
)
from ..stability import lu_factor, lu_solve, solve_in_place
from .columns import (
    X_EL,
    X_ER,
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
    X_TIME,
    X_TL,
    X_TR,
)
from .record import record
from .stability import equilibrium_jacobian, is_buckled_in, needs_stability_check
from .tube import segment_lengths, shape_pass, solve_shape, solve_shape_in, wire_lengths

NEWTON_HALVINGS = 30  # step halvings of the whole-shape Newton before it takes the last one


@hot
def wire_mechanics(dth, xpr, xmr, xpl, xml, kp):
    """Strains, stresses and the moment they produce, for a given shape (MODEL.md §3.6, §4.4, §4.8).

    Returns:
        (ε_R, ε_L, σ_R [Pa], σ_L [Pa], G = n_w A_w a (σ_R − σ_L) [N m]).
    """
    lr, ll = wire_lengths(dth, kp)
    return _wire_state(lr, ll, xpr, xmr, xpl, xml, kp)


@hot
def _wire_state(lr, ll, xpr, xmr, xpl, xml, kp):
    """(ε_R, ε_L, σ_R, σ_L, G) of :func:`wire_mechanics` from the wire lengths L_R, L_L [m]."""
    lref = kp[K_LREF]
    er = lr / lref - 1.0
    el = ll / lref - 1.0
    sr = stress(er, xpr, xmr, kp)
    sl = stress(el, xpl, xml, kp)
    return er, el, sr, sl, kp[K_NW] * kp[K_AW] * kp[K_A] * (sr - sl)


@hot
def mechanics_and_gain(dth, s, xpr, xmr, xpl, xml, kp):
    """:func:`wire_mechanics` and :func:`moment_gain` of one shape in one pass over its segments
    (the coupled Newton needs both every iteration; the same arithmetic, bit for bit).

    Returns:
        (ε_R, ε_L, σ_R, σ_L, G, dG/dM).
    """
    ls = kp[K_LS]
    a = kp[K_A]
    lr = kp[K_L0] - kp[K_NSEG] * ls
    ll = lr
    sum_c = 0.0
    sum_k = 0.0
    for i in range(dth.shape[0]):
        x = dth[i]
        dr, dl = segment_lengths(x, ls, a)
        lr += dr
        ll += dl
        pc, pk = _segment_response(x, s[i], ls, a)
        sum_c += pc
        sum_k += pk
    er, el, sr, sl, gm = _wire_state(lr, ll, xpr, xmr, xpl, xml, kp)
    gain = moment_gain(sum_c - sum_k, sum_c + sum_k, sr, sl, xpr, xmr, xpl, xml, kp)
    return er, el, sr, sl, gm, gain


@hot
def length_per_moment(dth, s, kp):
    """dL_R/dM and dL_L/dM [m/(N m)] of the shape response s = dΔθ/dM (MODEL.md §4.8).

    ∂L_R/∂Δθ_n = c'_n − a cos(Δθ_n/2), ∂L_L/∂Δθ_n = c'_n + a cos(Δθ_n/2), with the small-angle
    forms c' ≈ −ls Δθ/12 and cos ≈ 1 − Δθ²/8 (a Newton step or a Jacobian only needs ~1 %).
    """
    a = kp[K_A]
    ls = kp[K_LS]
    sum_c = 0.0
    sum_k = 0.0
    for i in range(dth.shape[0]):
        pc, pk = _segment_response(dth[i], s[i], ls, a)
        sum_c += pc
        sum_k += pk
    return sum_c - sum_k, sum_c + sum_k


@hot
def _segment_response(x, s_n, ls, a):
    """One segment's terms (c'_n s_n, a cos(Δθ_n/2) s_n) of :func:`length_per_moment`, small-angle forms."""
    return (-ls * x / 12.0) * s_n, a * (1.0 - x * x / 8.0) * s_n


@hot
def _taut_stiffness(sigma, xp, xm, kp):
    """Tangent modulus dσ/dε [Pa] of a wire for the Newton slopes: 1/compliance, 0 when slack."""
    return 1.0 / compliance(xp, xm, kp) if sigma > 0.0 else 0.0


@hot
def moment_gain(dl_r, dl_l, sr, sl, xpr, xmr, xpl, xml, kp):
    """dG/dM = Σ_n ∂G/∂Δθ_n s_n ≤ 0: how the wire moment answers a change of the applied moment.

    G = n_w A_w a (σ_R − σ_L) with dσ_w = E*_w dL_w / L_ref, from dL_R/dM and dL_L/dM of the shape
    response s (:func:`length_per_moment`, summed in :func:`mechanics_and_gain`); a slack wire
    (σ = 0) has zero tangent stiffness.
    """
    k_r = _taut_stiffness(sr, xpr, xmr, kp)
    k_l = _taut_stiffness(sl, xpl, xml, kp)
    pref = kp[K_NW] * kp[K_AW] * kp[K_A] / kp[K_LREF]
    return pref * (k_r * dl_r - k_l * dl_l)


@hot
def stress_sensitivity(dth, s, sr, sl, xpr, xmr, xpl, xml, kp, out):
    """dσ_w/dx of the composite equilibrium (§5) under fixed loads, written into ``out`` (2, 4).

    Rows: σ_R, σ_L; columns: x₊R, x₋R, x₊L, x₋L. At fixed strain the constitutive law §3.6 gives
    ∂σ/∂x₊ = −E* (ε_T + σ k_E) and ∂σ/∂x₋ = E* (ε_T − σ k_E) (E* = 1/compliance, 0 when slack);
    the moment then moves by dM = n_w A_w a (dσ_R − dσ_L)|_ε / (1 − dG/dM) and each strain by
    (dε_w/dM) dM (:func:`length_per_moment`). Used as the Jacobian of the coupled time step.
    """
    dl_r, dl_l = length_per_moment(dth, s, kp)
    e_r = dl_r / kp[K_LREF]
    e_l = dl_l / kp[K_LREF]
    k_r = _taut_stiffness(sr, xpr, xmr, kp)
    k_l = _taut_stiffness(sl, xpl, xml, kp)
    eps_t = kp[K_EPST]
    k_e = kp[K_KE]
    ar_p = -k_r * (eps_t + sr * k_e)
    ar_m = k_r * (eps_t - sr * k_e)
    al_p = -k_l * (eps_t + sl * k_e)
    al_m = k_l * (eps_t - sl * k_e)
    kg = kp[K_NW] * kp[K_AW] * kp[K_A]
    f = kg / (1.0 - kg * (k_r * e_r - k_l * e_l))
    cr = k_r * e_r * f
    cl = k_l * e_l * f
    out[0, 0] = ar_p * (1.0 + cr)
    out[0, 1] = ar_m * (1.0 + cr)
    out[0, 2] = -cr * al_p
    out[0, 3] = -cr * al_m
    out[1, 0] = cl * ar_p
    out[1, 1] = cl * ar_m
    out[1, 2] = al_p * (1.0 - cl)
    out[1, 3] = al_m * (1.0 - cl)


@hot
def _residual_full(dth, m, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape, new):
    """g(M) = G(M) − M with a full (warm-started) shape solve at M (scratch ``new`` (N,));
    returns (status, passes, g)."""
    st, it = solve_shape_in(dth, m, vforce, kp, tol_th, max_shape, new)
    er, el, sr, sl, gm = wire_mechanics(dth, xpr, xmr, xpl, xml, kp)
    return st, it, gm - m


@hot
def composite_bracketed(dth, m_prev, xpr, xmr, xpl, xml, vforce, kp, ks, illinois, new):
    """Bracketed composite solve (MODEL.md §5.2): bisection (seed) or Illinois regula falsi.

    The bracket is [min, max](M_prev, G(M_prev)); for a non-increasing G the root lies inside.
    ``new`` (N,) is the shape solves' scratch. One kernel of ~80 lines: the bracket search and the
    bisection/Illinois loop share their bracket state, and splitting them would change the compiled
    kernel that the seed's results (``method="bisect"``) are checked against.

    Returns:
        (status, M, passes): ``dth`` holds the converged shape for M.
    """
    tol_m = ks[S_TOLM]
    tol_th = ks[S_TOLTH]
    max_shape = int(ks[S_MAXSHAPE])
    max_root = int(ks[S_MAXROOT])
    passes = 0
    st, it, g0 = _residual_full(dth, m_prev, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape, new)
    passes += it
    if st != OK:
        return st, m_prev, passes
    if g0 == 0.0:
        return OK, m_prev, passes
    m_other = m_prev + g0  # = G(M_prev)
    if g0 > 0.0:
        lo, hi, g_lo = m_prev, m_other, g0
        g_hi = 0.0
    else:
        lo, hi, g_hi = m_other, m_prev, g0
        g_lo = 0.0
    if not illinois:
        for _ in range(max_root):
            if hi - lo <= tol_m:
                m = 0.5 * (lo + hi)
                st, it, gm = _residual_full(dth, m, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape, new)
                return st, m, passes + it
            m = 0.5 * (lo + hi)
            st, it, gm = _residual_full(dth, m, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape, new)
            passes += it
            if st != OK:
                return st, m, passes
            if gm > 0.0:
                lo = m
            else:
                hi = m
        return ERR_ROOT, 0.5 * (lo + hi), passes
    # Illinois: needs g at the second end of the bracket
    st, it, g_end = _residual_full(dth, m_other, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape, new)
    passes += it
    if st != OK:
        return st, m_other, passes
    if g0 > 0.0:
        g_hi = g_end
    else:
        g_lo = g_end
    if g_end == 0.0:
        return OK, m_other, passes
    side = 0
    m = m_other
    for _ in range(max_root):
        denom = g_lo - g_hi
        if denom > 0.0:
            m = lo + g_lo * (hi - lo) / denom
        else:
            m = 0.5 * (lo + hi)
        if not (lo < m < hi):  # guard against roundoff at the ends
            m = 0.5 * (lo + hi)
        st, it, gm = _residual_full(dth, m, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape, new)
        passes += it
        if st != OK:
            return st, m, passes
        if abs(gm) <= tol_m or hi - lo <= tol_m:
            return OK, m, passes
        if gm > 0.0:
            lo, g_lo = m, gm
            if side == 1:  # the same end moved twice: halve the other end's residual
                g_hi *= 0.5
            side = 1
        else:
            hi, g_hi = m, gm
            if side == -1:
                g_lo *= 0.5
            side = -1
    return ERR_ROOT, m, passes


@hot
def composite_newton(dth, s, m, xpr, xmr, xpl, xml, vforce, kp, ks, work):
    """Coupled Newton composite solve: one shape pass per iteration (see the module docstring).

    Returns:
        (status, M, passes, ε_R, ε_L, σ_R, σ_L) with the mechanics of the converged shape.
    """
    tol_m = ks[S_TOLM]
    tol_th = ks[S_TOLTH]
    max_root = int(ks[S_MAXROOT])
    n = dth.shape[0]
    e = np.inf
    passes = 0
    for _ in range(max_root):
        er, el, sr, sl, gm, gain = mechanics_and_gain(dth, s, xpr, xmr, xpl, xml, kp)
        slope = 1.0 - gain  # = −g'(M) >= 1
        dm = (gm - m) / slope
        if e < tol_th and abs(dm) < tol_m:
            return OK, m, passes, er, el, sr, sl
        if not math.isfinite(dm):
            return ERR_NONFINITE, m, passes, er, el, sr, sl
        m += dm
        for i in range(n):
            dth[i] += s[i] * dm
        e = shape_pass(dth, m, vforce, kp, work)
        passes += 1
        for i in range(n):
            dth[i] = work[i]
    return ERR_ROOT, m, passes, 0.0, 0.0, 0.0, 0.0


@hot
def composite_full_newton(dth, xpr, xmr, xpl, xml, vforce, kp, ks, work, mats, vecs):
    """Newton on the whole shape: solve R(Δθ) = Δθ − f(Δθ, G(Δθ)) = 0 with the exact tangent I − J.

    The fallback of the coupled Newton near buckling, where the fixed-point shape iteration
    contracts only by ≈ (load / critical load) per pass and runs out of iterations. J is
    :func:`stability.equilibrium_jacobian`; each iteration costs O(N³). Scratch: ``mats``
    (2, N, N) and ``vecs`` (3, N) (the first two rows).

    Returns:
        (status, M, iterations, ε_R, ε_L, σ_R, σ_L) with ``dth`` the converged shape.
    """
    tol_th = ks[S_TOLTH]
    n = dth.shape[0]
    jac = mats[0]
    lu = mats[1]
    trial = vecs[0]
    f_trial = vecs[1]
    for it in range(int(ks[S_MAXROOT])):
        er, el, sr, sl, gm = wire_mechanics(dth, xpr, xmr, xpl, xml, kp)
        e = shape_pass(dth, gm, vforce, kp, work)
        if not math.isfinite(e):
            return ERR_NONFINITE, gm, it, er, el, sr, sl
        if e < tol_th:
            return OK, gm, it + 1, er, el, sr, sl
        equilibrium_jacobian(dth, xpr, xmr, xpl, xml, vforce, kp, jac)
        for i in range(n):
            for j in range(n):
                lu[i, j] = (1.0 if i == j else 0.0) - jac[i, j]
            work[i] -= dth[i]  # −R
        if not solve_in_place(lu, work):
            return ERR_ROOT, gm, it + 1, er, el, sr, sl
        # backtracking: halve the step until the residual falls. A full step can jump across a
        # slack kink of the wires (σ = max(σ, 0)) and cycle between the two sides forever.
        lam = 1.0
        for _ in range(NEWTON_HALVINGS):
            for i in range(n):
                trial[i] = dth[i] + lam * work[i]
            gt = wire_mechanics(trial, xpr, xmr, xpl, xml, kp)[4]
            et = shape_pass(trial, gt, vforce, kp, f_trial)
            if et < e:
                break
            lam *= 0.5
        for i in range(n):
            dth[i] = trial[i]
    return ERR_ROOT, 0.0, int(ks[S_MAXROOT]), 0.0, 0.0, 0.0, 0.0


@hot
def _fallbacks(dth, m0, xpr, xmr, xpl, xml, vforce, kp, ks, work, saved, mats, vecs):
    """After the coupled Newton failed: Newton on the whole shape (needed near buckling), then the
    bracketed Illinois solve as the last safeguard, each from the starting shape ``saved``
    (scratch ``mats``, ``vecs`` as :func:`composite_full_newton`).

    Returns:
        (status, M, passes, ε_R, ε_L, σ_R, σ_L).
    """
    n = dth.shape[0]
    for i in range(n):
        dth[i] = saved[i]
    st, m, passes, er, el, sr, sl = composite_full_newton(
        dth, xpr, xmr, xpl, xml, vforce, kp, ks, work, mats, vecs
    )
    if st == OK:
        return st, m, passes, er, el, sr, sl
    for i in range(n):
        dth[i] = saved[i]
    st, m, p2 = composite_bracketed(dth, m0, xpr, xmr, xpl, xml, vforce, kp, ks, True, vecs[2])
    er, el, sr, sl, gm = wire_mechanics(dth, xpr, xmr, xpl, xml, kp)
    return st, m, passes + p2, er, el, sr, sl


@hot
def _buckling_status(state, st, vforce, kp, check, saved, mats):
    """Status of a solve after the stability test (see :func:`composite`); restores Δθ on failure."""
    n = saved.shape[0]
    dth = state[X_HEAD : X_HEAD + n]
    xpr = state[X_PR]
    xmr = state[X_MR]
    xpl = state[X_PL]
    xml = state[X_ML]
    if st == OK and not is_buckled_in(dth, xpr, xmr, xpl, xml, vforce, kp, mats):
        return OK
    for i in range(n):
        dth[i] = saved[i]
    if st == OK or (not check and is_buckled_in(dth, xpr, xmr, xpl, xml, vforce, kp, mats)):
        return ERR_BUCKLING
    return st


@jit
def composite(state, vforce, kp, ks, work, saved, check):
    """Solve the composite module for the state's fractions and the loads ``vforce``, in place:
    :func:`composite_in` with its scratch allocated here.

    Returns:
        (status, shape passes used).
    """
    n = work.shape[0]
    return composite_in(state, vforce, kp, ks, work, saved, check, np.empty((2, n, n)), np.empty((3, n)))


@hot
def composite_in(state, vforce, kp, ks, work, saved, check, mats, vecs):
    """Solve the composite module for the state's fractions and the loads ``vforce``, in place.

    Updates Δθ, M, ε_w, σ_w in ``state``; ``saved`` receives the starting shape. Default solver: the
    coupled Newton, then :func:`_fallbacks`. With ``check`` (loads that might buckle the spine, see
    :func:`stability.needs_stability_check`) both the starting shape (the last equilibrium, under the new
    loads and fractions) and the converged one are tested for stability, and ERR_BUCKLING is returned,
    state untouched, if either is unstable: the load path has passed a stability limit, even if the solver
    would find a distant post-buckled equilibrium (a snap the quasi-static model cannot follow). A solve
    that fails is reported as ERR_BUCKLING if its starting shape is unstable, else with the solver's own
    status; Δθ is left at the starting shape. Scratch (no allocation): ``work``, ``saved`` (N,), ``mats``
    (2, N, N), ``vecs`` (3, N).

    Returns:
        (status, shape passes used).
    """
    n = work.shape[0]
    dth = state[X_HEAD : X_HEAD + n]
    s = state[X_HEAD + n : X_HEAD + 2 * n]
    xpr = state[X_PR]
    xmr = state[X_MR]
    xpl = state[X_PL]
    xml = state[X_ML]
    m0 = state[X_MW]
    method = int(ks[S_METHOD])
    for i in range(n):
        saved[i] = dth[i]
    if check and is_buckled_in(dth, xpr, xmr, xpl, xml, vforce, kp, mats):
        return ERR_BUCKLING, 0
    if method == METHOD_NEWTON:
        st, m, passes, er, el, sr, sl = composite_newton(dth, s, m0, xpr, xmr, xpl, xml, vforce, kp, ks, work)
        if st != OK:
            st, m, p2, er, el, sr, sl = _fallbacks(
                dth, m0, xpr, xmr, xpl, xml, vforce, kp, ks, work, saved, mats, vecs
            )
            passes += p2
    else:
        st, m, passes = composite_bracketed(
            dth, m0, xpr, xmr, xpl, xml, vforce, kp, ks, method != METHOD_BISECT, vecs[2]
        )
        er, el, sr, sl, gm = wire_mechanics(dth, xpr, xmr, xpl, xml, kp)
    if st != OK or check:
        st = _buckling_status(state, st, vforce, kp, check, saved, mats)
        if st != OK:
            return st, passes
    state[X_MW] = m
    state[X_ER] = er
    state[X_EL] = el
    state[X_SR] = sr
    state[X_SL] = sl
    return OK, passes


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


# the coupled sub-step's scratch arrays: a tuple indexed by these (compile-time) constants
CW_X0, CW_XS, CW_RT, CW_RT_NEW, CW_SENS, CW_A_T, CW_B_T, CW_PIV, CW_LU, CW_VEC, CW_BACKUP = range(11)


COUPLED_WORK_SIZE = 4 + 4 + 24 + 24 + 8 + 2 + 4 + 4 + 16 + 4 + X_RCACHE  # floats of the CW_* scratch


@jit
def coupled_work(buf):
    """Scratch arrays of the coupled sub-step (the CW_* fields) as views of one flat ``buf``:
    fractions at the start and end (4), rates and slopes at the start and end (2, 12), dσ/dx (2, 4),
    the temperature terms a_t (2) and b_t (2, 2), the row exchanges (4, int64 over 4 floats) and LU
    factors (4, 4) of the step matrix, a vector (4), the state's head before the step (X_RCACHE)."""
    v = buf[:COUPLED_WORK_SIZE]
    return (
        v[0:4],
        v[4:8],
        v[8:32].reshape((2, 12)),
        v[32:56].reshape((2, 12)),
        v[56:64].reshape((2, 4)),
        v[64:66],
        v[66:70].reshape((2, 2)),
        v[70:74].view(np.int64),
        v[74:90].reshape((4, 4)),
        v[90:94],
        v[94:COUPLED_WORK_SIZE],
    )


_KEY = 4 + len(RATE_KP)  # (σ_R, T_R, σ_L, T_L) and the RATE_KP constants


@hot
def _cached_rates(state, kp, rt):
    """Rates and slopes (2, 12) at the state's stresses and temperatures into ``rt``: from the
    state's cache if it was filled at exactly these (σ_R, T_R, σ_L, T_L) and constants, else computed."""
    c = X_RCACHE
    hit = (
        state[c] == state[X_SR]
        and state[c + 1] == state[X_TR]
        and state[c + 2] == state[X_SL]
        and state[c + 3] == state[X_TL]
    )
    for k in range(len(RATE_KP)):
        hit = hit and state[c + 4 + k] == kp[RATE_KP[k]]
    if hit:
        for k in range(12):
            rt[0, k] = state[c + _KEY + k]
            rt[1, k] = state[c + _KEY + 12 + k]
        return
    rates_and_slopes(state[X_SR], state[X_TR], kp, rt[0])
    rates_and_slopes(state[X_SL], state[X_TL], kp, rt[1])


@hot
def _cache_rates(state, kp, rt):
    """Keep the rates ``rt`` at the state's (σ_R, T_R, σ_L, T_L) and constants for the next output step."""
    c = X_RCACHE
    state[c] = state[X_SR]
    state[c + 1] = state[X_TR]
    state[c + 2] = state[X_SL]
    state[c + 3] = state[X_TL]
    for k in range(len(RATE_KP)):
        state[c + 4 + k] = kp[RATE_KP[k]]
    for k in range(12):
        state[c + _KEY + k] = rt[0, k]
        state[c + _KEY + 12 + k] = rt[1, k]


@jit
def advance(state, kp, ks, v_r, v_l, vforce, dt, resolve=True):
    """Advance one spine by one output step ``dt`` with voltages and loads held (MODEL.md §6.1).

    Args:
        state: model state (see :mod:`.columns`), updated in place.
        kp, ks: constants and solver options.
        v_r, v_l: voltage on each wire of the right / left side [V].
        vforce: (N, 2) external forces at the vertices P_0 … P_{N−1} [N], global x/y.
        dt: output step [s].
        resolve: solve the mechanics first (needed when the loads changed since the last call;
            callers that know the loads are unchanged pass False to save a solve).

    The sub-steps are those of the option ``scheme``: :func:`_substep_coupled` (default) or
    :func:`_substep_frozen`. Under loads that might buckle the spine
    (:func:`stability.needs_stability_check`) the re-solve is checked for stability and so is the shape
    the step ends on; a sub-step whose solve fails is classified by :func:`composite`. An unstable
    equilibrium ends the step with ERR_BUCKLING.

    Returns:
        (status, sub-steps, shape passes).
    """
    st, _done, nsub, passes = _advance(state, kp, ks, v_r, v_l, vforce, dt, 1, resolve, None, 0)
    return st, nsub, passes


@jit
def advance_held(state, kp, ks, v_r, v_l, vforce, dt, n_out, resolve, out, row0):
    """Advance by ``n_out`` output steps of ``dt`` over which the inputs are held, in one span.

    The sub-steps run across the output points (MODEL.md §6.5, :mod:`.dense`): only the span's end
    cuts one. The record (:func:`.record.record`) of the state at output j = 1 … n_out goes to
    ``out[row0 + j − 1]``, linearly interpolated between the ends of the sub-step that contains it.
    With n_out = 1 this is :func:`advance` followed by a record. Arguments as :func:`advance`;
    the cap ``max_substeps`` and the stability check of the end shape apply per output step.

    Returns:
        (status, output steps completed, sub-steps, shape passes).
    """
    return _advance(state, kp, ks, v_r, v_l, vforce, dt, n_out, resolve, out, row0)


@hot
def _complete_outputs(state, start, mid, kp, out, row0, dt, n_out, done, sub):
    """Complete the outputs done + 1, … that the sub-step ``sub`` = (e0, e1, ends the span) reached
    (:func:`.dense.output_fraction`): the model time and, with ``out``, their records, interpolated
    between ``start`` and the state (dense output). Returns the outputs completed."""
    e0, e1, at_end = sub
    theta = output_fraction(done + 1, n_out, dt, e0, e1, at_end)
    while theta >= 0.0:
        state[X_TIME] += dt
        if out is not None:
            if theta == 1.0:
                record(state, kp, out[row0 + done])
            else:
                interpolate(start, state, theta, mid)
                mid[X_TIME] = state[X_TIME]
                record(mid, kp, out[row0 + done])
        done += 1
        if done == n_out:
            break
        theta = output_fraction(done + 1, n_out, dt, e0, e1, at_end)
    return done


@jit
def _advance(state, kp, ks, v_r, v_l, vforce, dt, n_out, resolve, out, row0):
    """:func:`advance_held`; ``out`` None records nothing (and copies nothing per sub-step)."""
    n = (state.shape[0] - X_HEAD) // 2
    size = state.shape[0]
    rows = 0 if out is None else 2 * size
    buf = np.empty(2 * n + COUPLED_WORK_SIZE + 2 * n * n + 3 * n + rows)  # one allocation per call
    work = buf[:n]
    saved = buf[n : 2 * n]
    cw = coupled_work(buf[2 * n : 2 * n + COUPLED_WORK_SIZE])
    k = 2 * n + COUPLED_WORK_SIZE  # the fallbacks' and the stability test's scratch
    mats = buf[k : k + 2 * n * n].reshape((2, n, n))
    vecs = buf[k + 2 * n * n : k + 2 * n * n + 3 * n].reshape((3, n))
    k += 2 * n * n + 3 * n
    start = buf[k : k + size]
    mid = buf[k + size :]
    scratch = (work, saved, mats, vecs, start, mid)
    return _span(state, kp, ks, v_r, v_l, vforce, dt, n_out, resolve, out, row0, scratch, cw)


@hot
def _span(state, kp, ks, v_r, v_l, vforce, dt, n_out, resolve, out, row0, scratch, cw):
    """The body of :func:`_advance` on its scratch arrays ``scratch`` = (work, saved, mats, vecs,
    start, mid) and ``cw`` (:func:`coupled_work`), allocated by the caller (no allocation here)."""
    work, saved, mats, vecs, start, mid = scratch
    n = work.shape[0]
    # 0. loads may have changed since the last call: re-solve the mechanics with the current x
    passes = 0
    check = needs_stability_check(vforce, kp)
    if resolve:
        st, passes = composite_in(state, vforce, kp, ks, work, saved, check, mats, vecs)
        if st != OK:
            return st, 0, 0, passes
    l0sq = kp[K_L0] * kp[K_L0]
    jr_num = v_r * v_r / l0sq
    jl_num = v_l * v_l / l0sq
    coupled = int(ks[S_SCHEME]) == SCHEME_COUPLED
    max_sub = int(ks[S_MAXSUB])
    span = dt * n_out
    rem = span
    nsub = 0
    since = 0  # sub-steps since the last output
    done = 0  # output steps completed
    solved = False
    if coupled:
        _cached_rates(state, kp, cw[CW_RT])
    while rem > 0.0:
        if out is not None:
            for i in range(start.shape[0]):
                start[i] = state[i]
        e0 = span - rem
        if coupled:
            st, h, p, sol = _substep_coupled(
                state, kp, ks, jr_num, jl_num, vforce, rem, dt, work, saved, cw, mats, vecs
            )
        else:
            st, h, p, sol = _substep_frozen(
                state, kp, ks, jr_num, jl_num, vforce, rem, dt, work, saved, cw[CW_XS], mats, vecs
            )
        passes += p
        solved = solved or sol
        if st != OK:
            return st, done, nsub, passes
        rem -= h
        nsub += 1
        since += 1
        if since > max_sub:
            return ERR_SUBSTEPS, done, nsub, passes
        sub = (e0, span - rem, rem <= 0.0)
        if coupled and rem <= 0.0:
            _cache_rates(state, kp, cw[CW_RT])
        if output_fraction(done + 1, n_out, dt, sub[0], sub[1], sub[2]) >= 0.0:
            # h. the sub-step reached an output: stability of the shape it ends on (once per output
            # step at most: the O(N³) test on every sub-step would triple the cost of a heavily
            # loaded run)
            dth = state[X_HEAD : X_HEAD + n]
            if (
                check
                and solved
                and is_buckled_in(dth, state[X_PR], state[X_MR], state[X_PL], state[X_ML], vforce, kp, mats)
            ):
                return ERR_BUCKLING, done, nsub, passes
            done = _complete_outputs(state, start, mid, kp, out, row0, dt, n_out, done, sub)
            since = 0
            solved = False
    return OK, done, nsub, passes


@jit
def init_state(state, kp, ks, vforce):
    """Initial state (MODEL.md §3.10) under the loads ``vforce``, written into ``state``.

    T = T_E, x_A = 0, x₊ = ½(1 + ε0/ε_T) (zero stress at the pre-strain), straight spine. The Newton
    sensitivity s = dΔθ/dM starts as a finite difference of two shape solves, then the mechanics
    are solved for the given loads (gravity alone keeps a symmetric spine straight, but if it is
    past buckling that is reported: ERR_BUCKLING).

    Returns:
        status of the mechanical solve.
    """
    n = (state.shape[0] - X_HEAD) // 2
    for i in range(state.shape[0]):
        state[i] = 0.0
    xp0 = 0.5 * (1.0 + kp[K_EPS0] / kp[K_EPST])
    state[X_PR] = xp0
    state[X_MR] = 1.0 - xp0
    state[X_PL] = xp0
    state[X_ML] = 1.0 - xp0
    state[X_TR] = kp[K_TE]
    state[X_TL] = kp[K_TE]
    state[X_ER] = kp[K_EPS0]
    state[X_EL] = kp[K_EPS0]
    s = state[X_HEAD + n : X_HEAD + 2 * n]
    zero = np.zeros((n, 2))
    probe = np.zeros(n)
    dm = 1e-3
    tol_th = ks[S_TOLTH]
    max_shape = int(ks[S_MAXSHAPE])
    st, it = solve_shape(probe, dm, zero, kp, tol_th, max_shape)
    for i in range(n):
        # a tube that buckles under its own weight at a fixed moment has no such response: start
        # from the weightless one, ls/(E I) (the secant refresh corrects it on the first steps)
        s[i] = probe[i] / dm if st == OK else kp[K_LS] / kp[K_EI]
    work = np.empty(n)
    saved = np.empty(n)
    st, p = composite(state, vforce, kp, ks, work, saved, needs_stability_check(vforce, kp))
    return st
