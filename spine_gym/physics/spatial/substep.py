"""One sub-step of a spatial spine's time integration (MODEL.md §6.1, §6.5, SPATIAL.md §8.6), as
:mod:`spine_gym.physics.planar.substep` over arrays of wires.

:func:`_substep_coupled` (the default ``scheme``) is the linearly implicit Euler step of every
wire's fractions (the wires that transform in one coupled system, :func:`_active_wires`) with a
local error estimate (:func:`_coupled_error`); :func:`_substep_frozen` is §6.1 as written. Both
use implicit convection and exact energy bookkeeping (:func:`_apply_heat`, each wire with its own
constants) and re-solve the composite module when a fraction moved (:func:`_mechanics_update`).
The per-wire pieces of the coupled step are :mod:`spine_gym.physics.coupled`'s, shared with the
planar core; the wire model is :mod:`spine_gym.physics.sma`'s.
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
    OK,
    S_C,
    S_HMAX,
    S_HMIN,
    S_TOLX,
)
from ..coupled import (
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
from .columns import F_SIG, F_T, W_DU, hnext_offset, wire_offset
from .composite import _fallback_solves, _newton_attempt, _secant_update, _store_strains
from .mechanics import stress_sensitivity
from .work import (
    WK_ACT,
    WK_AT,
    WK_BACKUP,
    WK_BT,
    WK_CHORDS,
    WK_DM,
    WK_DMDX,
    WK_EPS,
    WK_FRAMES,
    WK_G,
    WK_GAIN,
    WK_INV,
    WK_JAC,
    WK_JNUM,
    WK_KPW,
    WK_LU,
    WK_NEW,
    WK_PIV,
    WK_RATES,
    WK_RT,
    WK_RT_NEW,
    WK_RTA,
    WK_SA,
    WK_SAVED_M,
    WK_SAVED_W,
    WK_SIG,
    WK_SUMS,
    WK_VEC,
    WK_X0,
    WK_XA,
    WK_XS,
    copy_pairs,
)


MECH_RETRY = 0.25  # a coupled sub-step whose composite solve failed is retried this much shorter


@hot
def _choose_h(rem, dt, r, ks):
    """Sub-step size of MODEL.md §6.1 b, exactly as planar.integrate.advance."""
    c_crit = ks[S_C]
    h = rem
    if r * h > c_crit:
        h = min(max(c_crit / r, ks[S_HMIN]), rem)
    if h > ks[S_HMAX]:
        h = ks[S_HMAX]
    if rem - h < 1e-9 * dt:  # do not leave a sliver
        h = rem
    return h


@hot
def _apply_heat(xp, xm, temp, sig, qj, qc, ql, kpw, jnum, h, xs):
    """Joule and latent heat, implicit convection of every wire for the new fractions ``xs`` (§6.1 d–f),
    each wire with its own constants ``kpw[j]`` (:func:`wire_constants`).

    Writes the new temperatures and energy accumulators (the state's per-wire blocks passed in).
    Returns (status, whether any fraction moved).
    """
    moved = False
    ok = True
    for j in range(xp.shape[0]):
        kp = kpw[j]
        rhoc = kp[K_RHOC]
        asv = kp[K_ASV]
        t_e = kp[K_TE]
        xp2 = xs[2 * j]
        xm2 = xs[2 * j + 1]
        jj = jnum[j] / resistivity(xp2, xm2, kp)
        lp, lm = latent_heats(sig[j], kp)
        q = lp * (xp2 - xp[j]) + lm * (xm2 - xm[j])
        t2 = (temp[j] + (h * jj + h * asv * t_e + q) / rhoc) / (1.0 + h * asv / rhoc)
        qj[j] += h * jj
        qc[j] += h * asv * (t2 - t_e)
        ql[j] += q
        temp[j] = t2
        if xp2 != xp[j] or xm2 != xm[j]:
            moved = True
        if not math.isfinite(t2):
            return ERR_NONFINITE, moved
        if t2 > kp[K_TMAX] or t2 <= 0.0:
            ok = False
    if not ok:
        return ERR_TEMPERATURE, moved
    return OK, moved


@hot
def _mechanics_update(
    mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, xs, saved_w, saved_m, frames, chords, new, sums,
    e_new, s_new, gm, jac, gs, dm, sums_known,
):  # fmt: skip
    """Store the new fractions ``xs`` = wk[WK_XS] and re-solve the composite module (§6.1 g) by the
    first try of :func:`solve_mechanics` (unchecked; the work arrays of :func:`_newton_attempt`),
    then the Broyden update of S from the two converged shapes (``saved_w``, ``saved_m``: the
    start). ``sums_known``: ``gs`` holds the loop-gain sums of this ω and S (:func:`stress_sensitivity`
    ran on them). If it fails, the caller runs :func:`_mechanics_fallback` (it needs the work tuple).

    Returns (status, shape passes).
    """
    for j in range(xp.shape[0]):
        xp[j] = xs[2 * j]
        xm[j] = xs[2 * j + 1]
    # ω is the last converged shape, so eps are its strains (a rejected sub-step restores both)
    st, p = _newton_attempt(
        mw, omega, sens, xp, xm, eps, vforce, kp, ks, kw, km, saved_w, saved_m, frames, chords, new, sums, e_new,
        s_new, gm, jac, gs, dm, True, sums_known,
    )  # fmt: skip
    if st == OK:
        _store_strains(eps, sig, e_new, s_new)
        _secant_update(sens, omega, saved_w, mw, saved_m)
    return st, p


@hot
def _mechanics_fallback(mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, wk, passes):
    """:func:`_mechanics_update` after its coupled Newton failed: the fallbacks of
    :func:`solve_mechanics` (unchecked, a failure is still classified), then as there.
    Returns (status, shape passes including ``passes`` so far)."""
    st, p = _fallback_solves(mw, omega, sens, xp, xm, vforce, kp, ks, kw, km, wk, False)
    if st == OK:
        _store_strains(eps, sig, wk[WK_EPS], wk[WK_SIG])
        _secant_update(sens, omega, wk[WK_SAVED_W], mw, wk[WK_SAVED_M])
    return st, passes + p


@hot
def _mechanics(mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, wk, sums_known):
    """:func:`_mechanics_update`, then :func:`_mechanics_fallback` if needed (the frozen sub-step's call)."""
    st, p = _mechanics_update(
        mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, wk[WK_XS], wk[WK_SAVED_W], wk[WK_SAVED_M],
        wk[WK_FRAMES], wk[WK_CHORDS], wk[WK_NEW], wk[WK_SUMS], wk[WK_EPS], wk[WK_SIG], wk[WK_G], wk[WK_JAC],
        wk[WK_GAIN], wk[WK_DM], sums_known,
    )  # fmt: skip
    if st != OK:
        st, p = _mechanics_fallback(mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, wk, p)
    return st, p


@hot
def _substep_frozen(state, mw, omega, sens, wb, vforce, kp, ks, kw, km, rem, dt, wk):
    """One sub-step of MODEL.md §6.1 as written (rates frozen at its start, r·h <= c), as
    :func:`planar.substep._substep_frozen` for every wire. Returns (status, h, shape passes, solved)."""
    xp, xm, temp, sig, eps, qj, qc, ql = wb
    rt = wk[WK_RATES]
    xs = wk[WK_XS]
    kpw = wk[WK_KPW]
    r = 0.0
    for j in range(xp.shape[0]):  # a. rates once per sub-step, b. step size
        ppA, pAp, pmA, pAm = rates(sig[j], temp[j], kpw[j])
        rt[j, 0] = ppA
        rt[j, 1] = pAp
        rt[j, 2] = pmA
        rt[j, 3] = pAm
        r = max(r, step_rate(xp[j], xm[j], ppA, pAp, pmA, pAm))
    h = _choose_h(rem, dt, r, ks)
    for j in range(xp.shape[0]):  # c. implicit Euler on the phases
        xs[2 * j], xs[2 * j + 1] = phase_step(xp[j], xm[j], h, rt[j, 0], rt[j, 1], rt[j, 2], rt[j, 3])
    st, moved = _apply_heat(xp, xm, temp, sig, qj, qc, ql, kpw, wk[WK_JNUM], h, xs)  # d.–f.
    if st != OK or not moved:
        return st, h, 0, False
    st, p = _mechanics(mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, wk, False)  # g.
    return st, h, p, True


@hot
def _active_wires(x0, rt, h, act):
    """Indices of the wires that transform over h into ``act`` (W + 1; the count in act[W]).

    A wire for which :func:`.coupled.quiet` holds on its own (every active transition · h <=
    QUIET_RH) moves its fractions by less than 1e-9 over the step: its coupling terms in the step's
    matrix are below round-off (as for the planar core's quiet step), and through dσ/dx it moves the
    other wires' stresses by Pa. It takes the frozen-rate step and leaves the linear system, so
    unpowered wires away from their transformation cost no sensitivity column and no matrix rows.
    """
    nw = rt.shape[0]
    na = 0
    for j in range(nw):
        if not quiet(x0[2 * j : 2 * j + 2], rt[j : j + 1], h):
            act[na] = j
            na += 1
    act[nw] = na
    return na


@hot
def _predict_coupled(
    omega, sens, xp, xm, temp, sig, kp, kw, km, h, x0, xs, rt, act, jnum, xa, rta, sa, a_t, b_t, lu, piv, vec,
    jac, gs, inv, dm, dmdx, kpw,
):  # fmt: skip
    """Linearly implicit Euler step of every wire's fractions over h into ``xs`` = wk[WK_XS]
    (MODEL.md §6.5; cf. :func:`planar.substep._predict_coupled`): the wires of :func:`_active_wires`
    through the coupled system, whose LU factors stay in ``lu``, ``piv`` = wk[WK_LU], wk[WK_PIV] for
    the error estimate, the quiet ones by the frozen-rate step. The other arrays are the work
    arrays of the same names in :func:`make_work` (wk[WK_X0], wk[WK_RT], wk[WK_ACT], wk[WK_JNUM],
    wk[WK_XA], wk[WK_RTA], wk[WK_SA], wk[WK_AT], wk[WK_BT], wk[WK_VEC], and those of
    :func:`stress_sensitivity`). Returns False if the system is singular."""
    nw = kw.shape[0]
    for j in range(nw):
        x0[2 * j] = xp[j]
        x0[2 * j + 1] = xm[j]
        xs[2 * j], xs[2 * j + 1] = phase_step(xp[j], xm[j], h, rt[j, 0], rt[j, 1], rt[j, 2], rt[j, 3])
    na = _active_wires(x0, rt, h, act)
    if na == 0:
        return True
    if not stress_sensitivity(omega, sens, xp, xm, sig, kp, kw, km, act, na, jac, gs, inv, lu, piv, dm, dmdx, sa):
        return False
    for a in range(na):  # the active wires' rows (their dσ/dx block is already in sa)
        j = act[a]
        xa[2 * a] = xp[j]
        xa[2 * a + 1] = xm[j]
        for q in range(12):
            rta[a, q] = rt[j, q]
        a_t[a], b_t[a, 0], b_t[a, 1] = heat_terms(temp[j], sig[j], xp[j], xm[j], jnum[j], h, kpw[j])
    m = 2 * na
    lu = lu[:m, :m]
    vec = vec[:m]
    linear_system(xa[:m], rta[:na], sa[:na, :m], h, a_t[:na], b_t[:na], lu, vec)
    if not lu_factor(lu, piv):
        return False
    lu_solve(lu, piv, vec)
    for a in range(na):
        j = act[a]
        xs[2 * j], xs[2 * j + 1] = clip_fractions(xp[j] + vec[2 * a], xm[j] + vec[2 * a + 1])
    return True


@hot
def wire_error(h, x0p, x0m, x1p, x1m, r0, r1, t0, t1, sig0, sig1, j_num, kp):
    """One wire's share of the coupled step's error estimate (cf. :func:`planar.substep._coupled_error`).

    Returns (the larger of ½ h |F₁ − F₀| of each fraction and ½ h |Ṫ₁ − Ṫ₀| / T_PER_FRACTION, and the
    residual h F₁ − Δx of x₊ and x₋ of the exact implicit Euler equations), F = kinetics §3.5.
    """
    f0p, f0m = kinetics(x0p, x0m, r0)
    f1p, f1m = kinetics(x1p, x1m, r1)
    trunc = max(0.5 * h * abs(f1p - f0p), 0.5 * h * abs(f1m - f0m))
    d0 = heating_rate(t0, x0p, x0m, f0p, f0m, sig0, j_num, kp)
    d1 = heating_rate(t1, x1p, x1m, f1p, f1m, sig1, j_num, kp)
    trunc = max(trunc, 0.5 * h * abs(d1 - d0) / T_PER_FRACTION)
    return trunc, h * f1p - (x1p - x0p), h * f1m - (x1m - x0m)


@hot
def _coupled_error(temp, sig, kpw, kw, h, x0, xs, rt, rt1, back, jnum, vec, act, ra, lu, piv):
    """Local error estimate of the coupled step in units of the fractions (MODEL.md §6.5): the
    larger of the truncation errors and (I − hJ)⁻¹ (h F₁ − Δx), the matrix (LU factors ``lu``,
    ``piv``) that of the active wires ``act`` (the identity for the quiet ones); ``x0``, ``rt``,
    ``back`` (the state's head) hold the start, ``xs``, ``rt1`` and ``temp``, ``sig`` the end of
    the step (wk[WK_X0], wk[WK_RT], wk[WK_BACKUP], wk[WK_XS], wk[WK_RT_NEW]); ``vec``, ``ra``: work."""
    nw = kw.shape[0]
    o_t = wire_offset(F_T, nw)
    o_s = wire_offset(F_SIG, nw)
    na = act[nw]
    e = 0.0
    for j in range(nw):
        i = 2 * j
        tw, vec[i], vec[i + 1] = wire_error(
            h, x0[i], x0[i + 1], xs[i], xs[i + 1], rt[j], rt1[j], back[o_t + j], temp[j],
            back[o_s + j], sig[j], jnum[j], kpw[j],
        )  # fmt: skip
        e = max(e, tw)
    if na == 0:  # the filter is the identity
        for i in range(2 * nw):
            e = max(e, abs(vec[i]))
        return e
    # ra: the active wires' residuals through the step's own matrix
    for a in range(na):
        j = act[a]
        ra[2 * a] = vec[2 * j]
        ra[2 * a + 1] = vec[2 * j + 1]
        vec[2 * j] = 0.0
        vec[2 * j + 1] = 0.0
    m = 2 * na
    lu_solve(lu[:m, :m], piv, ra[:m])
    for i in range(m):
        e = max(e, abs(ra[i]))
    for i in range(2 * nw):  # the quiet wires' (identity rows)
        e = max(e, abs(vec[i]))
    return e


@hot
def _end_rates(sig, temp, kpw, kw, back, rt, rt1):
    """Rates and slopes at the end of a sub-step into ``rt1`` (``rt``: at its start, ``back``: the
    state's head at its start). They are a function of (σ, T) only: a wire whose (σ, T) did not
    change over the step (an unpowered slack wire) keeps its start-of-step row, and one at exactly another wire's (σ, T) (the mirror-image neutral wires of a
    bend in one plane) and Δu offset copies that wire's row; the others are computed with the
    wire's own constants ``kpw[j]``."""
    nw = sig.shape[0]
    o_t = wire_offset(F_T, nw)
    o_s = wire_offset(F_SIG, nw)
    for j in range(nw):
        if sig[j] == back[o_s + j] and temp[j] == back[o_t + j]:
            for q in range(12):
                rt1[j, q] = rt[j, q]
            continue
        twin = -1
        for i in range(j):
            if sig[i] == sig[j] and temp[i] == temp[j] and kw[i, W_DU] == kw[j, W_DU]:
                twin = i
                break
        if twin >= 0:
            for q in range(12):
                rt1[j, q] = rt1[twin, q]
        else:
            rates_and_slopes(sig[j], temp[j], kpw[j], rt1[j])


@hot
def _substep_coupled(state, mw, omega, sens, wb, vforce, kp, ks, kw, km, rem, dt, wk):
    """One accepted sub-step of the coupled scheme (default), as :func:`planar.substep._substep_coupled`
    for every wire: the linearly implicit Euler step with the rates at the end-of-step stress
    (through the composite equilibrium's dσ/dx) and temperature, a local error estimate against
    tol_x, rejection and retry shorter, the next step proposed as h · 0.9 (tol/err)^½ (kept in
    the state). Returns (status, h taken, shape passes, whether the mechanics were solved)."""
    xp, xm, temp, sig, eps, qj, qc, ql = wb
    nw, nm, ns = kw.shape[0], km.shape[0], omega.shape[0]
    io = hnext_offset(nw, nm, ns)
    back = wk[WK_BACKUP]
    saved_w = wk[WK_SAVED_W]
    tol = ks[S_TOLX]
    h_min = ks[S_HMIN]
    h = first_try(state[io], rem, ks[S_HMAX])
    nb = back.shape[0]
    for i in range(nb):
        back[i] = state[i]
    passes = 0
    while True:
        hh = last_h(rem, dt, h)
        if not _predict_coupled(
            omega, sens, xp, xm, temp, sig, kp, kw, km, hh, wk[WK_X0], wk[WK_XS], wk[WK_RT], wk[WK_ACT],
            wk[WK_JNUM], wk[WK_XA], wk[WK_RTA], wk[WK_SA], wk[WK_AT], wk[WK_BT], wk[WK_LU], wk[WK_PIV], wk[WK_VEC],
            wk[WK_JAC], wk[WK_GAIN], wk[WK_INV], wk[WK_DM], wk[WK_DMDX], wk[WK_KPW],
        ):  # fmt: skip
            return ERR_NONFINITE, hh, passes, False
        st, moved = _apply_heat(xp, xm, temp, sig, qj, qc, ql, wk[WK_KPW], wk[WK_JNUM], hh, wk[WK_XS])
        solved = False
        if st == OK and moved:
            sums = wk[WK_ACT][nw] > 0  # _predict_coupled's dσ/dx left the loop-gain sums of ω and S
            st, p = _mechanics_update(
                mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, wk[WK_XS], saved_w, wk[WK_SAVED_M],
                wk[WK_FRAMES], wk[WK_CHORDS], wk[WK_NEW], wk[WK_SUMS], wk[WK_EPS], wk[WK_SIG], wk[WK_G],
                wk[WK_JAC], wk[WK_GAIN], wk[WK_DM], sums,
            )  # fmt: skip
            if st != OK:
                st, p = _mechanics_fallback(mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, wk, p)
            passes += p
            solved = True
            if st != OK and hh > h_min:
                # the composite solve failed from the start (ω, M_w and S restored): a shorter step
                # moves the fractions less, back to the start of the sub-step and retry
                for i in range(nb):
                    state[i] = back[i]
                h = max(MECH_RETRY * hh, h_min)
                continue
        if st != OK:
            return st, hh, passes, solved
        _end_rates(sig, temp, wk[WK_KPW], kw, back, wk[WK_RT], wk[WK_RT_NEW])
        err = _coupled_error(
            temp, sig, wk[WK_KPW], kw, hh, wk[WK_X0], wk[WK_XS], wk[WK_RT], wk[WK_RT_NEW], back, wk[WK_JNUM], wk[WK_VEC],
            wk[WK_ACT], wk[WK_XA], wk[WK_LU], wk[WK_PIV],
        )  # fmt: skip
        err /= tol
        accepted, h = accept_or_retry(err, hh, h, h_min)
        if accepted:
            copy_rows(wk[WK_RT], wk[WK_RT_NEW])
            state[io] = h
            return OK, hh, passes, solved
        for i in range(nb):  # rejected: back to the start of the sub-step
            state[i] = back[i]
        if solved:
            copy_pairs(omega, saved_w)
