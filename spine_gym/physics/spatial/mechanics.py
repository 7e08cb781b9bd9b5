"""Wire mechanics of one spatial shape (MODEL.md §3.6, SPATIAL.md §3, §4): what the composite solve
and the coupled time step evaluate, with no iteration of their own.

For the rotations ω and every wire's fractions: the strains, the stresses and G(M), the wire moment
of every module (:func:`wire_mechanics`); the loop gain J = dG/dM = ∂G/∂ω · S (:func:`loop_gain`);
and dσ/dx of the composite equilibrium under fixed loads (:func:`stress_sensitivity`, the Jacobian
of the coupled step). The solve itself is :mod:`.composite`; the planar twins are
:mod:`spine_gym.physics.planar.mechanics`.
"""

from __future__ import annotations

import math

from .._jit import hot
from ..columns import K_AW, K_EPST, K_KE
from ..sma import compliance, stress
from ..stability import lu_factor, lu_solve
from .columns import W_A, W_EX, W_EY, W_LREF, W_MOD, W_NW
from .tube import chord_sums, gain_sums, length_slope, wire_length
from .work import WK_EPS, WK_G, WK_SIG, WK_SUMS


# The kernels called on every sub-step take the work arrays they use, not the work tuple: passing
# the 37-member work tuple down a call costs ~0.1-0.2 µs per call (its members are passed and
# reference-counted one by one), about as much as the arithmetic of a whole shape pass.
@hot
def wire_mechanics(omega, xp, xm, kp, kw, km, wk):
    """Strains, stresses (MODEL.md §3.6, SPATIAL.md §4) and G(M) (SPATIAL.md §3) of a shape.

    Writes wk[WK_EPS] = ε, wk[WK_SIG] = σ [Pa], wk[WK_G] = G = Σ_i n_w,i A_w σ_i a_i e_i per module [N m]
    (:func:`shape_mechanics` on the work tuple).
    """
    shape_mechanics(omega, xp, xm, kp, kw, km, wk[WK_SUMS], wk[WK_EPS], wk[WK_SIG], wk[WK_G])


@hot
def shape_mechanics(omega, xp, xm, kp, kw, km, sums, eps, sig, gm):
    """:func:`wire_mechanics` into the arrays ``sums`` (chord sums), ``eps``, ``sig`` and ``gm``."""
    chord_sums(omega, km, sums)
    for j in range(kw.shape[0]):
        eps[j] = wire_length(j, sums, kw, km) / kw[j, W_LREF] - 1.0
    strain_mechanics(xp, xm, kp, kw, eps, sig, gm)


@hot
def strain_mechanics(xp, xm, kp, kw, eps, sig, gm):
    """The second half of :func:`shape_mechanics`: ``sig`` and ``gm`` = G from the strains ``eps``
    (e.g. those of the last converged shape, when only the fractions changed since)."""
    for k in range(gm.shape[0]):
        gm[k, 0] = 0.0
        gm[k, 1] = 0.0
    aw = kp[K_AW]
    for j in range(kw.shape[0]):
        s = stress(eps[j], xp[j], xm[j], kp)
        sig[j] = s
        k = int(kw[j, W_MOD])
        t = kw[j, W_NW] * aw * s * kw[j, W_A]
        gm[k, 0] += t * kw[j, W_EX]
        gm[k, 1] += t * kw[j, W_EY]


@hot
def loop_gain(omega, sens, xp, xm, sig, kp, kw, km, jac, gs, sums_known=False):
    """J = dG/dM = ∂G/∂ω · S into ``jac`` (2K × 2K) at the stresses ``sig``; a slack wire (σ = 0)
    adds nothing.

    ∂L/∂ω · S of every wire from its module's sums ``gs`` (:func:`.tube.gain_sums`,
    :func:`.tube.length_slope`), computed here unless ``sums_known`` (they depend on ω and
    S only: the coupled step's dσ/dx computed them at the same ω and S).
    """
    ncol = jac.shape[1]
    for r in range(ncol):
        for c in range(ncol):
            jac[r, c] = 0.0
    if not sums_known:
        gain_sums(omega, sens, km, gs)
    aw = kp[K_AW]
    for j in range(kw.shape[0]):
        if sig[j] <= 0.0:
            continue
        k = int(kw[j, W_MOD])
        ex = kw[j, W_EX]
        ey = kw[j, W_EY]
        cw = kw[j, W_NW] * aw * kw[j, W_A] / (compliance(xp[j], xm[j], kp) * kw[j, W_LREF])
        for c in range(ncol):
            g = cw * length_slope(j, gs, c, kw, km)
            jac[2 * k, c] += ex * g
            jac[2 * k + 1, c] += ey * g


@hot
def stress_sensitivity(omega, sens, xp, xm, sig, kp, kw, km, act, na, jac, gs, inv, lu, piv, col, dmdx, sa):
    """dσ/dx of the composite equilibrium under fixed loads (MODEL.md §6.5), the rows and columns of
    the wires ``act[:na]`` only, into wk[WK_SA] (na, 2na): row a, columns 2b, 2b + 1 are ∂σ_{act[a]}
    over x₊, x₋ of wire act[b]. Work: the loop gain ``jac`` and its sums ``gs`` (2K × 2K, K × 2K × 3),
    ``inv`` = (I − J)⁻¹, ``lu`` (>= 2K × 2K), ``piv``, ``col`` (2K), ``dmdx`` (2K, >= 2 na).

    At fixed strain the constitutive law §3.6 gives ∂σ_j/∂x₊ = −E*_j (ε_T + σ_j k_E),
    ∂σ_j/∂x₋ = E*_j (ε_T − σ_j k_E) (E* = 1/compliance, 0 when slack), which moves G by
    dG_k = n_w A_w a_j e_j dσ_j|_ε (SPATIAL.md §3); the equilibrium M = G(M) then moves by
    dM = (I − J)⁻¹ dG|_ε (J = :func:`loop_gain`) and every stress by E*_i (dL_i/dM) dM / L_ref,i. The
    planar layout gives :func:`planar.mechanics.stress_sensitivity`. The other wires' rows and columns are
    not needed (:func:`_active_wires`); each entry is computed as over all wires.
    The loop-gain sums stay in wk[WK_GAIN] for the composite solve's first Newton step.
    """
    nm = km.shape[0]
    loop_gain(omega, sens, xp, xm, sig, kp, kw, km, jac, gs)  # J, and the length sums
    lu = lu[: 2 * nm, : 2 * nm]
    piv = piv[: 2 * nm]
    for r in range(2 * nm):
        for q in range(2 * nm):
            lu[r, q] = (1.0 if r == q else 0.0) - jac[r, q]
    if not _inverse(lu, piv, col, inv):
        return False
    eps_t = kp[K_EPST]
    k_e = kp[K_KE]
    aw = kp[K_AW]
    for b in range(na):
        j = act[b]
        d_p = 0.0
        d_m = 0.0
        if sig[j] > 0.0:
            e_star = 1.0 / compliance(xp[j], xm[j], kp)
            d_p = -e_star * (eps_t + sig[j] * k_e)
            d_m = e_star * (eps_t - sig[j] * k_e)
        k = int(kw[j, W_MOD])
        t = kw[j, W_NW] * aw * kw[j, W_A]
        for r in range(2 * nm):  # dM/dx_j = (I − J)⁻¹ dG/dx_j, dG_k = t e_j dσ_j
            f = inv[r, 2 * k] * kw[j, W_EX] + inv[r, 2 * k + 1] * kw[j, W_EY]
            dmdx[r, 2 * b] = 0.0 + t * f * d_p
            dmdx[r, 2 * b + 1] = 0.0 + t * f * d_m
        for a in range(na):  # its own (fixed-strain) column of its row
            sa[a, 2 * b] = d_p if act[a] == j else 0.0
            sa[a, 2 * b + 1] = d_m if act[a] == j else 0.0
    for a in range(na):
        i = act[a]
        if sig[i] <= 0.0:
            continue
        g = 1.0 / (compliance(xp[i], xm[i], kp) * kw[i, W_LREF])
        for r in range(2 * nm):
            dl = g * length_slope(i, gs, r, kw, km)
            if dl == 0.0:
                continue
            for c in range(2 * na):
                sa[a, c] += dl * dmdx[r, c]
    return True


@hot
def _inverse(a, piv, col, inv):
    """inv = a⁻¹ column by column (a overwritten: Cramer's rule for 2 × 2 as
    :func:`.stability.solve_in_place`, else one LU factorisation). Returns False if a is singular."""
    n = a.shape[0]
    if n == 2:
        det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        if det == 0.0 or not math.isfinite(det):
            return False
        inv[0, 0] = a[1, 1] / det
        inv[1, 0] = -a[1, 0] / det
        inv[0, 1] = -a[0, 1] / det
        inv[1, 1] = a[0, 0] / det
        return True
    if not lu_factor(a, piv):
        return False
    for c in range(n):
        for r in range(n):
            col[r] = 1.0 if r == c else 0.0
        lu_solve(a, piv, col[:n])
        for r in range(n):
            inv[r, c] = col[r]
    return True
