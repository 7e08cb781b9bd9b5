"""Sub-steps across output steps whose inputs are held, with dense output (MODEL.md §6.5).

The time loops of both cores (:func:`.planar.run.run`, :func:`.spatial.run.run`) hand every run of
consecutive output steps with equal inputs (voltages and loads: the zero-order hold of
``simulate``) to one call of the core's span advance (:func:`.planar.integrate.advance_held`,
:func:`.spatial.integrate.advance_held_in`), so the error-controlled sub-steps are not cut at every
output point. An output that falls inside an accepted sub-step is recorded from the state linearly
interpolated between the sub-step's ends; one at a sub-step's end is that state itself. This
module holds the rule both drivers share: which output steps form a span (:func:`held_steps`, :func:`next_span`),
where an output falls in a sub-step (:func:`output_fraction`) and the interpolation
(:func:`interpolate`) and the sub-step cap of a span (:func:`span_options`: ``SolverOptions.dense_h_max``,
never below the output step). ``SolverOptions.dense_output`` switches it off (one call per output
step); a span of one output step is exactly that call. :func:`last_h` is where both cores end a
sub-step before the end of its output step (or span).

Linear interpolation is consistent with the scheme: within a sub-step the discrete heat balance
and the energy accumulators (§6.1 d–f) are linear in the elapsed fraction of the step, so the
balance ρc (T − T₀) = Q_J − Q_conv + Q_lat holds at the interpolated outputs as exactly as at the
sub-step ends.
"""

from __future__ import annotations

import numpy as np

from ._jit import hot, jit
from .columns import S_DENSE, S_HMAX, S_SCHEME, SCHEME_COUPLED

OUTPUT_TOL = 1e-9  # an output within this fraction of dt after a sub-step's end counts as at the end


@jit
def held_steps(volts, loads, k):
    """Number m >= 1 of output steps k … k + m − 1 with the inputs of step k.

    Args:
        volts: (n, W) voltages of each output step [V].
        loads: (n, N, d) vertex forces of each output step, or (1, N, d) for constant loads [N].
        k: first output step of the span.
    """
    n = volts.shape[0]
    varying = loads.shape[0] > 1
    m = 1
    while k + m < n:
        j = k + m
        for w in range(volts.shape[1]):
            if volts[j, w] != volts[k, w]:
                return m
        if varying and not np.array_equal(loads[j], loads[k]):
            return m
        m += 1
    return m


@jit
def next_span(volts, loads, k, dense, ks, ks_span):
    """The span of a recorded time loop that starts at output step k: (its loads, whether the
    mechanics must be solved again first, its output steps m, its solver options).

    The loads are ``loads[k]`` (``loads[0]`` for constant loads); the caller solved the mechanics
    for ``loads[0]``, so a re-solve is due only where the loads changed since step k − 1. With
    ``dense`` (:func:`spans_outputs`) the span is the run of held steps (:func:`held_steps`) and a
    span of two or more steps takes ``ks_span`` (:func:`span_options`), else one step with ``ks``.
    """
    varying = loads.shape[0] > 1
    vf = loads[k] if varying else loads[0]
    resolve = varying and k > 0 and not np.array_equal(loads[k], loads[k - 1])
    m = held_steps(volts, loads, k) if dense else 1
    return vf, resolve, m, (ks_span if m > 1 else ks)


@jit
def spans_outputs(ks):
    """True if the time loop hands runs of held output steps to one span call: ``dense_output``
    on (ks[S_DENSE] > 0) and the coupled scheme, whose error control chooses the sub-steps. The
    frozen scheme is MODEL.md §6.1 as written, per output step (and so is the fine reference)."""
    return ks[S_DENSE] > 0.0 and int(ks[S_SCHEME]) == SCHEME_COUPLED


@jit
def span_options(ks, dt):
    """The solver options of a span of two or more held output steps: ``h_max`` lowered to
    max(dt, ks[S_DENSE]) (``SolverOptions.dense_h_max``, never below the output step)."""
    out = ks.copy()
    out[S_HMAX] = min(ks[S_HMAX], max(dt, ks[S_DENSE]))
    return out


@hot
def output_fraction(j, n_out, dt, e0, e1, at_end):
    """Where output j (1 … n_out, at j·dt from the span's start) falls in the sub-step [e0, e1].

    Returns θ ∈ [0, 1] (the output's state is (1 − θ) · start + θ · end of the sub-step), or −1 if
    the output lies after the sub-step. The last output is the span's end, reached by the sub-step
    that ends the span (``at_end``); another output within OUTPUT_TOL · dt of e1 is at the end.
    """
    if j == n_out:
        return 1.0 if at_end else -1.0
    t = j * dt
    if t > e1 + OUTPUT_TOL * dt:
        return 1.0 if at_end else -1.0  # (at the span's end: round-off of e1)
    if t >= e1 - OUTPUT_TOL * dt:
        return 1.0
    return min(1.0, max(0.0, (t - e0) / (e1 - e0)))


@hot
def interpolate(start, end, theta, out):
    """out = start + θ (end − start), elementwise: a quantity that did not change over the sub-step
    (a wire at rest, Joule heat after switch-off) stays exactly what it was."""
    for i in range(out.shape[0]):
        out[i] = start[i] + theta * (end[i] - start[i])


@hot
def last_h(rem, dt, h):
    """Clip a proposed sub-step to what is left of the output step, without leaving a sliver."""
    if h > rem or rem - h < 1e-9 * dt:
        return rem
    return h
