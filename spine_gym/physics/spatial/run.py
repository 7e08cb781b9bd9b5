"""The recorded time loop of one spatial spine: :func:`run`, used by :func:`spine_gym.simulate`.

The per-spine physics is :func:`.integrate.advance_held_in`; nothing here repeats an equation. The envs
step their spines with :mod:`.control` instead.
"""

from __future__ import annotations

from .._jit import jit
from ..columns import OK
from ..dense import next_span, span_options, spans_outputs
from .integrate import advance_held_in
from .record import record
from .work import make_work, sizes


@jit
def run(state, kp, ks, kw, km, volts, loads, dt, out):
    """Integrate one spatial spine over ``volts.shape[0]`` output steps, recording every step.

    Consecutive output steps with equal inputs are one span of :func:`advance_held_in` (MODEL.md
    §6.5, :mod:`.dense`) unless the option ``dense_output`` is off, as :func:`planar.run.run`.

    Args:
        state: initial state, advanced in place.
        volts: (n, W) voltages held over [t_k, t_k + dt) [V].
        loads: (n, N, 3) vertex forces over each step, or (1, N, 3) for constant loads [N].
        dt: output step [s].
        out: (n + 1, record_size) record; row 0 is the initial state.

    Returns:
        (status, index of the failing step or n, total sub-steps, total shape passes).
    """
    nw, nm, ns = sizes(kw, km)
    wk = make_work(nw, nm, ns)
    n = volts.shape[0]
    record(state, kp, kw, km, wk, out[0])
    dense = spans_outputs(ks)
    ks_span = span_options(ks, dt)
    nsub = 0
    npass = 0
    k = 0
    while k < n:
        vf, resolve, m, kss = next_span(volts, loads, k, dense, ks, ks_span)
        st, done, a, b = advance_held_in(state, kp, kss, kw, km, volts[k], vf, dt, m, resolve, wk, out, k + 1)
        nsub += a
        npass += b
        if st != OK:
            return st, k + done, nsub, npass
        k += m
    return OK, n, nsub, npass
