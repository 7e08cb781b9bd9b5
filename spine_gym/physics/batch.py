"""Loops over many spines, compiled serial and parallel from one body (MODEL.md §6, STYLE.md).

The per-spine physics is :func:`spine_gym.physics.solver.advance`; nothing here repeats an
equation. ``run`` records one spine's trajectory (used by :func:`spine_gym.simulate`);
``advance_many`` steps a batch of spines by one control period (used by the vector environment and
the design sweeps), in parallel across cores with ``prange``.
"""

from __future__ import annotations

import numba
import numpy as np

from ._jit import jit, pjit
from .layout import OK, X_HEAD, X_ML, X_MR, X_PL, X_PR
from .sma import resistivity
from .solver import advance
from .tube import tip_position

# columns written by ``record`` after the state's head
OUT_ANGLE, OUT_RES_R, OUT_RES_L, OUT_TIP_X, OUT_TIP_Y = range(X_HEAD, X_HEAD + 5)
OUT_SIZE = X_HEAD + 5


@jit
def record(state, kp, row):
    """Write the state's head, Θ [rad], the wire resistivities [Ω m] and the tip position [m]."""
    n = (state.shape[0] - X_HEAD) // 2
    for i in range(X_HEAD):
        row[i] = state[i]
    dth = state[X_HEAD : X_HEAD + n]
    theta = 0.0
    for i in range(n):
        theta += dth[i]
    row[OUT_ANGLE] = theta
    row[OUT_RES_R] = resistivity(state[X_PR], state[X_MR], kp)
    row[OUT_RES_L] = resistivity(state[X_PL], state[X_ML], kp)
    tx, ty = tip_position(dth, kp)
    row[OUT_TIP_X] = tx
    row[OUT_TIP_Y] = ty


@jit
def run(state, kp, ks, v_r, v_l, loads, dt, out):
    """Integrate one spine over ``v_r.shape[0]`` output steps, recording every step.

    Args:
        state: initial state, advanced in place.
        v_r, v_l: (n,) voltages held over [t_k, t_k + dt) [V].
        loads: (n, N, 2) vertex forces over each step, or (1, N, 2) for constant loads [N].
        dt: output step [s].
        out: (n + 1, OUT_SIZE) record; row 0 is the initial state.

    Returns:
        (status, index of the failing step or n, total sub-steps, total shape passes).
    """
    n = v_r.shape[0]
    record(state, kp, out[0])
    nsub = 0
    npass = 0
    varying = loads.shape[0] > 1
    for k in range(n):
        vf = loads[k] if varying else loads[0]
        # the caller solved the mechanics for loads[0]; re-solve only when the loads change
        resolve = varying and k > 0 and not np.array_equal(loads[k], loads[k - 1])
        st, a, b = advance(state, kp, ks, v_r[k], v_l[k], vf, dt, resolve)
        nsub += a
        npass += b
        if st != OK:
            return st, k, nsub, npass
        record(state, kp, out[k + 1])
    return OK, n, nsub, npass


def _advance_many(states, kps, ks, v_r, v_l, loads, dt, n_steps, status):
    """Advance each spine i by ``n_steps`` output steps of ``dt``; status[i] gets the first failure.

    ``kps`` is (B, KP_SIZE) so that every spine may carry its own (randomised) constants. A failed
    spine is left at its failing state and skipped afterwards.
    """
    b = states.shape[0]
    for i in numba.prange(b):
        status[i] = OK
        for _ in range(n_steps):
            st, a, c = advance(states[i], kps[i], ks, v_r[i], v_l[i], loads[i], dt)
            if st != OK:
                status[i] = st
                break


advance_many = pjit(_advance_many)
advance_many_serial = jit(_advance_many)


def empty_record(n_steps: int) -> np.ndarray:
    """Allocate the output array of :func:`run`."""
    return np.empty((n_steps + 1, OUT_SIZE))
