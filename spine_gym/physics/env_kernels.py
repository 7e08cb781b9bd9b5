"""One control period for many spines: the jitted loop shared by the single and the vector env.

Nothing here adds an equation: each spine is advanced with :func:`solver.advance` (the model's own
adaptive sub-steps inside every physics step ``dt``) and measured with :func:`batch.record`, exactly
as :func:`spine_gym.simulate` does. What the environments need on top is bookkeeping: a per-spine
``active`` mask (the vector env steps only the environments that are not being reset), a backup so
that a spine whose step fails is handed back at its last valid state (the env then terminates
with a status, never with NaN), and a ``resolve`` flag per spine (solve the mechanics again only
when the loads changed since the last solve, as ``batch.run`` does).

Compiled twice from one body (STYLE.md): ``step_many`` runs the loop over spines in parallel with
``prange``; ``step_many_serial`` is the serial twin used by the single env and by the vector env with
``parallel=False``. Both give bit-identical rows (tested), and each has its own on-disk cache entry
(``_jit.pjit``), so the serial twin never runs the parallel machine code (tested).

``step_many_spatial`` / ``step_many_spatial_serial`` are the same loop over spatial or chained
spines (:func:`spatial_solver.advance` and :func:`spatial_solver.record`, SPATIAL.md), used by
``SmaSpine3D-v0`` and ``SmaSpineChain-v0``; each spine carries its own layout tables (``kw``,
``km``), which depend on the episode's (possibly randomised) parameters.
"""

from __future__ import annotations

import math

import numba

from ._jit import jit, pjit
from .batch import record
from .layout import ERR_NONFINITE, OK
from .solver import advance
from .spatial_solver import advance_in as spatial_advance_in
from .spatial_solver import make_work, sizes
from .spatial_solver import record as spatial_record


def _step_many(states, backup, kps, ks, v_r, v_l, loads, resolve, active, dt, n_sub, status, meas):
    """Advance every active spine by ``n_sub`` physics steps of ``dt`` and record it.

    Args:
        states: (B, S) model states, advanced in place.
        backup: (B, S) scratch; row i receives the state before the step.
        kps: (B, KP_SIZE) constants (one row per spine, for domain randomisation).
        ks: solver options.
        v_r, v_l: (B,) voltages held over the control period [V].
        loads: (B, N, 2) vertex forces held over the control period [N].
        resolve: (B,) bool, the loads differ from those of the last mechanical solve.
        active: (B,) bool, spines to advance (others are left untouched).
        dt: physics step [s]; the control period is ``n_sub * dt``.
        n_sub: physics steps per control period.
        status: (B,) int64 out; ``layout`` status code of the step (OK or the first failure).
        meas: (B, batch.OUT_SIZE) out; :func:`batch.record` of each active spine after the step
            (of the restored state if the step failed).
    """
    b = states.shape[0]
    s = states.shape[1]
    for i in numba.prange(b):
        if not active[i]:
            continue
        status[i] = OK
        for q in range(s):
            backup[i, q] = states[i, q]
        for j in range(n_sub):
            st, _, _ = advance(states[i], kps[i], ks, v_r[i], v_l[i], loads[i], dt, resolve[i] and j == 0)
            if st != OK:
                status[i] = st
                for q in range(s):
                    states[i, q] = backup[i, q]
                break
        record(states[i], kps[i], meas[i])


step_many = pjit(_step_many)
step_many_serial = jit(_step_many)


@jit
def record_many(states, kps, rows, meas):
    """:func:`batch.record` of the spines ``rows`` (int array) into ``meas[rows]``."""
    for k in range(rows.shape[0]):
        i = rows[k]
        record(states[i], kps[i], meas[i])


@jit
def _all_finite(x):
    for q in range(x.shape[0]):
        if not math.isfinite(x[q]):
            return False
    return True


def _step_many_spatial(
    states, backup, kps, ks, kws, kms, volts, loads, resolve, active, dt, n_sub, status, rec
):
    """:func:`_step_many` for spatial or chained spines (:func:`spatial_solver.advance`, SPATIAL.md).

    Args as :func:`_step_many`, except: ``kws`` (B, W, KW_SIZE) and ``kms`` (B, K, KM_SIZE) the
    layout tables of each spine (they depend on the episode's parameters); ``volts`` (B, W) [V];
    ``loads`` (B, N, 3) global x/y/z vertex forces [N]; ``rec`` (B, record_size) out, the
    :func:`spatial_solver.record` row of each active spine after the step.

    A physics step that reports OK but leaves a non-finite state counts as failed (ERR_NONFINITE,
    rolled back): the spatial core can let a NaN through in rare steps of extreme drive under load
    (found by the env's fuzz test), and the env must never hand one out.
    """
    b = states.shape[0]
    s = states.shape[1]
    for i in numba.prange(b):
        if not active[i]:
            continue
        status[i] = OK
        for q in range(s):
            backup[i, q] = states[i, q]
        nw, nm, ns = sizes(kws[i], kms[i])
        wk = make_work(nw, nm, ns)  # once per spine and env step, shared by its sub-steps and record
        for j in range(n_sub):
            st, _, _ = spatial_advance_in(
                states[i], kps[i], ks, kws[i], kms[i], volts[i], loads[i], dt, resolve[i] and j == 0, wk
            )
            if st == OK and not _all_finite(states[i]):
                st = ERR_NONFINITE
            if st != OK:
                status[i] = st
                for q in range(s):
                    states[i, q] = backup[i, q]
                break
        spatial_record(states[i], kps[i], kws[i], kms[i], wk, rec[i])


step_many_spatial = pjit(_step_many_spatial)
step_many_spatial_serial = jit(_step_many_spatial)


@jit
def record_many_spatial(states, kps, kws, kms, rows, rec):
    """:func:`spatial_solver.record` of the spatial spines ``rows`` into ``rec[rows]``."""
    for k in range(rows.shape[0]):
        i = rows[k]
        nw, nm, ns = sizes(kws[i], kms[i])
        spatial_record(states[i], kps[i], kws[i], kms[i], make_work(nw, nm, ns), rec[i])
