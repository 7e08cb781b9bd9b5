"""One control period of one planar spine, as the envs step it (:func:`step_spine`), and the record
of spines between steps (:func:`record_many`).

Nothing here adds an equation: the spine is advanced with :func:`.integrate.advance` (the model's
own adaptive sub-steps inside every physics step ``dt``) and measured with :func:`.record.record`,
exactly as :func:`spine_gym.simulate` does. What the environments need on top is bookkeeping: a
backup so that a spine whose step fails is handed back at its last valid state (the env then
terminates with a status, never with NaN), and a ``resolve`` flag (solve the mechanics again only
when the loads changed since the last solve, as :func:`.run.run` does). The envs call
:func:`step_spine` from their one jitted call per step (:mod:`spine_gym.envs.step_kernels`:
inputs, physics, readings and bookkeeping together). The spatial twin is
:mod:`spine_gym.physics.spatial.control`.
"""

from __future__ import annotations

from .._jit import jit
from ..columns import OK
from .integrate import advance
from .record import record

__all__ = ["record_many", "step_spine"]


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
        meas: (record.OUT_SIZE,) out; :func:`.record.record` after the step (of the restored
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


@jit
def record_many(states, kps, rows, meas):
    """:func:`.record.record` of the spines ``rows`` (int array) into ``meas[rows]``."""
    for k in range(rows.shape[0]):
        i = rows[k]
        record(states[i], kps[i], meas[i])
