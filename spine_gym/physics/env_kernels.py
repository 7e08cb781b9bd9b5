"""One control period for many spines: the jitted step shared by the single and the vector env.

Nothing here adds an equation: each spine is advanced with :func:`planar.solver.advance` (the
model's own adaptive sub-steps inside every physics step ``dt``) and measured with
:func:`planar.record.record`, exactly as :func:`spine_gym.simulate` does. What the environments
need on top is bookkeeping: a backup so that a spine whose step fails is handed back at its last
valid state (the env then terminates with a status, never with NaN), and a ``resolve`` flag per
spine (solve the mechanics again only when the loads changed since the last solve, as
``planar.batch.run`` does).

:func:`step_spine` is one spine's control period; the envs call it from their one jitted call per
step (:mod:`spine_gym.envs.step_kernels`: inputs, physics, readings and bookkeeping together).
``step_many`` is the loop of it over a batch with an ``active`` mask, in parallel with ``prange``
(the spines dealt out to the threads one at a time, :mod:`._deal`);
``step_many_serial`` is its serial twin (one body compiled twice, so that the serial and the
parallel loop run the same code; each twin has its own on-disk cache entry, ``_jit.pjit``, so a
serial kernel never runs parallel machine code). No env calls them: they are the physics alone,
which ``benchmarks/bench_training_share.py`` ("the kernel alone") and ``benchmarks/bench_env.py``
time against the env, and ``tests/physics/test_spatial.py`` compares ``step_many_spatial`` with single
spines.

:func:`step_spine_spatial`, ``step_many_spatial`` / ``step_many_spatial_serial`` are the same for
spatial or chained spines (:func:`spatial.solver.advance_in` and :func:`spatial.solver.record`,
SPATIAL.md), used by ``SmaSpine3D-v0`` and ``SmaSpineChain-v0``; each spine carries its own layout
tables (``kw``, ``km``), which depend on the episode's (possibly randomised) parameters.
"""

from __future__ import annotations

import math

import numba

from ._deal import counter, take
from ._jit import jit, pjit
from .columns import ERR_NONFINITE, OK
from .planar.record import record
from .planar.solver import advance
from .spatial.solver import advance_in as spatial_advance_in
from .spatial.solver import make_work, sizes
from .spatial.solver import record as spatial_record


@jit
def step_spine(state, backup, kp, ks, v_r, v_l, loads, resolve, dt, n_sub, meas):
    """Advance one spine by ``n_sub`` physics steps of ``dt`` and record it; returns its status.

    Args:
        state: (S,) model state, advanced in place (handed back at its start value if a step fails).
        backup: (S,) scratch; receives the state before the step.
        kp, ks: the spine's constants and the solver options.
        v_r, v_l: voltages held over the control period [V].
        loads: (N, 2) vertex forces held over the control period [N].
        resolve: the loads differ from those of the last mechanical solve.
        dt: physics step [s]; the control period is ``n_sub * dt``.
        n_sub: physics steps per control period.
        meas: (planar.record.OUT_SIZE,) out; :func:`planar.record.record` after the step (of the restored
            state if the step failed).

    Returns:
        ``columns`` status code: OK or the first failure.
    """
    status = OK
    for q in range(state.shape[0]):
        backup[q] = state[q]
    for j in range(n_sub):
        st, _, _ = advance(state, kp, ks, v_r, v_l, loads, dt, resolve and j == 0)
        if st != OK:
            status = st
            for q in range(state.shape[0]):
                state[q] = backup[q]
            break
    record(state, kp, meas)
    return status


def _step_many(states, backup, kps, ks, v_r, v_l, loads, resolve, active, dt, n_sub, status, meas):
    """:func:`step_spine` of every active spine (row i of each (B, ...) argument).

    Args:
        states: (B, S) model states, advanced in place.
        backup: (B, S) scratch.
        kps: (B, KP_SIZE) constants (one row per spine, for domain randomisation).
        ks: solver options.
        v_r, v_l: (B,) voltages held over the control period [V].
        loads: (B, N, 2) vertex forces held over the control period [N].
        resolve: (B,) bool, the loads differ from those of the last mechanical solve.
        active: (B,) bool, spines to advance (others are left untouched).
        dt: physics step [s]; the control period is ``n_sub * dt``.
        n_sub: physics steps per control period.
        status: (B,) int64 out; ``columns`` status code of the step (OK or the first failure).
        meas: (B, planar.record.OUT_SIZE) out; :func:`planar.record.record` of each active spine after
            the step.
    """
    todo = counter()
    for _slot in numba.prange(states.shape[0]):  # rows dealt out one at a time (._deal)
        i = take(todo, states.shape[0])
        while i >= 0:
            if active[i]:
                status[i] = step_spine(
                    states[i], backup[i], kps[i], ks, v_r[i], v_l[i], loads[i], resolve[i], dt, n_sub, meas[i]
                )
            i = take(todo, states.shape[0])


step_many = pjit(_step_many)
step_many_serial = jit(_step_many)


@jit
def record_many(states, kps, rows, meas):
    """:func:`planar.record.record` of the spines ``rows`` (int array) into ``meas[rows]``."""
    for k in range(rows.shape[0]):
        i = rows[k]
        record(states[i], kps[i], meas[i])


@jit
def _all_finite(x):
    for q in range(x.shape[0]):
        if not math.isfinite(x[q]):
            return False
    return True


@jit
def step_spine_spatial(state, backup, kp, ks, kw, km, volts, loads, resolve, dt, n_sub, rec):
    """:func:`step_spine` for a spatial or chained spine (:func:`spatial.solver.advance_in`, SPATIAL.md).

    Args as :func:`step_spine`, except: ``kw`` (W, KW_SIZE) and ``km`` (K, KM_SIZE) the spine's
    layout tables (they depend on the episode's parameters); ``volts`` (W,) [V]; ``loads`` (N, 3)
    global x/y/z vertex forces [N]; ``rec`` (record_size,) out, the :func:`spatial.solver.record`
    row after the step.

    A physics step that reports OK but leaves a non-finite state counts as failed (ERR_NONFINITE,
    rolled back): the spatial core can let a NaN through in rare steps of extreme drive under load
    (found by the env's fuzz test), and the env must never hand one out.
    """
    status = OK
    for q in range(state.shape[0]):
        backup[q] = state[q]
    nw, nm, ns = sizes(kw, km)
    wk = make_work(nw, nm, ns)  # once per spine and env step, shared by its sub-steps and record
    for j in range(n_sub):
        st, _, _ = spatial_advance_in(state, kp, ks, kw, km, volts, loads, dt, resolve and j == 0, wk)
        if st == OK and not _all_finite(state):
            st = ERR_NONFINITE
        if st != OK:
            status = st
            for q in range(state.shape[0]):
                state[q] = backup[q]
            break
    spatial_record(state, kp, kw, km, wk, rec)
    return status


def _step_many_spatial(
    states, backup, kps, ks, kws, kms, volts, loads, resolve, active, dt, n_sub, status, rec
):
    """:func:`step_spine_spatial` of every active spine (args as :func:`_step_many`, except ``kws``
    (B, W, KW_SIZE), ``kms`` (B, K, KM_SIZE), ``volts`` (B, W) [V], ``loads`` (B, N, 3) and ``rec``
    (B, record_size) out)."""
    todo = counter()
    for _slot in numba.prange(states.shape[0]):  # rows dealt out one at a time (._deal)
        i = take(todo, states.shape[0])
        while i >= 0:
            if active[i]:
                status[i] = step_spine_spatial(
                    states[i],
                    backup[i],
                    kps[i],
                    ks,
                    kws[i],
                    kms[i],
                    volts[i],
                    loads[i],
                    resolve[i],
                    dt,
                    n_sub,
                    rec[i],
                )
            i = take(todo, states.shape[0])


step_many_spatial = pjit(_step_many_spatial)
step_many_spatial_serial = jit(_step_many_spatial)


@jit
def record_many_spatial(states, kps, kws, kms, rows, rec):
    """:func:`spatial.solver.record` of the spatial spines ``rows`` into ``rec[rows]``."""
    for k in range(rows.shape[0]):
        i = rows[k]
        nw, nm, ns = sizes(kws[i], kms[i])
        spatial_record(states[i], kps[i], kws[i], kms[i], make_work(nw, nm, ns), rec[i])
