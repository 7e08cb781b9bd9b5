"""Index constants of the arrays the spatial (wire- and module-generic) kernels take (SPATIAL.md).

Besides the material constants ``kp`` of :mod:`spine_gym.physics.columns` (only the material,
tube-stiffness and gravity entries are read) and the solver options ``ks``, the spatial kernels
take two tables
built by :meth:`spine_gym.layout.SpineLayout.to_kernel`:

* ``kw`` (W, KW_SIZE) — one row per wire group (n_w identical parallel wires in one pore);
* ``km`` (K, KM_SIZE) — one row per module, bottom (k = 0) to top (k = K − 1).

Segments are indexed like the planar core (MODEL.md §4.2): index 0 is the top segment, N − 1 the
bottom one; vertex j = 0 … N is the top vertex of segment j (P_0 the tip, P_N the clamped base).
Module k owns the contiguous segments ``km[k, KM_SEG0] … km[k, KM_SEG0] + km[k, KM_NSEG] − 1``.

The state of one spine is one flat float64 array (a batch of spines is a 2-D array):

    [time | x+ (W) | x- (W) | T (W) | σ (W) | ε (W) | Q_J (W) | Q_C (W) | Q_L (W)
     | M_w (K, 2) | ω (N, 2) | S = dω/dM_w (2N, 2K)
     | h_next | RATE_KP constants | per wire (σ, T, 12 rates and slopes) (W, 14)]

ω_n = (ω1, ω2) is segment n's bending rotation vector in the material axes (d1, d2) of its lower
section (SPATIAL.md §2), M_w,k module k's wire moment in material components (§3), and S the
secant sensitivity of the coupled Newton solve (§5). The tail belongs to the coupled time step
(MODEL.md §6.5), as the planar X_HNEXT and X_RCACHE: the sub-step its error control proposes next
(0: none yet) and each wire's rates at the end of the last sub-step, keyed by that wire's (σ, T)
and the constants they depend on, so that a continued run equals one run.

Per-wire material differences (a wire batch is never uniform): ``kw`` carries each wire's
resistivity scale, its Δu offset (a transformation-temperature shift s moves Δu by Δη·s, which
shifts σ_A(T), σ_M(T) by s along T at unchanged slope, MODEL.md §3.1) and its pre-strain. The
kernels evaluate each wire's rates, latent heats and Joule heating with its own constants.
"""

from __future__ import annotations

from .._jit import jit
from ..columns import RATE_KP

# ---------------------------------------------------------------- kw: wire-group table columns
(
    W_MOD,  # [-] module index k of the wire group (float)
    W_EX,  # [-] −sin ψ: material d1 component of the moment direction of a unit tension (§3)
    W_EY,  # [-] cos ψ: material d2 component
    W_A,  # [m] offset a of the pore from the tube axis
    W_NW,  # [-] parallel wires in the group (float)
    W_L0,  # [m] wire length, straight module
    W_LREF,  # [m] stress-free wire length L0/(1+ε0) of this wire's pre-strain
    W_LAMS,  # [-] resistivity scale of this wire (multiplies λ_A, λ_M of the material constants)
    W_DU,  # [J/m^3] offset of the internal-energy jump Δu: Δη · this wire's transformation-temperature shift
    W_EPS0,  # [-] pre-strain ε0 of this wire
    KW_SIZE,
) = range(11)

# ---------------------------------------------------------------- km: module table columns
(
    M_SEG0,  # [-] index of the module's top segment (segments are indexed top-down)
    M_NSEG,  # [-] segment count N_k (float)
    M_LS,  # [m] segment arc length
    M_MSEG,  # [kg] mass per segment
    M_MDISK,  # [kg] mass of the disk at the module's top (the top disk for k = K − 1)
    KM_SIZE,
) = range(6)

# ---------------------------------------------------------------- per-wire fields of the state
(
    F_XP,  # x+
    F_XM,  # x-
    F_T,  # [K] temperature
    F_SIG,  # [Pa] stress
    F_EPS,  # [-] strain
    F_QJ,  # [J/m^3] accumulated Joule heat per unit wire volume
    F_QC,  # [J/m^3] accumulated convective loss
    F_QL,  # [J/m^3] accumulated latent heat released into the wire
    N_WIRE_FIELDS,
) = range(9)

S_TIME = 0  # [s] model time
S_HEAD = 1  # the per-wire blocks start here


@jit
def wire_offset(field, n_wires):
    """Start of the per-wire block ``field`` (one of F_*) in the state."""
    return S_HEAD + field * n_wires


@jit
def moment_offset(n_wires):
    """Start of the module wire moments M_w (K × 2, row-major)."""
    return S_HEAD + N_WIRE_FIELDS * n_wires


@jit
def omega_offset(n_wires, n_mod):
    """Start of the segment rotation vectors ω (N × 2, row-major)."""
    return moment_offset(n_wires) + 2 * n_mod


@jit
def sens_offset(n_wires, n_mod, n_seg):
    """Start of the sensitivity S = dω/dM_w (2N × 2K, row-major)."""
    return omega_offset(n_wires, n_mod) + 2 * n_seg


# floats per wire of the rate cache: the key (σ, T, the wire's Δu offset), then the rates and slopes
RCACHE_WIRE = 3 + 12


@jit
def hnext_offset(n_wires, n_mod, n_seg):
    """Index of h_next [s], the coupled scheme's proposed next sub-step (the start of the tail)."""
    return sens_offset(n_wires, n_mod, n_seg) + 4 * n_seg * n_mod


@jit
def rate_key_offset(n_wires, n_mod, n_seg):
    """Start of the RATE_KP constants the cached rates were computed with."""
    return hnext_offset(n_wires, n_mod, n_seg) + 1


@jit
def rate_cache_offset(n_wires, n_mod, n_seg):
    """Start of the per-wire rate cache (W × RCACHE_WIRE, row-major)."""
    return rate_key_offset(n_wires, n_mod, n_seg) + len(RATE_KP)


def state_size(n_wires: int, n_mod: int, n_seg: int) -> int:
    """Length of the spatial state vector."""
    return rate_cache_offset(n_wires, n_mod, n_seg) + RCACHE_WIRE * n_wires
