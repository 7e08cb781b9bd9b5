"""Loops over many spines, compiled serial and parallel from one body (MODEL.md §6, STYLE.md).

The per-spine physics is :func:`spine_gym.physics.planar.solver.advance`; nothing here repeats an
equation. ``run`` records one spine's trajectory (used by :func:`spine_gym.simulate`);
``advance_many`` steps a batch of spines by one control period (used by the vector environment and
the design sweeps), in parallel across cores with ``prange`` (the spines dealt out to the threads one
at a time, :mod:`._deal`).
"""

from __future__ import annotations

import numba
import numpy as np

from .._deal import counter, take
from .._jit import jit, pjit
from ..columns import OK
from ..dense import held_steps, span_options, spans_outputs
from .record import OUT_ANGLE, OUT_RES_L, OUT_RES_R, OUT_SIZE, OUT_TIP_X, OUT_TIP_Y, record
from .solver import advance, advance_held

__all__ = [
    "OUT_ANGLE",
    "OUT_RES_L",
    "OUT_RES_R",
    "OUT_SIZE",
    "OUT_TIP_X",
    "OUT_TIP_Y",
    "advance_many",
    "advance_many_serial",
    "empty_record",
    "record",
    "run",
]


@jit
def run(state, kp, ks, v_r, v_l, loads, dt, out):
    """Integrate one spine over ``v_r.shape[0]`` output steps, recording every step.

    Consecutive output steps with equal inputs are advanced as one span (:func:`.solver.advance_held`,
    the sub-steps crossing their output points, the outputs in between interpolated: MODEL.md
    §6.5, :mod:`.dense`) unless the option ``dense_output`` is off; then every output step is one
    :func:`.solver.advance`.

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
    volts = np.empty((n, 2))
    volts[:, 0] = v_r
    volts[:, 1] = v_l
    dense = spans_outputs(ks)
    ks_span = span_options(ks, dt)
    nsub = 0
    npass = 0
    varying = loads.shape[0] > 1
    k = 0
    while k < n:
        vf = loads[k] if varying else loads[0]
        # the caller solved the mechanics for loads[0]; re-solve only when the loads change
        resolve = varying and k > 0 and not np.array_equal(loads[k], loads[k - 1])
        m = held_steps(volts, loads, k) if dense else 1
        kss = ks_span if m > 1 else ks
        st, done, a, b = advance_held(state, kp, kss, v_r[k], v_l[k], vf, dt, m, resolve, out, k + 1)
        nsub += a
        npass += b
        if st != OK:
            return st, k + done, nsub, npass
        k += m
    return OK, n, nsub, npass


def _advance_many(states, kps, ks, v_r, v_l, loads, dt, n_steps, status):
    """Advance each spine i by ``n_steps`` output steps of ``dt``; status[i] gets the first failure.

    ``kps`` is (B, KP_SIZE) so that every spine may carry its own (randomised) constants. A failed
    spine is left at its failing state and skipped afterwards.
    """
    b = states.shape[0]
    todo = counter()
    for _slot in numba.prange(b):  # rows dealt out one at a time (._deal)
        i = take(todo, b)
        while i >= 0:
            status[i] = OK
            for _step in range(n_steps):
                st, a, c = advance(states[i], kps[i], ks, v_r[i], v_l[i], loads[i], dt)
                if st != OK:
                    status[i] = st
                    break
            i = take(todo, b)


advance_many = pjit(_advance_many)
advance_many_serial = jit(_advance_many)


def empty_record(n_steps: int) -> np.ndarray:
    """Allocate the output array of :func:`run`."""
    return np.empty((n_steps + 1, OUT_SIZE))
