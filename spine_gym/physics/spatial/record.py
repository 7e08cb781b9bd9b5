"""The record row of one spatial spine: the state (without S) and the outputs derived from it.

One row per output step: the state's head, the module and tip bending vectors, the tip position and
frame, every wire's resistivity (:func:`record_size` columns). :func:`.run.run` and the dense output
of :func:`.integrate.advance_held_in` write it; the envs measure with it (:mod:`.control`).
"""

from __future__ import annotations

from .._jit import hot, jit
from ..sma import resistivity
from .columns import F_XM, F_XP, M_NSEG, M_SEG0, W_LAMS, omega_offset, sens_offset, wire_offset
from .tube import bending_vector, kinematics, tip_point
from .work import WK_CHORDS, WK_FRAMES, sizes


@jit
def record_size(nw, nm, ns):
    """Columns of one record row: the state without S, then the derived outputs of :func:`record`."""
    return sens_offset(nw, nm, ns) + 2 * nm + 2 + 3 + 9 + nw


@jit
def record(state, kp, kw, km, wk, row):
    """Write state (without S) | module bending vectors (K, 2) [rad] | tip bending vector (2) [rad]
    | tip position (3) [m] | tip frame (rows d1, d2, t) (9) | resistivity per wire (W) [Ω m]."""
    _record(state, kp, kw, km, wk[WK_FRAMES], wk[WK_CHORDS], row, row, False)


@hot
def _record(state, kp, kw, km, frames, chords, row, prev, reuse):
    """:func:`record` with its work arrays (frames, chords), as the time loop calls it.

    With ``reuse``, ``prev`` is an earlier record row: if its ω is bitwise this state's, the shape
    columns (bending vectors, tip position and frame: functions of ω alone) are copied from it
    instead of computed again (the same numbers; the spine at rest between transformations).
    Compiled without reference counting (:func:`._jit.hot`: 2 000 calls in the 20-s run), so it
    indexes the state instead of taking :func:`views` and :func:`wire_block`.
    """
    nw, nm, ns = sizes(kw, km)
    head = sens_offset(nw, nm, ns)
    for j in range(head):
        row[j] = state[j]
    oo = omega_offset(nw, nm)
    o = head + 2 * nm + 2 + 3 + 9  # after the shape columns
    if reuse and _same_span(row, prev, oo, head):
        for j in range(head, o):
            row[j] = prev[j]
    else:
        _record_shape(row[oo:head].reshape((ns, 2)), km, frames, chords, row[head:o])
    op = wire_offset(F_XP, nw)
    om = wire_offset(F_XM, nw)
    for j in range(nw):
        row[o + j] = resistivity(state[op + j], state[om + j], kp) * kw[j, W_LAMS]


@hot
def _same_span(a, b, lo, hi):
    """True if a[lo:hi] and b[lo:hi] are the same numbers."""
    for j in range(lo, hi):
        if a[j] != b[j]:
            return False
    return True


@hot
def _record_shape(omega, km, frames, chords, cols):
    """The shape columns of :func:`record` for the rotations ``omega`` into ``cols``: module
    bending vectors (K, 2), tip bending vector (2), tip position (3), tip frame (9)."""
    nm = km.shape[0]
    ns = omega.shape[0]
    kinematics(omega, km, frames, chords)
    t1, t2 = bending_vector(frames[ns], frames[0])
    for k in range(nm):
        seg0 = int(km[k, M_SEG0])
        top = seg0 + int(km[k, M_NSEG])
        if seg0 == 0 and top == ns:  # a single module: the tip's
            b1, b2 = t1, t2
        else:
            b1, b2 = bending_vector(frames[top], frames[seg0])
        cols[2 * k] = b1
        cols[2 * k + 1] = b2
    o = 2 * nm
    cols[o] = t1
    cols[o + 1] = t2
    o += 2
    cols[o], cols[o + 1], cols[o + 2] = tip_point(chords)
    o += 3
    for r in range(3):
        for c in range(3):
            cols[o + 3 * r + c] = frames[0, r, c]
