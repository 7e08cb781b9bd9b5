"""Composite constitutive/bending solve of one planar spine (MODEL.md §5).

The composite module finds, for given phase fractions and loads, the wire moment M for which the
wire stresses computed from the strains implied by the spine shape Δθ(M) reproduce M. Its residual
g(M) = G(M) − M is strictly decreasing, so a bracketed root always exists. Three solvers:

* ``bisect`` — the seed's bisection on M (§5.2) with a full shape solve per evaluation;
* ``illinois`` — the same bracket, safeguarded regula falsi (Illinois), full shape solves;
* ``newton`` (default) — one shape pass per outer iteration, M updated by Newton with the loop gain
  dG/dM = Σ_n ∂G/∂Δθ_n · s_n, where s = dΔθ/dM is a secant sensitivity carried in the state, and
  the shape predicted by Δθ += s ΔM (MODEL.md §6.4). If it does not converge within the caps it
  falls back to Newton on the whole shape (near buckling), then to ``illinois`` from the untouched
  starting point, so the bracket is the safeguard.

:func:`composite` and :func:`composite_in` are the entry points; they also classify a failed or
unstable solve (ERR_BUCKLING, §4.9). The equations are :mod:`.mechanics`'.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import hot, jit
from ..columns import (
    ERR_BUCKLING,
    ERR_NONFINITE,
    ERR_ROOT,
    METHOD_BISECT,
    METHOD_NEWTON,
    OK,
    S_MAXROOT,
    S_MAXSHAPE,
    S_METHOD,
    S_TOLM,
    S_TOLTH,
)
from ..stability import solve_in_place
from .columns import X_EL, X_ER, X_HEAD, X_ML, X_MR, X_MW, X_PL, X_PR, X_SL, X_SR
from .mechanics import mechanics_and_gain, wire_mechanics
from .stability import equilibrium_jacobian, is_buckled_in
from .tube import shape_pass, solve_shape_in


NEWTON_HALVINGS = 30  # step halvings of the whole-shape Newton before it takes the last one


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
            m = 0.5 * (lo + hi)
            st, it, gm = _residual_full(dth, m, xpr, xmr, xpl, xml, vforce, kp, tol_th, max_shape, new)
            passes += it
            if st != OK or hi - lo <= tol_m:  # failed, or converged: the midpoint of the bracket
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
