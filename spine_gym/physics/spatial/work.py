"""State views and work arrays of one spatial spine: its sizes (W, K, N), the views of M_w, ω and S
and of the per-wire blocks into the state (:mod:`.columns`; all blocks at once, by name:
:data:`WireBlocks`), and the preallocated work tuple (WK_* order) of :func:`make_work`, so that no
kernel allocates inside the sub-step loop.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .._jit import hot, jit
from ..columns import KP_SIZE
from .columns import (
    F_EPS,
    F_QC,
    F_QJ,
    F_QL,
    F_SIG,
    F_T,
    F_XM,
    F_XP,
    M_NSEG,
    moment_offset,
    omega_offset,
    sens_offset,
    wire_offset,
)
from .stability import stability_work


@jit
def sizes(kw, km):
    """(W, K, N): wire groups, modules, segments."""
    n = 0
    for k in range(km.shape[0]):
        n += int(km[k, M_NSEG])
    return kw.shape[0], km.shape[0], n


@jit
def views(state, nw, nm, ns):
    """(M_w (K, 2), ω (N, 2), S (2N, 2K)) as views into the state."""
    mo = moment_offset(nw)
    oo = omega_offset(nw, nm)
    so = sens_offset(nw, nm, ns)
    return (
        state[mo : mo + 2 * nm].reshape((nm, 2)),
        state[oo : oo + 2 * ns].reshape((ns, 2)),
        state[so : so + 4 * ns * nm].reshape((2 * ns, 2 * nm)),
    )


@jit
def wire_block(state, field, nw):
    """View of the per-wire block ``field`` (F_*) of the state."""
    o = wire_offset(field, nw)
    return state[o : o + nw]


# the state's per-wire blocks by name (views, F_* order): fractions x+ and x-, temperature [K],
# stress [Pa], strain, accumulated Joule heat, convective loss and latent heat [J/m^3]
WireBlocks = namedtuple("WireBlocks", "xp xm temp sig eps qj qc ql")


@jit
def wire_blocks(state, nw):
    """Every per-wire block of the state, as :data:`WireBlocks` of views."""
    return WireBlocks(
        wire_block(state, F_XP, nw),
        wire_block(state, F_XM, nw),
        wire_block(state, F_T, nw),
        wire_block(state, F_SIG, nw),
        wire_block(state, F_EPS, nw),
        wire_block(state, F_QJ, nw),
        wire_block(state, F_QC, nw),
        wire_block(state, F_QL, nw),
    )


# indices of the work tuple of make_work
(
    WK_FRAMES,  # (N + 1, 3, 3) section frames
    WK_CHORDS,  # (N, 3) chords
    WK_NEW,  # (N, 2) new ω of a shape pass
    WK_SAVED_W,  # (N, 2) saved ω
    WK_SUMS,  # (K, 3) chord sums of the wire lengths (spatial.tube.chord_sums)
    WK_EPS,  # (W,) strains
    WK_SIG,  # (W,) stresses
    WK_G,  # (K, 2) G(M)
    WK_JAC,  # (2K, 2K) Jacobian, then the Newton matrix
    WK_DM,  # (2K,) ΔM (the right-hand side G − M, solved in place)
    WK_MTRIAL,  # (K, 2) trial M
    WK_SAVED_M,  # (K, 2) saved M
    WK_WTRIAL,  # (N, 2) trial ω
    WK_RATES,  # (W, 4) rates
    WK_XNEW,  # (W, 2) new fractions
    WK_GAIN,  # (K, 2K, 3) sums of the loop gain (spatial.tube.gain_sums)
    # the coupled time step (MODEL.md §6.5; x and Δx ordered (x+, x-) of wire 0, wire 1, ...)
    WK_JNUM,  # (W,) U²/L0² of every wire [V²/m²] (Joule heating j = this / resistivity)
    WK_X0,  # (2W,) fractions at the start of the sub-step
    WK_XS,  # (2W,) fractions at its end
    WK_RT,  # (W, 12) rates and slopes at the start (sma.rates_and_slopes)
    WK_RT_NEW,  # (W, 12) rates and slopes at the end
    WK_DMDX,  # (2K, 2W) dM/dx of the composite equilibrium (the active wires' columns)
    WK_INV,  # (2K, 2K) (I − J)⁻¹
    WK_AT,  # (W,) temperature terms a of the linearised heat balance
    WK_BT,  # (W, 2) and b
    WK_ACT,  # (W + 1,) int: the wires in the linear system (_active_wires), their count last
    WK_XA,  # (2W,) their fractions (then the error's residuals)
    WK_RTA,  # (W, 12) their rates and slopes
    WK_SA,  # (W, 2W) their rows and columns of dσ/dx (stress_sensitivity)
    WK_LU,  # (2W, 2W) the step's matrix, then its LU factors
    WK_PIV,  # (2W,) int: their row exchanges
    WK_VEC,  # (2W,) right-hand side, solution
    WK_BACKUP,  # (omega_offset,) the state up to ω (time, wire blocks, M_w) at the sub-step's start
    # dense output: the recorded head of the state (up to S) at a sub-step's start, and interpolated
    WK_START,  # (sens_offset,)
    WK_MID,  # (sens_offset,)
    # the whole-shape Newton and the stability test
    WK_STEP,  # (2N,) Newton step on ω
    WK_STAB,  # the tuple of spatial.stability.stability_work
    WK_SAVED_S,  # (2N, 2K) S at the start of the fallbacks (restored if they fail)
    WK_KPW,  # (W, KP_SIZE) every wire's own material constants (:func:`wire_constants`)
) = range(39)


@jit
def make_work(nw, nm, ns):
    """Preallocated work arrays of one spine (no allocation inside the sub-step loop), WK_* order."""
    return (
        np.empty((ns + 1, 3, 3)),
        np.empty((ns, 3)),
        np.empty((ns, 2)),
        np.empty((ns, 2)),
        np.empty((nm, 3)),
        np.empty(nw),
        np.empty(nw),
        np.empty((nm, 2)),
        np.empty((2 * nm, 2 * nm)),
        np.empty(2 * nm),
        np.empty((nm, 2)),
        np.empty((nm, 2)),
        np.empty((ns, 2)),
        np.empty((nw, 4)),
        np.empty((nw, 2)),
        np.empty((nm, 2 * nm, 3)),
        np.empty(nw),
        np.empty(2 * nw),
        np.empty(2 * nw),
        np.empty((nw, 12)),
        np.empty((nw, 12)),
        np.empty((2 * nm, 2 * nw)),
        np.empty((2 * nm, 2 * nm)),
        np.empty(nw),
        np.empty((nw, 2)),
        np.zeros(nw + 1, dtype=np.int64),
        np.empty(2 * nw),
        np.empty((nw, 12)),
        np.empty((nw, 2 * nw)),
        np.empty((2 * nw, 2 * nw)),
        np.zeros(2 * nw, dtype=np.int64),
        np.empty(2 * nw),
        np.empty(omega_offset(nw, nm)),
        np.empty(sens_offset(nw, nm, ns)),
        np.empty(sens_offset(nw, nm, ns)),
        np.empty(2 * ns),
        stability_work(nw, nm, ns),
        np.empty((2 * ns, 2 * nm)),
        np.empty((nw, KP_SIZE)),
    )


@hot
def copy_pairs(dst, src):
    """dst[:, :] = src for (n, 2) arrays (an explicit loop: cheaper than a 2-D slice assignment)."""
    for i in range(src.shape[0]):
        dst[i, 0] = src[i, 0]
        dst[i, 1] = src[i, 1]
