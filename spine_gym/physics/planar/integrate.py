"""Time integration of one planar spine (MODEL.md §6).

:func:`advance` integrates one output step with adaptive sub-steps (:mod:`.substep`);
:func:`advance_held` integrates a span of output steps with held inputs in one go, the sub-steps
crossing the output points and the outputs inside a sub-step interpolated (dense output, §6.5,
:mod:`..dense`); :func:`init_state` is the initial state (§3.10). The recorded loop over many output
steps is :mod:`.run`, one control period of the envs :mod:`.control`.
"""

from __future__ import annotations

import numpy as np

from .._jit import hot, jit
from ..columns import (
    ERR_BUCKLING,
    ERR_SUBSTEPS,
    K_EI,
    K_EPS0,
    K_EPST,
    K_L0,
    K_LS,
    K_TE,
    OK,
    RATE_KP,
    S_MAXSHAPE,
    S_MAXSUB,
    S_SCHEME,
    S_TOLTH,
    SCHEME_COUPLED,
)
from ..dense import interpolate, output_fraction
from ..sma import rates_and_slopes
from .columns import X_EL, X_ER, X_HEAD, X_ML, X_MR, X_PL, X_PR, X_RCACHE, X_SL, X_SR, X_TIME, X_TL, X_TR
from .composite import composite, composite_in
from .record import record
from .stability import is_buckled_in, needs_stability_check
from .substep import _substep_coupled, _substep_frozen
from .tube import solve_shape
from .work import COUPLED_WORK_SIZE, CW_RT, CW_XS, coupled_work


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
