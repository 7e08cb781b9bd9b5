"""Time integration of one spatial spine (MODEL.md §6.1, §6.5; as :mod:`spine_gym.physics.planar.integrate`).

:func:`advance` integrates one output step with the sub-steps of :mod:`.substep`
(:func:`advance_in` the same with the caller's work arrays); :func:`advance_held_in` a span of
output steps with held inputs, the sub-steps crossing the output points (dense output,
:mod:`spine_gym.physics.dense`); :func:`init_state` is the initial state (§3.10). The recorded loop
over many output steps is :mod:`.run`, one control period of the envs :mod:`.control`.
"""

from __future__ import annotations

import numpy as np

from .._jit import hot, jit
from ..columns import (
    ERR_BUCKLING,
    ERR_SUBSTEPS,
    K_DU,
    K_EPS0,
    K_EPST,
    K_LREF,
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
from .columns import (
    F_EPS,
    F_SIG,
    F_T,
    F_XM,
    F_XP,
    RCACHE_WIRE,
    S_TIME,
    W_DU,
    W_EPS0,
    W_L0,
    W_LAMS,
    W_LREF,
    rate_cache_offset,
    rate_key_offset,
    sens_offset,
    wire_offset,
)
from .composite import composite, solve_mechanics
from .record import _record
from .stability import is_buckled_in, needs_stability_check
from .substep import _substep_coupled, _substep_frozen
from .tube import solve_shape
from .work import (
    WK_CHORDS,
    WK_FRAMES,
    WK_JNUM,
    WK_KPW,
    WK_MID,
    WK_NEW,
    WK_RT,
    WK_STAB,
    WK_START,
    make_work,
    sizes,
    views,
    wire_block,
    wire_blocks,
)


INIT_DM = 1e-3  # [N m] moment of the initial sensitivity probe (as planar.integrate.init_state)


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
    """Advance one spatial spine by one output step ``dt`` (MODEL.md §6.1, §6.5; cf. planar.integrate.advance).

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
    :func:`planar.integrate.advance_held`: the sub-steps cross the output points (MODEL.md §6.5,
    :mod:`.dense`) and the :func:`record` of output j = 1 … n_out goes to ``out[row0 + j − 1]``,
    from the state linearly interpolated within the sub-step that contains it.

    Returns:
        (status, output steps completed, sub-steps, shape passes).
    """
    return _advance_in(state, kp, ks, kw, km, volts, vforce, dt, n_out, resolve, wk, out, row0)


@hot
def _complete_outputs(state, start, mid, kp, kw, km, frames, chords, out, row0, dt, n_out, done, sub):
    """Complete the outputs done + 1, … that the sub-step ``sub`` = (e0, e1, ends the span)
    reached, as :func:`planar.integrate._complete_outputs`. Only the recorded head of the state (up to S)
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
    wb = wire_blocks(state, nw)
    return _span(state, mw, omega, sens, wb, kp, ks, kw, km, volts, vforce, dt, n_out, resolve, wk, out, row0)


@hot
def _span(state, mw, omega, sens, wb, kp, ks, kw, km, volts, vforce, dt, n_out, resolve, wk, out, row0):
    """The span loop of :func:`_advance_in` on the state's views (M_w, ω, S) and wire blocks ``wb``
    (:data:`.work.WireBlocks`); no allocation (the work tuple ``wk`` holds the scratch)."""
    nw, nm, ns = sizes(kw, km)
    xp, xm, sig, eps = wb.xp, wb.xm, wb.sig, wb.eps
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
            # step at most, as planar.integrate.advance)
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
    straight spine to a probe moment INIT_DM on that unknown (cf. planar.integrate.init_state).

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
