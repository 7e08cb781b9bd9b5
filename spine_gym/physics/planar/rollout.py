"""Many open-loop rollouts of one planar spine from one start state: the predictor of sampling MPC.

Nothing here adds an equation. Every rollout copies the start state and is advanced control step by
control step with :func:`.integrate.advance`, ``n_sub`` physics steps of ``dt`` per control step
and the mechanics re-solved on the first physics step of a control step whose loads changed —
exactly the loop of :func:`.control.step_spine`, so a rollout of the env's state with the env's
voltages and loads gives the env's trajectory bit for bit (tested). What a rollout records per
control step is what a controller's cost needs: the bending angle Θ [rad], both wire temperatures
[K] and both wires' accumulated Joule heat per unit volume [J/m^3] (the env's energy accounting,
:mod:`spine_gym.envs.readout`). A rollout whose step fails (``columns`` status != OK) keeps its
last valid values for the rest of the horizon and reports the status
(:mod:`spine_gym.physics.rollout_rows`), so the caller can reject it.

One loop serves every rollout (:func:`_rollout_steps`, over a step array: step h is ``n_sub``
physics steps of ``dts[h]``), compiled twice, so that the serial twin the tests compare the
parallel loop with (tests/controllers/test_mpc.py) runs the same code: :data:`rollout_many` runs
the rollouts in parallel with ``prange`` (dealt out to the threads one at a time,
:mod:`spine_gym.physics._deal`: sampled voltage sequences differ in cost), every step the env's
physics step; :data:`rollout_many_serial` is the serial twin; :data:`rollout_graded` is the serial
loop on steps of their own lengths (a move-blocked plan). The spatial twin is
:mod:`spine_gym.physics.spatial.rollout`.
"""

from __future__ import annotations

import numba
import numpy as np

from .._deal import counter, take
from .._jit import jit, pjit
from ..columns import OK
from ..rollout_rows import HOLD, RECORD, record_source
from .columns import X_HEAD, X_QJL, X_QJR, X_TL, X_TR
from .integrate import advance

__all__ = ["rollout_many", "rollout_many_serial", "rollout_graded"]


@jit
def _record_row(st, n, angle, temp, joule, h):
    """Θ, both temperatures and both Joule heats of the state ``st`` into row ``h``."""
    theta = 0.0
    for q in range(n):
        theta += st[X_HEAD + q]
    angle[h] = theta
    temp[h, 0] = st[X_TR]
    temp[h, 1] = st[X_TL]
    joule[h, 0] = st[X_QJR]
    joule[h, 1] = st[X_QJL]


def _rollout_steps(
    state0, kp, ks, v_r, v_l, loads, resolve, dts, n_sub, work, angle, temp, joule, status
):
    """Roll ``B`` copies of ``state0`` over ``H`` steps of ``n_sub × dts[h]`` s with their own voltages.

    The one loop of every planar rollout: step h is ``n_sub`` physics steps of ``dts[h]`` seconds
    (the adaptive sub-steps of :func:`.integrate.advance` inside each), the mechanics re-solved on
    the first physics step of a step h with ``resolve[h]``; one row recorded per step h.

    Args:
        state0: (S,) start state (not modified).
        kp, ks: constants and solver options.
        v_r, v_l: (B, H) voltages held over step h [V].
        loads: (H, N, 2) vertex forces held over step h [N] (shared by every rollout).
        resolve: (H,) bool, the loads of step h differ from those of the last mechanical solve
            (for h = 0: from the loads ``state0`` was solved under).
        dts: (H,) physics step of step h [s], each > 0; n_sub: physics steps per step.
        work: (B, S) scratch, row b receives rollout b's state (its final state on return).
        angle: (B, H) out, Θ [rad] after each step.
        temp: (B, H, 2) out, right and left wire temperature [K] after each step.
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
                            st, kp, ks, v_r[i, h], v_l[i, h], loads[h], dts[h], resolve[h] and j == 0
                        )
                        if code != OK:
                            status[i] = code
                            break
                src = record_source(status[i], h)
                if src == HOLD:
                    angle[i, h] = angle[i, h - 1]
                    temp[i, h, :] = temp[i, h - 1, :]
                    joule[i, h, :] = joule[i, h - 1, :]
                elif src == RECORD:
                    _record_row(st, n, angle[i], temp[i], joule[i], h)
                else:
                    _record_row(state0, n, angle[i], temp[i], joule[i], h)
            i = take(todo, b)


_rollout_steps_parallel = pjit(_rollout_steps)
_rollout_steps_serial = jit(_rollout_steps)


@jit
def rollout_many(state0, kp, ks, v_r, v_l, loads, resolve, dt, n_sub, work, angle, temp, joule, status):
    """Roll ``B`` copies of ``state0`` over ``H`` control steps with their own voltage sequences,
    the rows in parallel (``prange``).

    :func:`_rollout_steps` with every control step ``n_sub`` physics steps of ``dt`` [s] (the env's
    step loop); the arguments as there, ``dt`` the one physics step. :data:`rollout_many_serial`
    is its serial twin.
    """
    dts = np.full(v_r.shape[1], dt)
    _rollout_steps_parallel(
        state0, kp, ks, v_r, v_l, loads, resolve, dts, n_sub, work, angle, temp, joule, status
    )


@jit
def rollout_many_serial(
    state0, kp, ks, v_r, v_l, loads, resolve, dt, n_sub, work, angle, temp, joule, status
):
    """:data:`rollout_many` with the rows one after the other (the same loop, serial)."""
    dts = np.full(v_r.shape[1], dt)
    _rollout_steps_serial(
        state0, kp, ks, v_r, v_l, loads, resolve, dts, n_sub, work, angle, temp, joule, status
    )


@jit
def rollout_graded(state0, kp, ks, v_r, v_l, loads, dts, work, angle, temp, joule, status):
    """Roll ``B`` copies of ``state0`` over ``H`` steps of their own lengths ``dts`` (a move-blocked plan).

    :func:`_rollout_steps` (serial) with one physics step of ``dts[h]`` seconds per recorded step h
    (the adaptive sub-steps of :func:`.integrate.advance` inside it), the loads of step 0
    re-solved at the start and then held: the long-horizon planner's predictor
    (:mod:`spine_gym.controllers.mpc_long`), whose steps are voltage blocks of a second or so.

    Args:
        state0: (S,) start state (not modified).
        kp, ks: constants and solver options.
        v_r, v_l: (B, H) voltages held over step h [V].
        loads: (N, 2) vertex forces held over the whole horizon [N].
        dts: (H,) step lengths [s], each > 0.
        work, angle, temp, joule, status: as :data:`rollout_many_serial`.
    """
    horizon = v_r.shape[1]
    held = np.empty((horizon, loads.shape[0], loads.shape[1]))
    for h in range(horizon):
        held[h, :, :] = loads
    resolve = np.zeros(horizon, dtype=np.bool_)
    resolve[:1] = True
    _rollout_steps_serial(
        state0, kp, ks, v_r, v_l, held, resolve, dts, 1, work, angle, temp, joule, status
    )
