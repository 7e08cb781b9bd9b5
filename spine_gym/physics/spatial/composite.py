"""Composite solve of the wire- and module-generic spine (SPATIAL.md §5).

The unknowns of the composite module are the K module wire moments M_w,k (2K scalars, material
components). G(M) is the wire moment that the constitutive law (MODEL.md §3.6) gives at the strains
of the shape that M produces (SPATIAL.md §3–§4); the solve finds M = G(M).

* Coupled Newton (default, the generalisation of :func:`planar.composite.composite_newton`): one shape
  pass per iteration; M updated by the Newton step ΔM = (I − J)⁻¹ (G − M) with the loop gain
  J = ∂G/∂ω · S from the wires' tangent moduli and the shape sensitivity S = dω/dM, a secant
  (Broyden) matrix carried in the state; the shape predicted by ω += S ΔM.
* Whole-shape Newton (:func:`composite_full_newton`), if the coupled Newton does not converge
  (near buckling): Newton on ω with the stability Jacobian of :mod:`.stability`.
* Safeguard, if that does not converge either: from the untouched starting point,
  S is refreshed by finite differences of full shape solves and a back-tracking Newton with a
  full shape solve per evaluation drives max|G − M| below the tolerance (the step is halved
  until the residual falls). Failure returns a status, never NaN.

For the planar layouts (wires at 0° and 180°, optionally unpowered ones at 90°/270°) every d1
quantity is exactly zero, the Newton step reduces to the planar scalar step and the secant update
to the planar one, so the two cores agree to the solver tolerance (SPATIAL.md §7.1, tested).
:func:`composite` and :func:`solve_mechanics` are the entry points; they also classify a failed
or unstable solve (ERR_BUCKLING).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import hot, jit
from ..columns import ERR_BUCKLING, ERR_NONFINITE, ERR_ROOT, OK, S_MAXROOT, S_MAXSHAPE, S_TOLM, S_TOLTH
from ..coupled import SECANT_MIN_DM
from ..stability import solve_in_place
from .columns import F_EPS, F_SIG, F_XM, F_XP
from .mechanics import loop_gain, shape_mechanics, strain_mechanics, wire_mechanics
from .stability import add_wire_term, is_buckled_at, is_buckled_in, tube_jacobian
from .tube import shape_pass, solve_shape
from .work import (
    WK_CHORDS,
    WK_DM,
    WK_EPS,
    WK_FRAMES,
    WK_G,
    WK_GAIN,
    WK_JAC,
    WK_MTRIAL,
    WK_NEW,
    WK_SAVED_M,
    WK_SAVED_S,
    WK_SAVED_W,
    WK_SIG,
    WK_STAB,
    WK_STEP,
    WK_SUMS,
    WK_WTRIAL,
    copy_pairs,
    sizes,
    views,
    wire_block,
)


FD_DM = 1e-4  # [N m] moment step of the finite-difference sensitivity of the safeguard


MAX_HALVINGS = 30  # back-tracking halvings of one safeguarded Newton step


SAFE_TOL = 0.01  # shape tolerance of the safeguard relative to tol_theta


@hot
def newton_step(mw, omega, sens, xp, xm, kp, kw, km, wk, sums_known=False):
    """ΔM = (I − J)⁻¹ (G(M) − M) into wk[WK_DM] at the shape ``omega``, given its
    :func:`wire_mechanics` in ``wk`` (:func:`newton_update` on the work tuple).

    Returns:
        max |ΔM| [N m] (inf if I − J is singular or the step is not finite).
    """
    return newton_update(
        mw, omega, sens, xp, xm, kp, kw, km, wk[WK_SIG], wk[WK_G], wk[WK_JAC], wk[WK_GAIN], wk[WK_DM], sums_known
    )


@hot
def newton_update(mw, omega, sens, xp, xm, kp, kw, km, sig, gm, a, gs, dm, sums_known):
    """:func:`newton_step` on the arrays: stresses ``sig`` and G ``gm`` of the shape, the Jacobian
    ``a`` and gain sums ``gs`` (:func:`loop_gain`, ``sums_known`` there), ΔM into ``dm``."""
    loop_gain(omega, sens, xp, xm, sig, kp, kw, km, a, gs, sums_known)
    nm = mw.shape[0]
    for k in range(nm):
        dm[2 * k] = gm[k, 0] - mw[k, 0]
        dm[2 * k + 1] = gm[k, 1] - mw[k, 1]
    for r in range(2 * nm):
        for c in range(2 * nm):
            a[r, c] = -a[r, c]
        a[r, r] += 1.0
    if not solve_in_place(a, dm):
        return np.inf
    big = 0.0
    for r in range(2 * nm):
        if not math.isfinite(dm[r]):
            return np.inf
        big = max(big, abs(dm[r]))
    return big


@hot
def _residual_norm(mw, gm):
    """max |G(M) − M| for G = ``gm`` of :func:`wire_mechanics` (inf if any component is not finite)."""
    r = 0.0
    for k in range(mw.shape[0]):
        for b in range(2):
            d = abs(gm[k, b] - mw[k, b])
            if not math.isfinite(d):
                return np.inf
            r = max(r, d)
    return r


@hot
def _predict(omega, sens, dm, scale, out):
    """out = ω + scale · S ΔM (the shape predicted for the moment change)."""
    for i in range(omega.shape[0]):
        for b in range(2):
            v = 0.0
            for c in range(dm.shape[0]):
                v += sens[2 * i + b, c] * dm[c]
            out[i, b] = omega[i, b] + scale * v


@jit
def composite_newton(mw, omega, sens, xp, xm, vforce, kp, ks, kw, km, wk, known=False, sums_known=False):
    """Coupled Newton composite solve in place on (mw, omega); cf. :func:`planar.composite.composite_newton`.

    Converged when the last shape pass moved ω by less than tol_theta and either the residual
    max|G − M| or the Newton step ΔM is below tol_moment. The residual is tested first, as it needs
    no Jacobian; in the planar case |ΔM| = |G − M| / (1 − J) <= |G − M| (J <= 0), so whenever the
    residual test passes the planar step test passes too, and the decisions are the planar ones.

    With ``known``, wk[WK_EPS] already holds the strains of the starting shape (the last converged
    one: only the fractions changed), so the first iteration takes its stresses from them; with
    ``sums_known`` also wk[WK_GAIN] its loop-gain sums (:func:`loop_gain`).

    Returns:
        (status, shape passes); on OK, wk[WK_EPS], wk[WK_SIG] hold the strains and stresses of the shape.
    """
    return _newton_solve(
        mw, omega, sens, xp, xm, vforce, kp, ks, kw, km, wk[WK_FRAMES], wk[WK_CHORDS], wk[WK_NEW], wk[WK_SUMS],
        wk[WK_EPS], wk[WK_SIG], wk[WK_G], wk[WK_JAC], wk[WK_GAIN], wk[WK_DM], known, sums_known,
    )  # fmt: skip


@hot
def _newton_solve(
    mw, omega, sens, xp, xm, vforce, kp, ks, kw, km, frames, chords, new, sums, eps, sig, gm, jac, gs, dm, known,
    sums_known,
):  # fmt: skip
    """:func:`composite_newton` on its work arrays (frames, chords, new ω, chord sums, ε, σ, G, J, gain sums, ΔM)."""
    tol_m = ks[S_TOLM]
    tol_th = ks[S_TOLTH]
    nm = mw.shape[0]
    ns = omega.shape[0]
    e = np.inf
    passes = 0
    for it in range(int(ks[S_MAXROOT])):
        if known and it == 0:
            strain_mechanics(xp, xm, kp, kw, eps, sig, gm)
        else:
            shape_mechanics(omega, xp, xm, kp, kw, km, sums, eps, sig, gm)
        if e < tol_th and _residual_norm(mw, gm) < tol_m:
            return OK, passes
        big = newton_update(mw, omega, sens, xp, xm, kp, kw, km, sig, gm, jac, gs, dm, sums_known and it == 0)
        if e < tol_th and big < tol_m:
            return OK, passes
        if not math.isfinite(big):
            return ERR_NONFINITE, passes
        for k in range(nm):
            mw[k, 0] += dm[2 * k]
            mw[k, 1] += dm[2 * k + 1]
        _predict(omega, sens, dm, 1.0, omega)
        e = shape_pass(omega, mw, vforce, kp, km, frames, chords, new)
        passes += 1
        for i in range(ns):
            omega[i, 0] = new[i, 0]
            omega[i, 1] = new[i, 1]
    return ERR_ROOT, passes


@hot
def refresh_sensitivity(mw, omega, sens, vforce, kp, ks, km, wk, tol):
    """S = dω/dM by forward differences of full shape solves (tolerance ``tol``) at the shape for ``mw``.

    ``omega`` is first solved for ``mw``. Returns (status, shape passes).
    """
    max_shape = int(ks[S_MAXSHAPE])
    frames, chords, new = wk[WK_FRAMES], wk[WK_CHORDS], wk[WK_NEW]
    trial = wk[WK_WTRIAL]
    mt = wk[WK_MTRIAL]
    nm = mw.shape[0]
    st, passes = solve_shape(omega, mw, vforce, kp, km, tol, max_shape, frames, chords, new)
    if st != OK:
        return st, passes
    for c in range(2 * nm):
        copy_pairs(mt, mw)
        mt[c // 2, c % 2] += FD_DM
        copy_pairs(trial, omega)
        st, it = solve_shape(trial, mt, vforce, kp, km, tol, max_shape, frames, chords, new)
        passes += it
        if st != OK:
            return st, passes
        for i in range(omega.shape[0]):
            sens[2 * i, c] = (trial[i, 0] - omega[i, 0]) / FD_DM
            sens[2 * i + 1, c] = (trial[i, 1] - omega[i, 1]) / FD_DM
    return OK, passes


@hot
def _line_search(mw, omega, sens, norm, xp, xm, vforce, kp, ks, kw, km, wk, tol):
    """Try M + λ ΔM (ΔM in wk[WK_DM]), λ = 1, ½, ¼ …, each with a full shape solve from the shape
    predicted by S; accept the first that lowers max|G − M| (then written into mw, omega).

    Returns:
        (accepted, shape passes).
    """
    max_shape = int(ks[S_MAXSHAPE])
    frames, chords, new = wk[WK_FRAMES], wk[WK_CHORDS], wk[WK_NEW]
    trial, mt, dm = wk[WK_WTRIAL], wk[WK_MTRIAL], wk[WK_DM]
    passes = 0
    lam = 1.0
    for _ in range(MAX_HALVINGS):
        for k in range(mw.shape[0]):
            mt[k, 0] = mw[k, 0] + lam * dm[2 * k]
            mt[k, 1] = mw[k, 1] + lam * dm[2 * k + 1]
        _predict(omega, sens, dm, lam, trial)
        st, it = solve_shape(trial, mt, vforce, kp, km, tol, max_shape, frames, chords, new)
        passes += it
        if st == OK:
            wire_mechanics(trial, xp, xm, kp, kw, km, wk)
            if _residual_norm(mt, wk[WK_G]) < (1.0 - 1e-4 * lam) * norm:
                copy_pairs(mw, mt)
                copy_pairs(omega, trial)
                return True, passes
        lam *= 0.5
    return False, passes


@hot
def composite_safeguard(mw, omega, sens, xp, xm, vforce, kp, ks, kw, km, wk):
    """The safeguard of §5: Newton with full shape solves, a finite-difference S refreshed at every
    iterate, and back-tracking; if no Newton step lowers the residual, the fixed-point direction
    ΔM = G(M) − M (a descent direction: −g' = I − J is positive definite as the wires stiffen the
    structure) with back-tracking. The shape solves use SAFE_TOL × tol_theta, so that the residual
    is resolved well below tol_moment.

    Returns:
        (status, shape passes); on OK, wk[WK_EPS], wk[WK_SIG] hold the strains and stresses of the shape.
    """
    tol_m = ks[S_TOLM]
    tol = SAFE_TOL * ks[S_TOLTH]
    dm, gm = wk[WK_DM], wk[WK_G]
    passes = 0
    for _ in range(int(ks[S_MAXROOT])):
        st, p = refresh_sensitivity(mw, omega, sens, vforce, kp, ks, km, wk, tol)
        passes += p
        if st != OK:
            return st, passes
        wire_mechanics(omega, xp, xm, kp, kw, km, wk)
        norm = _residual_norm(mw, wk[WK_G])
        if norm <= tol_m:
            return OK, passes
        if not math.isfinite(newton_step(mw, omega, sens, xp, xm, kp, kw, km, wk)):
            return ERR_NONFINITE, passes
        ok, p = _line_search(mw, omega, sens, norm, xp, xm, vforce, kp, ks, kw, km, wk, tol)
        passes += p
        if not ok:
            wire_mechanics(omega, xp, xm, kp, kw, km, wk)
            for k in range(mw.shape[0]):
                dm[2 * k] = gm[k, 0] - mw[k, 0]
                dm[2 * k + 1] = gm[k, 1] - mw[k, 1]
            ok, p = _line_search(mw, omega, sens, norm, xp, xm, vforce, kp, ks, kw, km, wk, tol)
            passes += p
            if not ok:
                return ERR_ROOT, passes
    return ERR_ROOT, passes


@hot
def composite_full_newton(mw, omega, xp, xm, vforce, kp, ks, kw, km, wk):
    """Newton on the whole shape, R(ω) = ω − f(ω, G(ω)) = 0 with the tangent I − J (cf.
    :func:`planar.composite.composite_full_newton`): the fallback near buckling, where the coupled Newton's
    fixed-point passes contract only by ≈ load / critical load. J is the stability Jacobian of
    :mod:`.stability`; O(N³) per iteration. M_w = G(ω) at every iterate.

    Returns:
        (status, iterations); on OK, wk[WK_EPS], wk[WK_SIG] hold the strains and stresses of the shape.
    """
    ns = omega.shape[0]
    frames, chords, new = wk[WK_FRAMES], wk[WK_CHORDS], wk[WK_NEW]
    trial = wk[WK_WTRIAL]
    gm = wk[WK_G]
    step = wk[WK_STEP]
    for it in range(int(ks[S_MAXROOT])):
        e = _full_residual(mw, omega, xp, xm, vforce, kp, kw, km, wk)
        if not math.isfinite(e):
            return ERR_NONFINITE, it
        if e < ks[S_TOLTH]:
            return OK, it + 1
        if not _full_step(mw, omega, xp, xm, vforce, kp, kw, km, wk):
            return ERR_ROOT, it + 1
        lam = 1.0  # back-tracking: a full step can jump across a wire's slack kink and cycle
        for _ in range(MAX_HALVINGS):
            for i in range(ns):
                trial[i, 0] = omega[i, 0] + lam * step[2 * i]
                trial[i, 1] = omega[i, 1] + lam * step[2 * i + 1]
            wire_mechanics(trial, xp, xm, kp, kw, km, wk)
            if shape_pass(trial, gm, vforce, kp, km, frames, chords, new) < e:
                break
            lam *= 0.5
        copy_pairs(omega, trial)
    return ERR_ROOT, int(ks[S_MAXROOT])


@hot
def _full_residual(mw, omega, xp, xm, vforce, kp, kw, km, wk):
    """The whole-shape Newton's residual at ``omega``: wk[WK_EPS], wk[WK_SIG], wk[WK_G] of the shape,
    ``mw`` = G, the shape pass into wk[WK_NEW]; returns max|f(ω, G(ω)) − ω|."""
    wire_mechanics(omega, xp, xm, kp, kw, km, wk)
    copy_pairs(mw, wk[WK_G])
    return shape_pass(omega, mw, vforce, kp, km, wk[WK_FRAMES], wk[WK_CHORDS], wk[WK_NEW])


@hot
def _full_step(mw, omega, xp, xm, vforce, kp, kw, km, wk):
    """The whole-shape Newton step (I − J) Δω = f − ω into wk[WK_STEP], after :func:`_full_residual`
    at the same ``omega`` (its shape pass is the right-hand side). False if I − J is singular."""
    n2 = 2 * omega.shape[0]
    new = wk[WK_NEW]
    step = wk[WK_STEP]
    stab = wk[WK_STAB]
    jac = stab[0][0]
    tube_jacobian(omega, mw, vforce, kp, km, jac, stab[1], stab[2], stab[3])
    add_wire_term(omega, xp, xm, kp, kw, km, jac, stab[4], stab[5], stab[6], stab[7])
    for r in range(n2):
        for c in range(n2):
            jac[r, c] = (1.0 if r == c else 0.0) - jac[r, c]
        step[r] = new[r // 2, r % 2] - omega[r // 2, r % 2]  # −R
    return solve_in_place(jac, step)


@hot
def slack_fold(omega, xp, xm, vforce, kp, kw, km, wk):
    """True if a solve from the equilibrium ``omega`` (of the fractions or loads before the change)
    ends at a wire's slack kink past which the spine is unstable: a limit point, no equilibrium
    beyond it nearby (SPATIAL.md §8.11). The first whole-shape Newton step (the linearised
    equilibrium under the new fractions ``xp``, ``xm`` and loads) slackens wires that are taut at
    the start, and with those wires at their threshold the start fails the stability test
    (:func:`.stability.is_buckled_at`). ``omega`` and the state are left as they are
    (scratch: wk[WK_MTRIAL], wk[WK_WTRIAL] and the whole-shape Newton's arrays)."""
    mt = wk[WK_MTRIAL]
    trial = wk[WK_WTRIAL]
    step = wk[WK_STEP]
    sig = wk[WK_SIG]
    at = wk[WK_STAB][8]
    e = _full_residual(mt, omega, xp, xm, vforce, kp, kw, km, wk)
    for j in range(sig.shape[0]):
        at[j] = sig[j] > 0.0
    if not math.isfinite(e) or not _full_step(mt, omega, xp, xm, vforce, kp, kw, km, wk):
        return False
    for i in range(omega.shape[0]):
        trial[i, 0] = omega[i, 0] + step[2 * i]
        trial[i, 1] = omega[i, 1] + step[2 * i + 1]
    wire_mechanics(trial, xp, xm, kp, kw, km, wk)
    slackened = False
    for j in range(sig.shape[0]):
        at[j] = at[j] and sig[j] <= 0.0
        slackened = slackened or at[j]
    wire_mechanics(omega, xp, xm, kp, kw, km, wk)  # mt = G of the start for the test (any M_w would do)
    copy_pairs(mt, wk[WK_G])
    return slackened and is_buckled_at(omega, mt, xp, xm, vforce, kp, kw, km, wk[WK_STAB], at)


@hot
def solve_mechanics(
    mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, wk, check=False, known=False, sums_known=False
):
    """Composite solve on the state's views (M_w, ω, S, x+, x-, and ε, σ written on success).

    Newton first, then Newton on the whole shape (needed near buckling), then the safeguard, each
    from the untouched starting point (cf. planar.composite.composite).
    With ``check`` (loads that might buckle the spine, :func:`.stability.needs_stability_check`)
    the starting shape and the converged one are tested for stability and ERR_BUCKLING returned,
    state untouched, if either is unstable (as :func:`planar.composite.composite`). A failed solve is
    reported as ERR_BUCKLING if its starting shape is unstable, else with its own status.
    ``known``: ``eps`` are the strains of the starting shape ω, ``sums_known``: wk[WK_GAIN] its
    loop-gain sums (see :func:`composite_newton`).
    Returns (status, shape passes used).
    """
    if check and is_buckled_in(omega, mw, xp, xm, vforce, kp, kw, km, wk[WK_STAB]):
        return ERR_BUCKLING, 0
    st, passes = _newton_attempt(
        mw, omega, sens, xp, xm, eps, vforce, kp, ks, kw, km, wk[WK_SAVED_W], wk[WK_SAVED_M], wk[WK_FRAMES],
        wk[WK_CHORDS], wk[WK_NEW], wk[WK_SUMS], wk[WK_EPS], wk[WK_SIG], wk[WK_G], wk[WK_JAC], wk[WK_GAIN],
        wk[WK_DM], known, sums_known,
    )  # fmt: skip
    if st != OK:
        st, p2 = _fallback_solves(mw, omega, sens, xp, xm, vforce, kp, ks, kw, km, wk, check)
        passes += p2
        if st != OK:
            return st, passes
    if check and is_buckled_in(omega, mw, xp, xm, vforce, kp, kw, km, wk[WK_STAB]):
        copy_pairs(omega, wk[WK_SAVED_W])
        copy_pairs(mw, wk[WK_SAVED_M])
        return ERR_BUCKLING, passes
    _store_strains(eps, sig, wk[WK_EPS], wk[WK_SIG])
    return OK, passes


@hot
def _newton_attempt(
    mw, omega, sens, xp, xm, eps, vforce, kp, ks, kw, km, saved_w, saved_m, frames, chords, new, sums, e_new,
    s_new, gm, jac, gs, dm, known, sums_known,
):  # fmt: skip
    """The first try of :func:`solve_mechanics` on its work arrays: keep the starting shape and
    moments (``saved_w``, ``saved_m``), then the coupled Newton (:func:`_newton_solve`; ``known``:
    the strains ``eps`` of the start are copied to ``e_new`` for it). Returns (status, passes)."""
    copy_pairs(saved_w, omega)
    copy_pairs(saved_m, mw)
    if known:
        for j in range(eps.shape[0]):
            e_new[j] = eps[j]
    return _newton_solve(
        mw, omega, sens, xp, xm, vforce, kp, ks, kw, km, frames, chords, new, sums, e_new, s_new, gm, jac, gs, dm,
        known, sums_known,
    )  # fmt: skip


@hot
def _fallback_solves(mw, omega, sens, xp, xm, vforce, kp, ks, kw, km, wk, check):
    """After a failed coupled Newton, from the untouched start (wk[WK_SAVED_W], wk[WK_SAVED_M]): the
    whole-shape Newton, then the safeguard. If both fail the start (and S) is restored and the
    failure reported: as ERR_BUCKLING if, unchecked so far, the start is unstable, or if the solve
    runs into a slack kink past which the spine is unstable (:func:`slack_fold`), else with the
    solver's own status. Returns (status, passes)."""
    saved_w, saved_m, saved_s = wk[WK_SAVED_W], wk[WK_SAVED_M], wk[WK_SAVED_S]
    copy_pairs(omega, saved_w)
    copy_pairs(mw, saved_m)
    st, passes = composite_full_newton(mw, omega, xp, xm, vforce, kp, ks, kw, km, wk)
    if st == OK:
        return st, passes
    copy_pairs(omega, saved_w)
    copy_pairs(mw, saved_m)
    _copy_matrix(saved_s, sens)
    st, p2 = composite_safeguard(mw, omega, sens, xp, xm, vforce, kp, ks, kw, km, wk)
    passes += p2
    if st != OK:
        copy_pairs(omega, saved_w)
        copy_pairs(mw, saved_m)
        _copy_matrix(sens, saved_s)
        if not check and is_buckled_in(omega, mw, xp, xm, vforce, kp, kw, km, wk[WK_STAB]):
            return ERR_BUCKLING, passes
        if slack_fold(omega, xp, xm, vforce, kp, kw, km, wk):
            return ERR_BUCKLING, passes
    return st, passes


@hot
def _copy_matrix(dst, src):
    """dst[:, :] = src (an explicit loop, as :func:`copy_pairs`)."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]


@hot
def _store_strains(eps, sig, e_new, s_new):
    """The converged strains and stresses into the state's blocks."""
    for j in range(eps.shape[0]):
        eps[j] = e_new[j]
        sig[j] = s_new[j]


@jit
def composite(state, vforce, kp, ks, kw, km, wk, check=False):
    """Solve the composite module for the state's fractions and the loads, in place
    (cf. planar.composite.composite).

    Updates M_w, ω, ε, σ in ``state``; ``check`` as :func:`solve_mechanics`.
    Returns (status, shape passes used).
    """
    nw, nm, ns = sizes(kw, km)
    mw, omega, sens = views(state, nw, nm, ns)
    return solve_mechanics(
        mw,
        omega,
        sens,
        wire_block(state, F_XP, nw),
        wire_block(state, F_XM, nw),
        wire_block(state, F_EPS, nw),
        wire_block(state, F_SIG, nw),
        vforce,
        kp,
        ks,
        kw,
        km,
        wk,
        check,
    )


@hot
def _secant_update(sens, omega, saved_w, mw, saved_m):
    """Broyden update S += (Δω − S ΔM) ΔMᵀ / |ΔM|² from two converged shapes (same loads).

    With ΔM along one axis (the planar case) this is the planar secant s = Δθ/ΔM of that column.
    """
    nm = mw.shape[0]
    big = 0.0
    nrm = 0.0
    for c in range(2 * nm):  # column c of S is component c of M
        d = mw[c // 2, c % 2] - saved_m[c // 2, c % 2]
        big = max(big, abs(d))
        nrm += d * d
    if big <= SECANT_MIN_DM:
        return
    inv = 1.0 / nrm
    for i in range(omega.shape[0]):
        for b in range(2):
            r = 2 * i + b
            miss = omega[i, b] - saved_w[i, b]
            for c in range(2 * nm):
                miss -= sens[r, c] * (mw[c // 2, c % 2] - saved_m[c // 2, c % 2])
            f = miss * inv
            for c in range(2 * nm):
                sens[r, c] += f * (mw[c // 2, c % 2] - saved_m[c // 2, c % 2])
