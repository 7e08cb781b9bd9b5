"""Many open-loop rollouts of one spatial or chained spine from one start state: the predictor of
the spatial sampling MPC (SPATIAL.md), as :mod:`spine_gym.physics.planar.rollout`.

Every rollout is advanced with :func:`.integrate.advance_in`, exactly the loop of
:func:`.control.step_spine` (a physics step that reports OK but leaves a non-finite state counts
as failed, as there), and records after every control step the spine's :func:`.record.record`
row — the row the env's probe turns into its readings (tip bending, tip position, temperatures,
resistances, Joule heat), so the caller scores a rollout with the env's own conversions. A failed
rollout holds its last valid row (:mod:`spine_gym.physics.rollout_rows`). :data:`rollout_many`
runs the rollouts in parallel with ``prange``, :data:`rollout_many_serial` is its serial twin
(one body compiled twice).
"""

from __future__ import annotations

import numba
import numpy as np

from .._deal import counter, take
from .._jit import jit, pjit
from ..columns import ERR_NONFINITE, OK
from ..rollout_rows import HOLD, START, record_source
from .integrate import advance_in
from .record import record
from .work import make_work, sizes

__all__ = ["rollout_many", "rollout_many_serial"]


def _rollout_many(state0, kp, ks, kw, km, volts, loads, resolve, dt, n_sub, work, rec, status):
    """Roll ``B`` copies of the spatial ``state0`` over ``H`` control steps with their own voltages.

    Args:
        state0: (S,) spatial start state (:mod:`.columns`; not modified).
        kp, ks: constants and solver options; kw, km: the spine's wire-group and module tables.
        volts: (B, H, W) voltage on each wire group held over control step h [V].
        loads: (H, N, 3) global vertex forces held over control step h [N] (shared by every rollout).
        resolve: (H,) bool, the loads of step h differ from those of the last mechanical solve.
        dt: physics step [s]; n_sub: physics steps per control step.
        work: (B, S) scratch, row b receives rollout b's state (its final state on return).
        rec: (B, H, R) out, the :func:`.record.record` row after each control step
            (R = ``record_size``); a failed rollout holds its last valid row (the start state's
            if it failed in the first step).
        status: (B,) int64 out, OK or the first failure's status code.
    """
    b = volts.shape[0]
    horizon = volts.shape[1]
    s = state0.shape[0]
    nw, nm, ns = sizes(kw, km)
    todo = counter()
    for _slot in numba.prange(b):  # rows dealt out one at a time (._deal)
        i = take(todo, b)
        while i >= 0:
            st = work[i]
            wk = make_work(nw, nm, ns)
            for q in range(s):
                st[q] = state0[q]
            status[i] = OK
            for h in range(horizon):
                if status[i] == OK:
                    for j in range(n_sub):
                        code, _, _ = advance_in(
                            st, kp, ks, kw, km, volts[i, h], loads[h], dt, resolve[h] and j == 0, wk
                        )
                        if code == OK and not np.all(np.isfinite(st)):
                            code = ERR_NONFINITE
                        if code != OK:
                            status[i] = code
                            break
                src = record_source(status[i], h)
                if src == HOLD:
                    rec[i, h, :] = rec[i, h - 1, :]
                else:
                    if src == START:
                        for q in range(s):
                            st[q] = state0[q]
                    record(st, kp, kw, km, wk, rec[i, h])
            i = take(todo, b)


rollout_many = pjit(_rollout_many)
rollout_many_serial = jit(_rollout_many)
