"""One control period of one spatial or chained spine, as the envs step it (:func:`step_spine`),
and the record of spines between steps (:func:`record_many`); as :mod:`spine_gym.physics.planar.control`.

Nothing here adds an equation: the spine is advanced with :func:`.integrate.advance_in` and
measured with :func:`.record.record` (SPATIAL.md), with the planar core's bookkeeping (a backup
handed back if a step fails, a ``resolve`` flag). Used by ``SmaSpine3D-v0`` and
``SmaSpineChain-v0``; each spine carries its own layout tables (``kw``, ``km``), which depend on
the episode's (possibly randomised) parameters.
"""

from __future__ import annotations

import math

from .._jit import jit
from ..columns import ERR_NONFINITE, OK
from .integrate import advance_in
from .record import record
from .work import make_work, sizes

__all__ = ["record_many", "step_spine"]


@jit
def _all_finite(x):
    for q in range(x.shape[0]):
        if not math.isfinite(x[q]):
            return False
    return True


@jit
def step_spine(state, backup, kp, ks, kw, km, volts, loads, resolve, dt, n_sub, rec):
    """Advance one spine by ``n_sub`` physics steps of ``dt`` and record it; returns its status
    (as :func:`spine_gym.physics.planar.control.step_spine`).

    Args as the planar :func:`~spine_gym.physics.planar.control.step_spine`, except: ``kw``
    (W, KW_SIZE) and ``km`` (K, KM_SIZE) the spine's layout tables (they depend on the episode's
    parameters); ``volts`` (W,) [V]; ``loads`` (N, 3) global x/y/z vertex forces [N]; ``rec``
    (record_size,) out, the :func:`.record.record` row after the step.

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
        st, _, _ = advance_in(state, kp, ks, kw, km, volts, loads, dt, resolve and j == 0, wk)
        if st == OK and not _all_finite(state):
            st = ERR_NONFINITE
        if st != OK:
            status = st
            for q in range(state.shape[0]):
                state[q] = backup[q]
            break
    record(state, kp, kw, km, wk, rec)
    return status


@jit
def record_many(states, kps, kws, kms, rows, rec):
    """:func:`.record.record` of the spines ``rows`` into ``rec[rows]``."""
    for k in range(rows.shape[0]):
        i = rows[k]
        nw, nm, ns = sizes(kws[i], kms[i])
        record(states[i], kps[i], kws[i], kms[i], make_work(nw, nm, ns), rec[i])
