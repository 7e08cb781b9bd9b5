"""Many open-loop rollouts of one spine from one start state: the predictor of sampling MPC.

Nothing here adds an equation. Every rollout copies the start state and is advanced control step by
control step with :func:`planar.solver.advance`, ``n_sub`` physics steps of ``dt`` per control step and the
mechanics re-solved on the first physics step of a control step whose loads changed — exactly the
loop of :func:`env_kernels.step_many`, so a rollout of the env's state with the env's voltages and
loads gives the env's trajectory bit for bit (tested). What a rollout records per control step is
what a controller's cost needs: the bending angle Θ [rad], both wire temperatures [K] and both
wires' accumulated Joule heat per unit volume [J/m^3] (the env's energy accounting,
:mod:`spine_gym.envs.readout`). A rollout whose step fails (``columns`` status != OK) keeps its
last valid values for the rest of the horizon and reports the status, so the caller can reject it.

Compiled twice from one body, so that the serial twin the tests compare the parallel loop with
(tests/controllers/test_mpc.py) runs the same code: ``rollout_many`` runs the rollouts in parallel with
``prange`` (dealt out to the threads one at a time, :mod:`._deal`: sampled voltage sequences
differ in cost); ``rollout_many_serial`` is the serial twin.

``rollout_many_spatial`` / ``rollout_many_spatial_serial`` are the same for a spatial or chained
spine (SPATIAL.md): every rollout is advanced with :func:`spatial.solver.advance`, exactly the loop
of :func:`env_kernels.step_many_spatial` (a physics step that reports OK but leaves a non-finite
state counts as failed, as there), and records after every control step the spine's
:func:`spatial.solver.record` row — the row the env's probe turns into its readings (tip bending,
tip position, temperatures, resistances, Joule heat), so the caller scores a rollout with the
env's own conversions.
"""

from __future__ import annotations

import numba
import numpy as np

from ._deal import counter, take
from ._jit import jit, pjit
from .columns import ERR_NONFINITE, OK
from .planar.columns import X_HEAD, X_QJL, X_QJR, X_TL, X_TR
from .planar.solver import advance
from .spatial.solver import advance_in as spatial_advance_in
from .spatial.solver import make_work, sizes
from .spatial.solver import record as spatial_record

RECORD, START, HOLD = 0, 1, 2  # what a rollout records after a control step (_record_source)


@jit
def _record_source(status, h):
    """What a rollout records after control step ``h``: RECORD its state (status OK), START its
    start state (it failed in the first step), HOLD its last valid row (it failed earlier)."""
    if status == OK:
        return RECORD
    return START if h == 0 else HOLD


@jit
def _record_planar(st, n, angle, temp, joule, h):
    """Θ, both temperatures and both Joule heats of the planar state ``st`` into row ``h``."""
    theta = 0.0
    for q in range(n):
        theta += st[X_HEAD + q]
    angle[h] = theta
    temp[h, 0] = st[X_TR]
    temp[h, 1] = st[X_TL]
    joule[h, 0] = st[X_QJR]
    joule[h, 1] = st[X_QJL]


def _rollout_many(state0, kp, ks, v_r, v_l, loads, resolve, dt, n_sub, work, angle, temp, joule, status):
    """Roll ``B`` copies of ``state0`` over ``H`` control steps with their own voltage sequences.

    Args:
        state0: (S,) start state (not modified).
        kp, ks: constants and solver options.
        v_r, v_l: (B, H) voltages held over control step h [V].
        loads: (H, N, 2) vertex forces held over control step h [N] (shared by every rollout).
        resolve: (H,) bool, the loads of step h differ from those of the last mechanical solve
            (for h = 0: from the loads ``state0`` was solved under).
        dt: physics step [s]; n_sub: physics steps per control step.
        work: (B, S) scratch, row b receives rollout b's state (its final state on return).
        angle: (B, H) out, Θ [rad] after each control step.
        temp: (B, H, 2) out, right and left wire temperature [K] after each control step.
        joule: (B, H, 2) out, accumulated Joule heat per unit volume [J/m^3] after each step.
        status: (B,) int64 out, OK or the first failure's status code.
    """
    b = v_r.shape[0]
    horizon = v_r.shape[1]
    s = state0.shape[0]
    n = (s - X_HEAD) // 2
    todo = counter()
    for _slot in numba.prange(b):  # rows dealt out one at a time (._deal)
        i = take(todo, b)
        while i >= 0:
            st = work[i]
            for q in range(s):
                st[q] = state0[q]
            status[i] = OK
            for h in range(horizon):
                if status[i] == OK:
                    for j in range(n_sub):
                        code, _, _ = advance(
                            st, kp, ks, v_r[i, h], v_l[i, h], loads[h], dt, resolve[h] and j == 0
                        )
                        if code != OK:
                            status[i] = code
                            break
                src = _record_source(status[i], h)
                if src == HOLD:
                    angle[i, h] = angle[i, h - 1]
                    temp[i, h, :] = temp[i, h - 1, :]
                    joule[i, h, :] = joule[i, h - 1, :]
                elif src == RECORD:
                    _record_planar(st, n, angle[i], temp[i], joule[i], h)
                else:
                    _record_planar(state0, n, angle[i], temp[i], joule[i], h)
            i = take(todo, b)


rollout_many = pjit(_rollout_many)
rollout_many_serial = jit(_rollout_many)


def _rollout_many_spatial(state0, kp, ks, kw, km, volts, loads, resolve, dt, n_sub, work, rec, status):
    """Roll ``B`` copies of the spatial ``state0`` over ``H`` control steps with their own voltages.

    Args:
        state0: (S,) spatial start state (:mod:`.spatial.columns`; not modified).
        kp, ks: constants and solver options; kw, km: the spine's wire-group and module tables.
        volts: (B, H, W) voltage on each wire group held over control step h [V].
        loads: (H, N, 3) global vertex forces held over control step h [N] (shared by every rollout).
        resolve: (H,) bool, the loads of step h differ from those of the last mechanical solve.
        dt: physics step [s]; n_sub: physics steps per control step.
        work: (B, S) scratch, row b receives rollout b's state (its final state on return).
        rec: (B, H, R) out, the :func:`spatial.solver.record` row after each control step
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
                        code, _, _ = spatial_advance_in(
                            st, kp, ks, kw, km, volts[i, h], loads[h], dt, resolve[h] and j == 0, wk
                        )
                        if code == OK and not np.all(np.isfinite(st)):
                            code = ERR_NONFINITE
                        if code != OK:
                            status[i] = code
                            break
                src = _record_source(status[i], h)
                if src == HOLD:
                    rec[i, h, :] = rec[i, h - 1, :]
                else:
                    if src == START:
                        for q in range(s):
                            st[q] = state0[q]
                    spatial_record(st, kp, kw, km, wk, rec[i, h])
            i = take(todo, b)


rollout_many_spatial = pjit(_rollout_many_spatial)
rollout_many_spatial_serial = jit(_rollout_many_spatial)
