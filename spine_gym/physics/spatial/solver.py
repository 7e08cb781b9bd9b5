"""Composite solve and time integration of the wire- and module-generic spine (SPATIAL.md §5, MODEL.md §6).

The unknowns of the composite module are the K module wire moments M_w,k (2K scalars, material
components). G(M) is the wire moment that the constitutive law (MODEL.md §3.6) gives at the strains
of the shape that M produces (SPATIAL.md §3–§4); the solve finds M = G(M).

* Coupled Newton (default, the generalisation of :func:`planar.solver.composite_newton`): one shape
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

:func:`advance` mirrors :func:`planar.solver.advance` over arrays of wires, with the scheme that
``SolverOptions.scheme`` selects: the coupled linearly implicit step with error-controlled sub-steps
(default, MODEL.md §6.5, SPATIAL.md §8.6; its per-wire pieces are :mod:`.coupled`'s, shared with the
planar core) or the frozen-rate step of MODEL.md §6.1; implicit convection and exact energy
bookkeeping in both. The wire model is :mod:`.sma`'s, not a copy.
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
    K_ASV,
    K_AW,
    K_DU,
    K_EPS0,
    K_EPST,
    K_KE,
    K_LREF,
    K_RHOC,
    K_TE,
    K_TMAX,
    KP_SIZE,
    OK,
    RATE_KP,
    S_C,
    S_HMAX,
    S_HMIN,
    S_MAXROOT,
    S_MAXSHAPE,
    S_MAXSUB,
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
from ..dense import held_steps, interpolate, last_h, output_fraction, span_options, spans_outputs
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
    F_EPS,
    F_QC,
    F_QJ,
    F_QL,
    F_SIG,
    F_T,
    F_XM,
    F_XP,
    M_NSEG,
    M_SEG0,
    RCACHE_WIRE,
    S_TIME,
    W_A,
    W_DU,
    W_EPS0,
    W_EX,
    W_EY,
    W_L0,
    W_LAMS,
    W_LREF,
    W_MOD,
    W_NW,
    hnext_offset,
    moment_offset,
    omega_offset,
    rate_cache_offset,
    rate_key_offset,
    sens_offset,
    wire_offset,
)
from .stability import (
    add_wire_term,
    is_buckled_at,
    is_buckled_in,
    needs_stability_check,
    stability_work,
    tube_jacobian,
)
from .tube import (
    bending_vector,
    chord_sums,
    gain_sums,
    kinematics,
    length_slope,
    shape_pass,
    solve_shape,
    tip_point,
    wire_length,
)

FD_DM = 1e-4  # [N m] moment step of the finite-difference sensitivity of the safeguard
INIT_DM = 1e-3  # [N m] moment of the initial sensitivity probe (as planar.solver.init_state)
MAX_HALVINGS = 30  # back-tracking halvings of one safeguarded Newton step
SAFE_TOL = 0.01  # shape tolerance of the safeguard relative to tol_theta
MECH_RETRY = 0.25  # a coupled sub-step whose composite solve failed is retried this much shorter


# ---------------------------------------------------------------- state views and work arrays
@jit
def sizes(kw, km):
    """(W, K, N): wire groups, modules, segments."""
    n = 0
    for k in range(km.shape[0]):
        n += int(km[k, M_NSEG])
    return kw.shape[0], km.shape[0], n


@jit
def views(state, nw, nm, ns):
    """(M_w (K, 2), ω (N, 2), S (2N, 2K)) as views into the state."""
    mo = moment_offset(nw)
    oo = omega_offset(nw, nm)
    so = sens_offset(nw, nm, ns)
    return (
        state[mo : mo + 2 * nm].reshape((nm, 2)),
        state[oo : oo + 2 * ns].reshape((ns, 2)),
        state[so : so + 4 * ns * nm].reshape((2 * ns, 2 * nm)),
    )


@jit
def wire_block(state, field, nw):
    """View of the per-wire block ``field`` (F_*) of the state."""
    o = wire_offset(field, nw)
    return state[o : o + nw]


# indices of the work tuple of make_work
(
    WK_FRAMES,  # (N + 1, 3, 3) section frames
    WK_CHORDS,  # (N, 3) chords
    WK_NEW,  # (N, 2) new ω of a shape pass
    WK_SAVED_W,  # (N, 2) saved ω
    WK_SUMS,  # (K, 3) chord sums of the wire lengths (spatial.tube.chord_sums)
    WK_EPS,  # (W,) strains
    WK_SIG,  # (W,) stresses
    WK_G,  # (K, 2) G(M)
    WK_JAC,  # (2K, 2K) Jacobian, then the Newton matrix
    WK_DM,  # (2K,) ΔM (the right-hand side G − M, solved in place)
    WK_MTRIAL,  # (K, 2) trial M
    WK_SAVED_M,  # (K, 2) saved M
    WK_WTRIAL,  # (N, 2) trial ω
    WK_RATES,  # (W, 4) rates
    WK_XNEW,  # (W, 2) new fractions
    WK_GAIN,  # (K, 2K, 3) sums of the loop gain (spatial.tube.gain_sums)
    # the coupled time step (MODEL.md §6.5; x and Δx ordered (x+, x-) of wire 0, wire 1, ...)
    WK_JNUM,  # (W,) U²/L0² of every wire [V²/m²] (Joule heating j = this / resistivity)
    WK_X0,  # (2W,) fractions at the start of the sub-step
    WK_XS,  # (2W,) fractions at its end
    WK_RT,  # (W, 12) rates and slopes at the start (sma.rates_and_slopes)
    WK_RT_NEW,  # (W, 12) rates and slopes at the end
    WK_DMDX,  # (2K, 2W) dM/dx of the composite equilibrium (the active wires' columns)
    WK_INV,  # (2K, 2K) (I − J)⁻¹
    WK_AT,  # (W,) temperature terms a of the linearised heat balance
    WK_BT,  # (W, 2) and b
    WK_ACT,  # (W + 1,) int: the wires in the linear system (_active_wires), their count last
    WK_XA,  # (2W,) their fractions (then the error's residuals)
    WK_RTA,  # (W, 12) their rates and slopes
    WK_SA,  # (W, 2W) their rows and columns of dσ/dx (stress_sensitivity)
    WK_LU,  # (2W, 2W) the step's matrix, then its LU factors
    WK_PIV,  # (2W,) int: their row exchanges
    WK_VEC,  # (2W,) right-hand side, solution
    WK_BACKUP,  # (omega_offset,) the state up to ω (time, wire blocks, M_w) at the sub-step's start
    # dense output: the recorded head of the state (up to S) at a sub-step's start, and interpolated
    WK_START,  # (sens_offset,)
    WK_MID,  # (sens_offset,)
    # the whole-shape Newton and the stability test
    WK_STEP,  # (2N,) Newton step on ω
    WK_STAB,  # the tuple of spatial.stability.stability_work
    WK_SAVED_S,  # (2N, 2K) S at the start of the fallbacks (restored if they fail)
    WK_KPW,  # (W, KP_SIZE) every wire's own material constants (:func:`wire_constants`)
) = range(39)


@jit
def make_work(nw, nm, ns):
    """Preallocated work arrays of one spine (no allocation inside the sub-step loop), WK_* order."""
    return (
        np.empty((ns + 1, 3, 3)),
        np.empty((ns, 3)),
        np.empty((ns, 2)),
        np.empty((ns, 2)),
        np.empty((nm, 3)),
        np.empty(nw),
        np.empty(nw),
        np.empty((nm, 2)),
        np.empty((2 * nm, 2 * nm)),
        np.empty(2 * nm),
        np.empty((nm, 2)),
        np.empty((nm, 2)),
        np.empty((ns, 2)),
        np.empty((nw, 4)),
        np.empty((nw, 2)),
        np.empty((nm, 2 * nm, 3)),
        np.empty(nw),
        np.empty(2 * nw),
        np.empty(2 * nw),
        np.empty((nw, 12)),
        np.empty((nw, 12)),
        np.empty((2 * nm, 2 * nw)),
        np.empty((2 * nm, 2 * nm)),
        np.empty(nw),
        np.empty((nw, 2)),
        np.zeros(nw + 1, dtype=np.int64),
        np.empty(2 * nw),
        np.empty((nw, 12)),
        np.empty((nw, 2 * nw)),
        np.empty((2 * nw, 2 * nw)),
        np.zeros(2 * nw, dtype=np.int64),
        np.empty(2 * nw),
        np.empty(omega_offset(nw, nm)),
        np.empty(sens_offset(nw, nm, ns)),
        np.empty(sens_offset(nw, nm, ns)),
        np.empty(2 * ns),
        stability_work(nw, nm, ns),
        np.empty((2 * ns, 2 * nm)),
        np.empty((nw, KP_SIZE)),
    )


@hot
def wire_constants(kp, kw, kpw):
    """Every wire's own material constants into ``kpw`` (W, KP_SIZE): ``kp`` with the wire's Δu
    offset, pre-strain and stress-free length (``kw``). Its resistivity scale enters the Joule
    heating and the recorded resistivity directly. A wire with no offsets gets ``kp`` bit for bit."""
    for j in range(kw.shape[0]):
        for q in range(kp.shape[0]):
            kpw[j, q] = kp[q]
        kpw[j, K_DU] = kp[K_DU] + kw[j, W_DU]
        kpw[j, K_EPS0] = kw[j, W_EPS0]
        kpw[j, K_LREF] = kw[j, W_LREF]


# ---------------------------------------------------------------- mechanics
# The kernels called on every sub-step take the work arrays they use, not the work tuple: passing
# the 37-member work tuple down a call costs ~0.1-0.2 µs per call (its members are passed and
# reference-counted one by one), about as much as the arithmetic of a whole shape pass.
@hot
def wire_mechanics(omega, xp, xm, kp, kw, km, wk):
    """Strains, stresses (MODEL.md §3.6, SPATIAL.md §4) and G(M) (SPATIAL.md §3) of a shape.

    Writes wk[WK_EPS] = ε, wk[WK_SIG] = σ [Pa], wk[WK_G] = G = Σ_i n_w,i A_w σ_i a_i e_i per module [N m]
    (:func:`shape_mechanics` on the work tuple).
    """
    shape_mechanics(omega, xp, xm, kp, kw, km, wk[WK_SUMS], wk[WK_EPS], wk[WK_SIG], wk[WK_G])


@hot
def shape_mechanics(omega, xp, xm, kp, kw, km, sums, eps, sig, gm):
    """:func:`wire_mechanics` into the arrays ``sums`` (chord sums), ``eps``, ``sig`` and ``gm``."""
    chord_sums(omega, km, sums)
    for j in range(kw.shape[0]):
        eps[j] = wire_length(j, sums, kw, km) / kw[j, W_LREF] - 1.0
    strain_mechanics(xp, xm, kp, kw, eps, sig, gm)


@hot
def strain_mechanics(xp, xm, kp, kw, eps, sig, gm):
    """The second half of :func:`shape_mechanics`: ``sig`` and ``gm`` = G from the strains ``eps``
    (e.g. those of the last converged shape, when only the fractions changed since)."""
    for k in range(gm.shape[0]):
        gm[k, 0] = 0.0
        gm[k, 1] = 0.0
    aw = kp[K_AW]
    for j in range(kw.shape[0]):
        s = stress(eps[j], xp[j], xm[j], kp)
        sig[j] = s
        k = int(kw[j, W_MOD])
        t = kw[j, W_NW] * aw * s * kw[j, W_A]
        gm[k, 0] += t * kw[j, W_EX]
        gm[k, 1] += t * kw[j, W_EY]


@hot
def loop_gain(omega, sens, xp, xm, sig, kp, kw, km, jac, gs, sums_known=False):
    """J = dG/dM = ∂G/∂ω · S into ``jac`` (2K × 2K) at the stresses ``sig``; a slack wire (σ = 0)
    adds nothing.

    ∂L/∂ω · S of every wire from its module's sums ``gs`` (:func:`.tube.gain_sums`,
    :func:`.tube.length_slope`), computed here unless ``sums_known`` (they depend on ω and
    S only: the coupled step's dσ/dx computed them at the same ω and S).
    """
    ncol = jac.shape[1]
    for r in range(ncol):
        for c in range(ncol):
            jac[r, c] = 0.0
    if not sums_known:
        gain_sums(omega, sens, km, gs)
    aw = kp[K_AW]
    for j in range(kw.shape[0]):
        if sig[j] <= 0.0:
            continue
        k = int(kw[j, W_MOD])
        ex = kw[j, W_EX]
        ey = kw[j, W_EY]
        cw = kw[j, W_NW] * aw * kw[j, W_A] / (compliance(xp[j], xm[j], kp) * kw[j, W_LREF])
        for c in range(ncol):
            g = cw * length_slope(j, gs, c, kw, km)
            jac[2 * k, c] += ex * g
            jac[2 * k + 1, c] += ey * g


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
    """Coupled Newton composite solve in place on (mw, omega); cf. :func:`planar.solver.composite_newton`.

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
def copy_pairs(dst, src):
    """dst[:, :] = src for (n, 2) arrays (an explicit loop: cheaper than a 2-D slice assignment)."""
    for i in range(src.shape[0]):
        dst[i, 0] = src[i, 0]
        dst[i, 1] = src[i, 1]


@hot
def composite_full_newton(mw, omega, xp, xm, vforce, kp, ks, kw, km, wk):
    """Newton on the whole shape, R(ω) = ω − f(ω, G(ω)) = 0 with the tangent I − J (cf.
    :func:`planar.solver.composite_full_newton`): the fallback near buckling, where the coupled Newton's
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
    from the untouched starting point (cf. planar.solver.composite).
    With ``check`` (loads that might buckle the spine, :func:`.stability.needs_stability_check`)
    the starting shape and the converged one are tested for stability and ERR_BUCKLING returned,
    state untouched, if either is unstable (as :func:`planar.solver.composite`). A failed solve is
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
    (cf. planar.solver.composite).

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


# ---------------------------------------------------------------- time step (MODEL.md §6.1, §6.5)
@hot
def _choose_h(rem, dt, r, ks):
    """Sub-step size of MODEL.md §6.1 b, exactly as planar.solver.advance."""
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
    :func:`planar.solver._substep_frozen` for every wire. Returns (status, h, shape passes, solved)."""
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
def stress_sensitivity(omega, sens, xp, xm, sig, kp, kw, km, act, na, jac, gs, inv, lu, piv, col, dmdx, sa):
    """dσ/dx of the composite equilibrium under fixed loads (MODEL.md §6.5), the rows and columns of
    the wires ``act[:na]`` only, into wk[WK_SA] (na, 2na): row a, columns 2b, 2b + 1 are ∂σ_{act[a]}
    over x₊, x₋ of wire act[b]. Work: the loop gain ``jac`` and its sums ``gs`` (2K × 2K, K × 2K × 3),
    ``inv`` = (I − J)⁻¹, ``lu`` (>= 2K × 2K), ``piv``, ``col`` (2K), ``dmdx`` (2K, >= 2 na).

    At fixed strain the constitutive law §3.6 gives ∂σ_j/∂x₊ = −E*_j (ε_T + σ_j k_E),
    ∂σ_j/∂x₋ = E*_j (ε_T − σ_j k_E) (E* = 1/compliance, 0 when slack), which moves G by
    dG_k = n_w A_w a_j e_j dσ_j|_ε (SPATIAL.md §3); the equilibrium M = G(M) then moves by
    dM = (I − J)⁻¹ dG|_ε (J = :func:`loop_gain`) and every stress by E*_i (dL_i/dM) dM / L_ref,i. The
    planar layout gives :func:`planar.solver.stress_sensitivity`. The other wires' rows and columns are
    not needed (:func:`_active_wires`); each entry is computed as over all wires.
    The loop-gain sums stay in wk[WK_GAIN] for the composite solve's first Newton step.
    """
    nm = km.shape[0]
    loop_gain(omega, sens, xp, xm, sig, kp, kw, km, jac, gs)  # J, and the length sums
    lu = lu[: 2 * nm, : 2 * nm]
    piv = piv[: 2 * nm]
    for r in range(2 * nm):
        for q in range(2 * nm):
            lu[r, q] = (1.0 if r == q else 0.0) - jac[r, q]
    if not _inverse(lu, piv, col, inv):
        return False
    eps_t = kp[K_EPST]
    k_e = kp[K_KE]
    aw = kp[K_AW]
    for b in range(na):
        j = act[b]
        d_p = 0.0
        d_m = 0.0
        if sig[j] > 0.0:
            e_star = 1.0 / compliance(xp[j], xm[j], kp)
            d_p = -e_star * (eps_t + sig[j] * k_e)
            d_m = e_star * (eps_t - sig[j] * k_e)
        k = int(kw[j, W_MOD])
        t = kw[j, W_NW] * aw * kw[j, W_A]
        for r in range(2 * nm):  # dM/dx_j = (I − J)⁻¹ dG/dx_j, dG_k = t e_j dσ_j
            f = inv[r, 2 * k] * kw[j, W_EX] + inv[r, 2 * k + 1] * kw[j, W_EY]
            dmdx[r, 2 * b] = 0.0 + t * f * d_p
            dmdx[r, 2 * b + 1] = 0.0 + t * f * d_m
        for a in range(na):  # its own (fixed-strain) column of its row
            sa[a, 2 * b] = d_p if act[a] == j else 0.0
            sa[a, 2 * b + 1] = d_m if act[a] == j else 0.0
    for a in range(na):
        i = act[a]
        if sig[i] <= 0.0:
            continue
        g = 1.0 / (compliance(xp[i], xm[i], kp) * kw[i, W_LREF])
        for r in range(2 * nm):
            dl = g * length_slope(i, gs, r, kw, km)
            if dl == 0.0:
                continue
            for c in range(2 * na):
                sa[a, c] += dl * dmdx[r, c]
    return True


@hot
def _inverse(a, piv, col, inv):
    """inv = a⁻¹ column by column (a overwritten: Cramer's rule for 2 × 2 as
    :func:`.stability.solve_in_place`, else one LU factorisation). Returns False if a is singular."""
    n = a.shape[0]
    if n == 2:
        det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        if det == 0.0 or not math.isfinite(det):
            return False
        inv[0, 0] = a[1, 1] / det
        inv[1, 0] = -a[1, 0] / det
        inv[0, 1] = -a[0, 1] / det
        inv[1, 1] = a[0, 0] / det
        return True
    if not lu_factor(a, piv):
        return False
    for c in range(n):
        for r in range(n):
            col[r] = 1.0 if r == c else 0.0
        lu_solve(a, piv, col[:n])
        for r in range(n):
            inv[r, c] = col[r]
    return True


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
    (MODEL.md §6.5; cf. :func:`planar.solver._predict_coupled`): the wires of :func:`_active_wires`
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
    """One wire's share of the coupled step's error estimate (cf. :func:`planar.solver._coupled_error`).

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
    """One accepted sub-step of the coupled scheme (default), as :func:`planar.solver._substep_coupled`
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


@hot
def _load_rates(state, kp, kw, km, ns, rt, kpw):
    """Every wire's rates and slopes at its (σ, T) into ``rt`` (W, 12): from the state's rate cache
    where it was filled at exactly this (σ, T) and these constants (the wire's Δu offset
    included), else computed with the wire's constants ``kpw[j]``."""
    nw, nm = kw.shape[0], km.shape[0]
    ko = rate_key_offset(nw, nm, ns)
    co = rate_cache_offset(nw, nm, ns)
    o_s = wire_offset(F_SIG, nw)
    o_t = wire_offset(F_T, nw)
    same_kp = True
    for k in range(len(RATE_KP)):
        same_kp = same_kp and state[ko + k] == kp[RATE_KP[k]]
    for j in range(nw):
        c = co + RCACHE_WIRE * j
        hit = state[c] == state[o_s + j] and state[c + 1] == state[o_t + j] and state[c + 2] == kw[j, W_DU]
        if same_kp and hit:
            for q in range(12):
                rt[j, q] = state[c + 3 + q]
        else:
            rates_and_slopes(state[o_s + j], state[o_t + j], kpw[j], rt[j])


@hot
def _store_rates(state, kp, kw, km, ns, rt):
    """Keep the rates ``rt`` at every wire's (σ, T) and the constants for the next output step."""
    nw, nm = kw.shape[0], km.shape[0]
    ko = rate_key_offset(nw, nm, ns)
    co = rate_cache_offset(nw, nm, ns)
    o_s = wire_offset(F_SIG, nw)
    o_t = wire_offset(F_T, nw)
    for k in range(len(RATE_KP)):
        state[ko + k] = kp[RATE_KP[k]]
    for j in range(nw):
        c = co + RCACHE_WIRE * j
        state[c] = state[o_s + j]
        state[c + 1] = state[o_t + j]
        state[c + 2] = kw[j, W_DU]
        for q in range(12):
            state[c + 3 + q] = rt[j, q]


@jit
def advance(state, kp, ks, kw, km, volts, vforce, dt, resolve=True):
    """Advance one spatial spine by one output step ``dt`` (MODEL.md §6.1, §6.5; cf. planar.solver.advance).

    Args:
        state: spatial state (see :mod:`.columns`), updated in place.
        kp, ks: material constants and solver options.
        kw, km: wire-group and module tables.
        volts: (W,) voltage on each wire of every group [V].
        vforce: (N, 3) external forces at the vertices P_0 … P_{N−1} [N], global x/y/z.
        dt: output step [s].
        resolve: solve the mechanics first (the loads changed since the last call).

    Allocates its work arrays; a time loop passes them to :func:`advance_in`, the same step.

    Returns:
        (status, sub-steps, shape passes).
    """
    nw, nm, ns = sizes(kw, km)
    return advance_in(state, kp, ks, kw, km, volts, vforce, dt, resolve, make_work(nw, nm, ns))


@jit
def advance_in(state, kp, ks, kw, km, volts, vforce, dt, resolve, wk):
    """:func:`advance` with the work arrays ``wk`` of :func:`make_work` (no allocation).

    The sub-steps are those of the option ``scheme``: :func:`_substep_coupled` (default) or
    :func:`_substep_frozen`. Under loads that might buckle the spine
    (:func:`.stability.needs_stability_check`) the re-solve and the shape the step ends on
    are checked for stability, as in the planar core; an unstable equilibrium ends the step with
    ERR_BUCKLING.
    """
    st, _done, nsub, passes = _advance_in(state, kp, ks, kw, km, volts, vforce, dt, 1, resolve, wk, None, 0)
    return st, nsub, passes


@jit
def advance_held_in(state, kp, ks, kw, km, volts, vforce, dt, n_out, resolve, wk, out, row0):
    """Advance by ``n_out`` output steps of ``dt`` with the inputs held, in one span, as
    :func:`planar.solver.advance_held`: the sub-steps cross the output points (MODEL.md §6.5,
    :mod:`.dense`) and the :func:`record` of output j = 1 … n_out goes to ``out[row0 + j − 1]``,
    from the state linearly interpolated within the sub-step that contains it.

    Returns:
        (status, output steps completed, sub-steps, shape passes).
    """
    return _advance_in(state, kp, ks, kw, km, volts, vforce, dt, n_out, resolve, wk, out, row0)


@hot
def _complete_outputs(state, start, mid, kp, kw, km, frames, chords, out, row0, dt, n_out, done, sub):
    """Complete the outputs done + 1, … that the sub-step ``sub`` = (e0, e1, ends the span)
    reached, as :func:`planar.solver._complete_outputs`. Only the recorded head of the state (up to S)
    is interpolated, and the record gets its work arrays (frames, chords), not the work tuple;
    after the span's first output it reuses the previous row's shape columns where ω did not
    change (:func:`_record`). Returns the outputs completed."""
    e0, e1, at_end = sub
    nw, nm, ns = sizes(kw, km)
    head = sens_offset(nw, nm, ns)
    theta = output_fraction(done + 1, n_out, dt, e0, e1, at_end)
    while theta >= 0.0:
        state[S_TIME] += dt
        if out is not None:
            src = state
            if theta != 1.0:
                interpolate(start[:head], state[:head], theta, mid[:head])
                mid[S_TIME] = state[S_TIME]
                src = mid
            _record(src, kp, kw, km, frames, chords, out[row0 + done], out[row0 + done - 1], done > 0)
        done += 1
        if done == n_out:
            break
        theta = output_fraction(done + 1, n_out, dt, e0, e1, at_end)
    return done


@jit
def _advance_in(state, kp, ks, kw, km, volts, vforce, dt, n_out, resolve, wk, out, row0):
    """:func:`advance_held_in`; ``out`` None records nothing (and copies nothing per sub-step).

    Takes the state's views and per-wire blocks (kernels that make views return arrays, so the
    ``hot`` span loop cannot) and runs :func:`_span` on them.
    """
    nw, nm, ns = sizes(kw, km)
    mw, omega, sens = views(state, nw, nm, ns)
    wb = (
        wire_block(state, F_XP, nw),
        wire_block(state, F_XM, nw),
        wire_block(state, F_T, nw),
        wire_block(state, F_SIG, nw),
        wire_block(state, F_EPS, nw),
        wire_block(state, F_QJ, nw),
        wire_block(state, F_QC, nw),
        wire_block(state, F_QL, nw),
    )
    return _span(state, mw, omega, sens, wb, kp, ks, kw, km, volts, vforce, dt, n_out, resolve, wk, out, row0)


@hot
def _span(state, mw, omega, sens, wb, kp, ks, kw, km, volts, vforce, dt, n_out, resolve, wk, out, row0):
    """The span loop of :func:`_advance_in` on the state's views (M_w, ω, S) and wire blocks ``wb``
    (x+, x-, T, σ, ε, Q_J, Q_C, Q_L); no allocation (the work tuple ``wk`` holds the scratch)."""
    nw, nm, ns = sizes(kw, km)
    xp, xm, sig, eps = wb[0], wb[1], wb[3], wb[4]
    passes = 0
    check = needs_stability_check(vforce, kp, km)
    if resolve:
        st, passes = solve_mechanics(mw, omega, sens, xp, xm, eps, sig, vforce, kp, ks, kw, km, wk, check)
        if st != OK:
            return st, 0, 0, passes
    wire_constants(kp, kw, wk[WK_KPW])
    jnum = wk[WK_JNUM]
    for j in range(nw):  # the wire's resistivity scale: j = U²/(s λ L0²)
        jnum[j] = volts[j] * volts[j] / (kw[j, W_L0] * kw[j, W_L0]) / kw[j, W_LAMS]
    coupled = int(ks[S_SCHEME]) == SCHEME_COUPLED
    if coupled:
        _load_rates(state, kp, kw, km, ns, wk[WK_RT], wk[WK_KPW])
    # with ``out``: the recorded head of the state at the start of a sub-step and one interpolated
    start = wk[WK_START]
    mid = wk[WK_MID]
    head = start.shape[0]
    solved = False
    max_sub = int(ks[S_MAXSUB])
    span = dt * n_out
    rem = span
    nsub = 0
    since = 0  # sub-steps since the last output
    done = 0  # output steps completed
    while rem > 0.0:
        if out is not None:
            for i in range(head):
                start[i] = state[i]
        e0 = span - rem
        if coupled:
            st, h, p, sol = _substep_coupled(state, mw, omega, sens, wb, vforce, kp, ks, kw, km, rem, dt, wk)
        else:
            st, h, p, sol = _substep_frozen(state, mw, omega, sens, wb, vforce, kp, ks, kw, km, rem, dt, wk)
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
            _store_rates(state, kp, kw, km, ns, wk[WK_RT])
        if output_fraction(done + 1, n_out, dt, sub[0], sub[1], sub[2]) >= 0.0:
            # h. the sub-step reached an output: stability of the shape it ends on (once per output
            # step at most, as planar.solver.advance)
            if check and solved and is_buckled_in(omega, mw, xp, xm, vforce, kp, kw, km, wk[WK_STAB]):
                return ERR_BUCKLING, done, nsub, passes
            done = _complete_outputs(
                state, start, mid, kp, kw, km, wk[WK_FRAMES], wk[WK_CHORDS], out, row0, dt, n_out, done, sub
            )
            since = 0
            solved = False
    return OK, done, nsub, passes


@jit
def init_state(state, kp, ks, kw, km, vforce):
    """Initial state (MODEL.md §3.10) of every wire, straight spine, solved under ``vforce``.

    The sensitivity S starts, column by column, as the response of a full shape solve from the
    straight spine to a probe moment INIT_DM on that unknown (cf. planar.solver.init_state).

    Returns:
        status of the mechanical solve.
    """
    nw, nm, ns = sizes(kw, km)
    state[:] = 0.0
    for j in range(nw):  # each wire at its own pre-strain
        xp0 = 0.5 * (1.0 + kw[j, W_EPS0] / kp[K_EPST])
        wire_block(state, F_XP, nw)[j] = xp0
        wire_block(state, F_XM, nw)[j] = 1.0 - xp0
        wire_block(state, F_EPS, nw)[j] = kw[j, W_EPS0]
    wire_block(state, F_T, nw)[:] = kp[K_TE]
    mw, omega, sens = views(state, nw, nm, ns)
    wk = make_work(nw, nm, ns)
    zero = np.zeros((ns, 3))
    probe = np.empty((ns, 2))
    mp = np.empty((nm, 2))
    for c in range(2 * nm):
        probe[:, :] = 0.0
        mp[:, :] = 0.0
        mp[c // 2, c % 2] = INIT_DM
        st, _ = solve_shape(
            probe,
            mp,
            zero,
            kp,
            km,
            ks[S_TOLTH],
            int(ks[S_MAXSHAPE]),
            wk[WK_FRAMES],
            wk[WK_CHORDS],
            wk[WK_NEW],
        )
        if st != OK:
            return st
        for i in range(ns):
            sens[2 * i, c] = probe[i, 0] / INIT_DM
            sens[2 * i + 1, c] = probe[i, 1] / INIT_DM
    st, _ = composite(state, vforce, kp, ks, kw, km, wk, needs_stability_check(vforce, kp, km))
    return st


# ---------------------------------------------------------------- recording and the time loop
@jit
def record_size(nw, nm, ns):
    """Columns of one record row: the state without S, then the derived outputs of :func:`record`."""
    return sens_offset(nw, nm, ns) + 2 * nm + 2 + 3 + 9 + nw


@jit
def record(state, kp, kw, km, wk, row):
    """Write state (without S) | module bending vectors (K, 2) [rad] | tip bending vector (2) [rad]
    | tip position (3) [m] | tip frame (rows d1, d2, t) (9) | resistivity per wire (W) [Ω m]."""
    _record(state, kp, kw, km, wk[WK_FRAMES], wk[WK_CHORDS], row, row, False)


@hot
def _record(state, kp, kw, km, frames, chords, row, prev, reuse):
    """:func:`record` with its work arrays (frames, chords), as the time loop calls it.

    With ``reuse``, ``prev`` is an earlier record row: if its ω is bitwise this state's, the shape
    columns (bending vectors, tip position and frame: functions of ω alone) are copied from it
    instead of computed again (the same numbers; the spine at rest between transformations).
    Compiled without reference counting (:func:`._jit.hot`: 2 000 calls in the 20-s run), so it
    indexes the state instead of taking :func:`views` and :func:`wire_block`.
    """
    nw, nm, ns = sizes(kw, km)
    head = sens_offset(nw, nm, ns)
    for j in range(head):
        row[j] = state[j]
    oo = omega_offset(nw, nm)
    o = head + 2 * nm + 2 + 3 + 9  # after the shape columns
    if reuse and _same_span(row, prev, oo, head):
        for j in range(head, o):
            row[j] = prev[j]
    else:
        _record_shape(row[oo:head].reshape((ns, 2)), km, frames, chords, row[head:o])
    op = wire_offset(F_XP, nw)
    om = wire_offset(F_XM, nw)
    for j in range(nw):
        row[o + j] = resistivity(state[op + j], state[om + j], kp) * kw[j, W_LAMS]


@hot
def _same_span(a, b, lo, hi):
    """True if a[lo:hi] and b[lo:hi] are the same numbers."""
    for j in range(lo, hi):
        if a[j] != b[j]:
            return False
    return True


@hot
def _record_shape(omega, km, frames, chords, cols):
    """The shape columns of :func:`record` for the rotations ``omega`` into ``cols``: module
    bending vectors (K, 2), tip bending vector (2), tip position (3), tip frame (9)."""
    nm = km.shape[0]
    ns = omega.shape[0]
    kinematics(omega, km, frames, chords)
    t1, t2 = bending_vector(frames[ns], frames[0])
    for k in range(nm):
        seg0 = int(km[k, M_SEG0])
        top = seg0 + int(km[k, M_NSEG])
        if seg0 == 0 and top == ns:  # a single module: the tip's
            b1, b2 = t1, t2
        else:
            b1, b2 = bending_vector(frames[top], frames[seg0])
        cols[2 * k] = b1
        cols[2 * k + 1] = b2
    o = 2 * nm
    cols[o] = t1
    cols[o + 1] = t2
    o += 2
    cols[o], cols[o + 1], cols[o + 2] = tip_point(chords)
    o += 3
    for r in range(3):
        for c in range(3):
            cols[o + 3 * r + c] = frames[0, r, c]


@jit
def run(state, kp, ks, kw, km, volts, loads, dt, out):
    """Integrate one spatial spine over ``volts.shape[0]`` output steps, recording every step.

    Consecutive output steps with equal inputs are one span of :func:`advance_held_in` (MODEL.md
    §6.5, :mod:`.dense`) unless the option ``dense_output`` is off, as :func:`planar.batch.run`.

    Args:
        state: initial state, advanced in place.
        volts: (n, W) voltages held over [t_k, t_k + dt) [V].
        loads: (n, N, 3) vertex forces over each step, or (1, N, 3) for constant loads [N].
        dt: output step [s].
        out: (n + 1, record_size) record; row 0 is the initial state.

    Returns:
        (status, index of the failing step or n, total sub-steps, total shape passes).
    """
    nw, nm, ns = sizes(kw, km)
    wk = make_work(nw, nm, ns)
    n = volts.shape[0]
    record(state, kp, kw, km, wk, out[0])
    dense = spans_outputs(ks)
    ks_span = span_options(ks, dt)
    nsub = 0
    npass = 0
    varying = loads.shape[0] > 1
    k = 0
    while k < n:
        vf = loads[k] if varying else loads[0]
        resolve = varying and k > 0 and not np.array_equal(loads[k], loads[k - 1])
        m = held_steps(volts, loads, k) if dense else 1
        kss = ks_span if m > 1 else ks
        st, done, a, b = advance_held_in(state, kp, kss, kw, km, volts[k], vf, dt, m, resolve, wk, out, k + 1)
        nsub += a
        npass += b
        if st != OK:
            return st, k + done, nsub, npass
        k += m
    return OK, n, nsub, npass
