"""Many open-loop rollouts of one spine from one start state: the predictor of sampling MPC.

Nothing here adds an equation. Every rollout copies the start state and is advanced control step by
control step with :func:`solver.advance`, ``n_sub`` physics steps of ``dt`` per control step and the
mechanics re-solved on the first physics step of a control step whose loads changed — exactly the
loop of :func:`env_kernels.step_many`, so a rollout of the env's state with the env's voltages and
loads gives the env's trajectory bit for bit (tested). What a rollout records per control step is
what a controller's cost needs: the bending angle Θ [rad], both wire temperatures [K] and both
wires' accumulated Joule heat per unit volume [J/m^3] (the env's energy accounting,
:mod:`spine_gym.envs._bookkeeping`). A rollout whose step fails (``layout`` status != OK) keeps its
last valid values for the rest of the horizon and reports the status, so the caller can reject it.

Compiled twice from one body (STYLE.md): ``rollout_many`` runs the rollouts in parallel with
``prange``; ``rollout_many_serial`` is the serial twin.
"""

from __future__ import annotations

import numba

from ._jit import jit, pjit
from .layout import OK, X_HEAD, X_QJL, X_QJR, X_TL, X_TR
from .solver import advance


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
    for i in numba.prange(b):
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
            if status[i] == OK:
                theta = 0.0
                for q in range(n):
                    theta += st[X_HEAD + q]
                angle[i, h] = theta
                temp[i, h, 0] = st[X_TR]
                temp[i, h, 1] = st[X_TL]
                joule[i, h, 0] = st[X_QJR]
                joule[i, h, 1] = st[X_QJL]
            elif h == 0:  # failed in the first step: report the start state
                theta = 0.0
                for q in range(n):
                    theta += state0[X_HEAD + q]
                angle[i, 0] = theta
                temp[i, 0, 0] = state0[X_TR]
                temp[i, 0, 1] = state0[X_TL]
                joule[i, 0, 0] = state0[X_QJR]
                joule[i, 0, 1] = state0[X_QJL]
            else:  # failed earlier: hold the last valid values
                angle[i, h] = angle[i, h - 1]
                temp[i, h, 0] = temp[i, h - 1, 0]
                temp[i, h, 1] = temp[i, h - 1, 1]
                joule[i, h, 0] = joule[i, h - 1, 0]
                joule[i, h, 1] = joule[i, h - 1, 1]


rollout_many = pjit(_rollout_many)
rollout_many_serial = jit(_rollout_many)
