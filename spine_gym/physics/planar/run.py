"""The recorded time loop of one planar spine (MODEL.md §6): :func:`run`, used by :func:`spine_gym.simulate`.

The per-spine physics is :func:`.integrate.advance_held`; nothing here repeats an equation. The envs
step their spines with :mod:`.control` instead.
"""

from __future__ import annotations

import numpy as np

from .._jit import jit
from ..columns import OK
from ..dense import next_span, span_options, spans_outputs
from .integrate import advance_held
from .record import OUT_SIZE, record

__all__ = ["empty_record", "run"]


@jit
def run(state, kp, ks, v_r, v_l, loads, dt, out):
    """Integrate one spine over ``v_r.shape[0]`` output steps, recording every step.

    Consecutive output steps with equal inputs are advanced as one span (:func:`.integrate.advance_held`,
    the sub-steps crossing their output points, the outputs in between interpolated: MODEL.md
    §6.5, :mod:`.dense`) unless the option ``dense_output`` is off; then every output step is one
    :func:`.integrate.advance`.

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
    k = 0
    while k < n:
        vf, resolve, m, kss = next_span(volts, loads, k, dense, ks, ks_span)
        st, done, a, b = advance_held(state, kp, kss, v_r[k], v_l[k], vf, dt, m, resolve, out, k + 1)
        nsub += a
        npass += b
        if st != OK:
            return st, k + done, nsub, npass
        k += m
    return OK, n, nsub, npass


def empty_record(n_steps: int) -> np.ndarray:
    """Allocate the output array of :func:`run`."""
    return np.empty((n_steps + 1, OUT_SIZE))
