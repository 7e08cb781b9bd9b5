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
implicit convection and exact discrete energy bookkeeping (§6.1).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit
from .layout import (
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
    K_L0,
    K_LREF,
    K_LS,
    K_NW,
    K_RHOC,
    K_TE,
    K_TMAX,
    METHOD_BISECT,
    METHOD_NEWTON,
    OK,
    S_C,
    S_HMAX,
    S_HMIN,
    S_MAXROOT,
    S_MAXSHAPE,
    S_MAXSUB,
    S_METHOD,
    S_TOLM,
    S_TOLTH,
    X_EL,
    X_ER,
    X_HEAD,
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
    X_SL,
    X_SR,
    X_TIME,
    X_TL,
    X_TR,
)
from .sma import compliance, latent_heats, phase_step, rates, resistivity, stress
from .stability import solve_in_place, unstable_modes
from .tube import chord_slope, load_ratio, shape_jacobian, shape_pass, solve_shape, wire_lengths

X_ACTIVE = 1e-6  # a phase with fraction above this takes part in the step-size rule (§6.1 b)
SECANT_MIN_DM = 1e-6  # [N m] smallest moment change used to refresh the sensitivity s
BUCKLING_SCREEN = 0.9  # Dunkerley load ratio above which converged shapes are tested for stability
NEWTON_HALVINGS = 30  # step halvings of the whole-shape Newton before it takes the last one
SLACK_TOL = 1e-9  # [-] a wire within this strain of its stress-free length is at the slack threshold


@jit
def wire_mechanics(dth, xpr, xmr, xpl, xml, kp):
    """Strains, stresses and the moment they produce, for a given shape (MODEL.md §3.6, §4.4, §4.8).

    Returns:
        (ε_R, ε_L, σ_R [Pa], σ_L [Pa], G = n_w A_w a (σ_R − σ_L) [N m]).
    """
    lr, ll = wire_lengths(dth, kp)
    lref = kp[K_LREF]
    er = lr / lref - 1.0
    el = ll / lref - 1.0
    sr = stress(er, xpr, xmr, kp)
    sl = stress(el, xpl, xml, kp)
    return er, el, sr, sl, kp[K_NW] * kp[K_AW] * kp[K_A] * (sr - sl)


@jit
def moment_gain(dth, s, sr, sl, xpr, xmr, xpl, xml, kp):
    """dG/dM = Σ_n ∂G/∂Δθ_n s_n ≤ 0: how the wire moment answers a change of the applied moment.

    ∂L_R/∂Δθ_n = c'_n − a cos(Δθ_n/2), ∂L_L/∂Δθ_n = c'_n + a cos(Δθ_n/2), with the small-angle
    forms c' ≈ −ls Δθ/12 and cos ≈ 1 − Δθ²/8 (a Newton step only needs the slope to ~1 %).
    A slack wire (σ = 0) has zero tangent stiffness.
    """
    a = kp[K_A]
    ls = kp[K_LS]
    er_stiff = 1.0 / compliance(xpr, xmr, kp) if sr > 0.0 else 0.0
    el_stiff = 1.0 / compliance(xpl, xml, kp) if sl > 0.0 else 0.0
    sum_c = 0.0
    sum_k = 0.0
    for i in range(dth.shape[0]):
        x = dth[i]
        sum_c += (-ls * x / 12.0) * s[i]
        sum_k += a * (1.0 - x * x / 8.0) * s[i]
    pref = kp[K_NW] * kp[K_AW] * a / kp[K_LREF]
    return pref * (er_stiff * (sum_c - sum_k) - el_stiff * (sum_c + sum_k))


@jit
def _tangent_moduli(er, el, xpr, xmr, xpl, xml, kp):
    """Tangent moduli dσ/dε [Pa] of the right and left wire for the stability check (§3.6).

    A taut wire (ε above its stress-free strain ε_T (x₊ − x₋)) has 1/compliance, a slack one 0.
    A wire exactly at its stress-free strain (within ``SLACK_TOL``, e.g. the initial straight
    spine of §3.10) resists bending only in the direction that stretches it. If the other wire is
    taut or slack, the weaker direction is the one in which it does not count; if both sit at the
    threshold, each direction is resisted by one of them and the weaker is the softer wire.
    """
    ex_r = er - kp[K_EPST] * (xpr - xmr)
    ex_l = el - kp[K_EPST] * (xpl - xml)
    kr = 1.0 / compliance(xpr, xmr, kp) if ex_r > SLACK_TOL else 0.0
    kl = 1.0 / compliance(xpl, xml, kp) if ex_l > SLACK_TOL else 0.0
    if abs(ex_r) <= SLACK_TOL and abs(ex_l) <= SLACK_TOL:
        kr_t = 1.0 / compliance(xpr, xmr, kp)
        kl_t = 1.0 / compliance(xpl, xml, kp)
        if kr_t <= kl_t:
            kr = kr_t
        else:
            kl = kl_t
    return kr, kl


@jit
def equilibrium_jacobian(dth, xpr, xmr, xpl, xml, vforce, kp, jac):
    """Jacobian of the coupled shape map Δθ ↦ f(Δθ, G(Δθ)) (MODEL.md §4.9 with §5), into ``jac``.

    The tube part (wire moment fixed) is :func:`tube.shape_jacobian`. The wire moment G = n_w A_w a
    (σ_R − σ_L) follows the shape through the wire lengths (§4.8): ∂ε_R/∂Δθ_n = (c'_n − a cos(Δθ_n/2))
    / L_ref, ∂ε_L/∂Δθ_n = (c'_n + a cos(Δθ_n/2)) / L_ref, and enters every segment angle with
    ∂f_i/∂M_w = ls/(E I). A rank-one term: the wires stiffen the modes that turn the top disk.
    """
    shape_jacobian(dth, vforce, kp, jac)
    lr, ll = wire_lengths(dth, kp)
    lref = kp[K_LREF]
    kr, kl = _tangent_moduli(lr / lref - 1.0, ll / lref - 1.0, xpr, xmr, xpl, xml, kp)
    if kr == 0.0 and kl == 0.0:
        return jac
    a = kp[K_A]
    ls = kp[K_LS]
    pref = kp[K_NW] * kp[K_AW] * a / lref * ls / kp[K_EI]
    n = dth.shape[0]
    for j in range(n):
        cs = chord_slope(dth[j], ls)
        lever = a * math.cos(0.5 * dth[j])
        col = pref * (kr * (cs - lever) - kl * (cs + lever))
        for i in range(n):
            jac[i, j] += col
    return jac


@jit
def is_buckled(dth, xpr, xmr, xpl, xml, vforce, kp):
    """True if the equilibrium ``dth`` under ``vforce`` is unstable (a load past buckling).

    See :mod:`.stability` for the criterion; O(N³), so callers screen with
    :func:`needs_stability_check` first.
    """
    n = dth.shape[0]
    jac = np.empty((n, n))
    equilibrium_jacobian(dth, xpr, xmr, xpl, xml, vforce, kp, jac)
    return unstable_modes(jac, np.empty((n, n))) > 0


@jit
def _residual_full(dth, m, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape):
    """g(M) = G(M) − M with a full (warm-started) shape solve at M; returns (status, passes, g)."""
    st, it = solve_shape(dth, m, vforce, kp, tol_th, max_shape)
    er, el, sr, sl, gm = wire_mechanics(dth, xpr, xmr, xpl, xml, kp)
    return st, it, gm - m


@jit
def composite_bracketed(dth, m_prev, xpr, xmr, xpl, xml, vforce, kp, ks, illinois):
    """Bracketed composite solve (MODEL.md §5.2): bisection (seed) or Illinois regula falsi.

    The bracket is [min, max](M_prev, G(M_prev)); for a non-increasing G the root lies inside.

    Returns:
        (status, M, passes): ``dth`` holds the converged shape for M.
    """
    tol_m = ks[S_TOLM]
    tol_th = ks[S_TOLTH]
    max_shape = int(ks[S_MAXSHAPE])
    max_root = int(ks[S_MAXROOT])
    passes = 0
    st, it, g0 = _residual_full(dth, m_prev, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape)
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
                st, it, gm = _residual_full(dth, m, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape)
                return st, m, passes + it
            m = 0.5 * (lo + hi)
            st, it, gm = _residual_full(dth, m, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape)
            passes += it
            if st != OK:
                return st, m, passes
            if gm > 0.0:
                lo = m
            else:
                hi = m
        return ERR_ROOT, 0.5 * (lo + hi), passes
    # Illinois: needs g at the second end of the bracket
    st, it, g_end = _residual_full(dth, m_other, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape)
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
        st, it, gm = _residual_full(dth, m, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape)
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


@jit
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
        er, el, sr, sl, gm = wire_mechanics(dth, xpr, xmr, xpl, xml, kp)
        slope = 1.0 - moment_gain(dth, s, sr, sl, xpr, xmr, xpl, xml, kp)  # = −g'(M) >= 1
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


@jit
def composite_full_newton(dth, xpr, xmr, xpl, xml, vforce, kp, ks, work):
    """Newton on the whole shape: solve R(Δθ) = Δθ − f(Δθ, G(Δθ)) = 0 with the exact tangent I − J.

    The fallback of the coupled Newton near buckling, where the fixed-point shape iteration
    contracts only by ≈ (load / critical load) per pass and runs out of iterations. J is
    :func:`equilibrium_jacobian`; each iteration costs O(N³).

    Returns:
        (status, M, iterations, ε_R, ε_L, σ_R, σ_L) with ``dth`` the converged shape.
    """
    tol_th = ks[S_TOLTH]
    n = dth.shape[0]
    jac = np.empty((n, n))
    lu = np.empty((n, n))
    trial = np.empty(n)
    f_trial = np.empty(n)
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


@jit
def _fallbacks(dth, m0, xpr, xmr, xpl, xml, vforce, kp, ks, work, saved):
    """After the coupled Newton failed: Newton on the whole shape (needed near buckling), then the
    bracketed Illinois solve as the last safeguard, each from the starting shape ``saved``.

    Returns:
        (status, M, passes, ε_R, ε_L, σ_R, σ_L).
    """
    n = dth.shape[0]
    for i in range(n):
        dth[i] = saved[i]
    st, m, passes, er, el, sr, sl = composite_full_newton(dth, xpr, xmr, xpl, xml, vforce, kp, ks, work)
    if st == OK:
        return st, m, passes, er, el, sr, sl
    for i in range(n):
        dth[i] = saved[i]
    st, m, p2 = composite_bracketed(dth, m0, xpr, xmr, xpl, xml, vforce, kp, ks, True)
    er, el, sr, sl, gm = wire_mechanics(dth, xpr, xmr, xpl, xml, kp)
    return st, m, passes + p2, er, el, sr, sl


@jit
def _buckling_status(state, st, vforce, kp, check, saved):
    """Status of a solve after the stability test (see :func:`composite`); restores Δθ on failure."""
    n = saved.shape[0]
    dth = state[X_HEAD : X_HEAD + n]
    xpr = state[X_PR]
    xmr = state[X_MR]
    xpl = state[X_PL]
    xml = state[X_ML]
    if st == OK and not is_buckled(dth, xpr, xmr, xpl, xml, vforce, kp):
        return OK
    for i in range(n):
        dth[i] = saved[i]
    if st == OK or (not check and is_buckled(dth, xpr, xmr, xpl, xml, vforce, kp)):
        return ERR_BUCKLING
    return st


@jit
def composite(state, vforce, kp, ks, work, saved, check):
    """Solve the composite module for the state's fractions and the loads ``vforce``, in place.

    Updates Δθ, M, ε_w, σ_w in ``state``; ``saved`` receives the starting shape. Default solver:
    the coupled Newton, then :func:`_fallbacks`. With ``check`` (loads that might buckle the
    spine, see :func:`needs_stability_check`) both the starting shape (the last equilibrium, under
    the new loads and fractions) and the converged one are tested for stability, and ERR_BUCKLING
    is returned, state untouched, if either is unstable: the load path has passed a stability
    limit, even if the solver would find a distant post-buckled equilibrium (a snap the
    quasi-static model cannot follow). A solve that fails is reported as ERR_BUCKLING if its
    starting shape is unstable, else with the solver's own status; Δθ is left at the starting
    shape.

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
    if check and is_buckled(dth, xpr, xmr, xpl, xml, vforce, kp):
        return ERR_BUCKLING, 0
    if method == METHOD_NEWTON:
        st, m, passes, er, el, sr, sl = composite_newton(dth, s, m0, xpr, xmr, xpl, xml, vforce, kp, ks, work)
        if st != OK:
            st, m, p2, er, el, sr, sl = _fallbacks(dth, m0, xpr, xmr, xpl, xml, vforce, kp, ks, work, saved)
            passes += p2
    else:
        st, m, passes = composite_bracketed(
            dth, m0, xpr, xmr, xpl, xml, vforce, kp, ks, method != METHOD_BISECT
        )
        er, el, sr, sl, gm = wire_mechanics(dth, xpr, xmr, xpl, xml, kp)
    if st != OK or check:
        st = _buckling_status(state, st, vforce, kp, check, saved)
        if st != OK:
            return st, passes
    state[X_MW] = m
    state[X_ER] = er
    state[X_EL] = el
    state[X_SR] = sr
    state[X_SL] = sl
    return OK, passes


@jit
def needs_stability_check(vforce, kp):
    """False when the loads cannot buckle the spine in any shape (Dunkerley screen, §4.9).

    The screen :func:`tube.load_ratio` is a lower bound for the bare tube (the wires only add
    stiffness); below ``BUCKLING_SCREEN`` the O(N³) stability test of :func:`composite` is skipped,
    so the unloaded and lightly loaded spine (the §10 runs, the env's default loads) pay nothing.
    """
    return load_ratio(vforce, kp) > BUCKLING_SCREEN


@jit
def _step_rate(xp, xm, ppA, pAp, pmA, pAm):
    """Fastest active transition of one wire (MODEL.md §6.1 b)."""
    r = 0.0
    if xp > X_ACTIVE and ppA > r:
        r = ppA
    if xm > X_ACTIVE and pmA > r:
        r = pmA
    if 1.0 - xp - xm > X_ACTIVE and pAp + pAm > r:
        r = pAp + pAm
    return r


@jit
def advance(state, kp, ks, v_r, v_l, vforce, dt, resolve=True):
    """Advance one spine by one output step ``dt`` with voltages and loads held (MODEL.md §6.1).

    Args:
        state: model state (see :mod:`layout`), updated in place.
        kp, ks: constants and solver options.
        v_r, v_l: voltage on each wire of the right / left side [V].
        vforce: (N, 2) external forces at the vertices P_0 … P_{N−1} [N], global x/y.
        dt: output step [s].
        resolve: solve the mechanics first (needed when the loads changed since the last call;
            callers that know the loads are unchanged pass False to save a solve).

    Under loads that might buckle the spine (:func:`needs_stability_check`) the re-solve is
    checked for stability and so is the shape the step ends on; a sub-step whose solve fails is
    classified by :func:`composite`. An unstable equilibrium ends the step with ERR_BUCKLING.

    Returns:
        (status, sub-steps, shape passes).
    """
    n = state.shape[0] - X_HEAD
    n = n // 2
    work = np.empty(n)
    saved = np.empty(n)
    dth = state[X_HEAD : X_HEAD + n]
    s = state[X_HEAD + n : X_HEAD + 2 * n]
    # 0. loads may have changed since the last call: re-solve the mechanics with the current x
    passes = 0
    check = needs_stability_check(vforce, kp)
    if resolve:
        st, passes = composite(state, vforce, kp, ks, work, saved, check)
        if st != OK:
            return st, 0, passes
    c_crit = ks[S_C]
    h_min = ks[S_HMIN]
    h_max = ks[S_HMAX]
    max_sub = int(ks[S_MAXSUB])
    newton = int(ks[S_METHOD]) == METHOD_NEWTON
    rhoc = kp[K_RHOC]
    asv = kp[K_ASV]
    t_e = kp[K_TE]
    l0sq = kp[K_L0] * kp[K_L0]
    jr_num = v_r * v_r / l0sq
    jl_num = v_l * v_l / l0sq
    rem = dt
    nsub = 0
    solved = False
    while rem > 0.0:
        xpr = state[X_PR]
        xmr = state[X_MR]
        xpl = state[X_PL]
        xml = state[X_ML]
        tr = state[X_TR]
        tl = state[X_TL]
        sr = state[X_SR]
        sl = state[X_SL]
        # a. rates once per sub-step, used for the step size and the update
        ppA_r, pAp_r, pmA_r, pAm_r = rates(sr, tr, kp)
        ppA_l, pAp_l, pmA_l, pAm_l = rates(sl, tl, kp)
        # b. step size
        r = max(
            _step_rate(xpr, xmr, ppA_r, pAp_r, pmA_r, pAm_r), _step_rate(xpl, xml, ppA_l, pAp_l, pmA_l, pAm_l)
        )
        h = rem
        if r * h > c_crit:
            h = min(max(c_crit / r, h_min), rem)
        if h > h_max:
            h = h_max
        if rem - h < 1e-9 * dt:  # do not leave a sliver
            h = rem
        # c. implicit phase update
        xpr2, xmr2 = phase_step(xpr, xmr, h, ppA_r, pAp_r, pmA_r, pAm_r)
        xpl2, xml2 = phase_step(xpl, xml, h, ppA_l, pAp_l, pmA_l, pAm_l)
        # d. Joule heating with the new resistivity, e. latent heat of the discrete Δx
        jr = jr_num / resistivity(xpr2, xmr2, kp)
        jl = jl_num / resistivity(xpl2, xml2, kp)
        lp_r, lm_r = latent_heats(sr, kp)
        lp_l, lm_l = latent_heats(sl, kp)
        qr = lp_r * (xpr2 - xpr) + lm_r * (xmr2 - xmr)
        ql = lp_l * (xpl2 - xpl) + lm_l * (xml2 - xml)
        # f. heat balance, convection implicit: ρc(T'−T) = h j − h αS_V (T'−T_E) + q
        tr2 = (tr + (h * jr + h * asv * t_e + qr) / rhoc) / (1.0 + h * asv / rhoc)
        tl2 = (tl + (h * jl + h * asv * t_e + ql) / rhoc) / (1.0 + h * asv / rhoc)
        state[X_QJR] += h * jr
        state[X_QJL] += h * jl
        state[X_QCR] += h * asv * (tr2 - t_e)
        state[X_QCL] += h * asv * (tl2 - t_e)
        state[X_QLR] += qr
        state[X_QLL] += ql
        state[X_TR] = tr2
        state[X_TL] = tl2
        if not (math.isfinite(tr2) and math.isfinite(tl2)):
            return ERR_NONFINITE, nsub, passes
        if tr2 > kp[K_TMAX] or tl2 > kp[K_TMAX] or tr2 <= 0.0 or tl2 <= 0.0:
            return ERR_TEMPERATURE, nsub, passes
        # g. composite solve only when a fraction moved (stresses depend on x and shape only)
        if xpr2 != xpr or xmr2 != xmr or xpl2 != xpl or xml2 != xml:
            state[X_PR] = xpr2
            state[X_MR] = xmr2
            state[X_PL] = xpl2
            state[X_ML] = xml2
            m_old = state[X_MW]
            # unchecked: a failure is still classified; the end of the step is checked below
            st, p = composite(state, vforce, kp, ks, work, saved, False)  # saved ← starting shape
            passes += p
            solved = True
            if st != OK:
                return st, nsub, passes
            if newton:  # refresh the secant sensitivity s = dΔθ/dM (same loads, converged shapes)
                dm = state[X_MW] - m_old
                if abs(dm) > SECANT_MIN_DM:
                    for i in range(n):
                        s[i] = (dth[i] - saved[i]) / dm
        rem -= h
        nsub += 1
        if nsub > max_sub:
            return ERR_SUBSTEPS, nsub, passes
    # h. stability of the shape the step ends on (once per output step: the O(N³) test on every
    # sub-step would triple the cost of a heavily loaded run)
    if check and solved and is_buckled(dth, state[X_PR], state[X_MR], state[X_PL], state[X_ML], vforce, kp):
        return ERR_BUCKLING, nsub, passes
    state[X_TIME] += dt
    return OK, nsub, passes


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
