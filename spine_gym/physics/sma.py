"""Müller–Achenbach–Seelecke (MAS) wire model, per unit volume (MODEL.md §3).

Pure jitted kernels: scalars and the constant array ``kp`` in, scalars out. Energies and stresses
are in J/m^3 ≡ Pa. Nothing here knows about the spine; the cores' ``substep`` modules couple it.
"""

from __future__ import annotations

import math

from ._jit import hot
from .columns import K_DETA, K_DSIG, K_DU, K_EA, K_EM, K_EPST, K_INVTAU, K_KE, K_LAMA, K_LAMM, K_LAMP, K_VLKB

EXP_CLAMP = 700.0  # MODEL.md §6.3.1: exp(-min(λΔG, 700)); never exp of a huge argument
SLACK_TOL = 1e-9  # [-] a wire within this strain of its stress-free length is at the slack threshold
SLOPE_DT = 1e-3  # [K] temperature step of the finite difference ∂ΔG/∂T in rates_and_slopes


@hot
def landscape(T, kp):
    """Temperature-dependent free-energy landscape (MODEL.md §3.1).

    Args:
        T: wire temperature [K].
        kp: kernel constants.

    Returns:
        (σ_A, σ_M, ε_A, ε_M, Δβ): instability stresses [Pa], branch strains [-], energy lift [J/m^3].
    """
    E_A = kp[K_EA]
    E_M = kp[K_EM]
    eps_T = kp[K_EPST]
    dsig = kp[K_DSIG]
    k_E = kp[K_KE]
    dbeta = kp[K_DU] - T * kp[K_DETA]
    B = 2.0 * eps_T - k_E * dsig
    C = 2.0 * dbeta - eps_T * dsig
    if C >= 0.0:
        # σ_A = −2C/(B + …) would be <= 0: low-temperature clamp (MODEL.md §3.1, §6.3.2). Testing C
        # first also avoids the negative discriminant that very low temperatures would give.
        sig_A = 0.0
        dbeta = 0.5 * eps_T * dsig
    else:
        # root of k_E s^2 + B s + C = 0 in its cancellation-free form (C < 0: real and positive)
        sig_A = -2.0 * C / (B + math.sqrt(B * B - 4.0 * k_E * C))
    sig_M = sig_A - dsig
    eps_A = sig_A / E_A
    eps_M = eps_T + sig_M / E_M
    return sig_A, sig_M, eps_A, eps_M, dbeta


@hot
def helmholtz(eps, E_A, E_M, eps_T, dsig, sig_A, eps_A, eps_M, dbeta):
    """Helmholtz free energy ψ(ε) of §3.2 (even in ε), in the numerically friendly branch form."""
    u = abs(eps)
    if u <= eps_A:
        return 0.5 * E_A * u * u + dbeta
    if u < eps_M:
        du = u - eps_A
        return 0.5 * E_A * eps_A * eps_A + dbeta + sig_A * du - dsig * du * du / (2.0 * (eps_M - eps_A))
    dm = u - eps_T
    return 0.5 * E_M * dm * dm


@hot
def barriers_and_slopes(sigma, T, kp):
    """Energy barriers of the Gibbs energy G = ψ − σε at stress σ (MODEL.md §3.3) and their σ-slopes.

    At every stationary point ε_i (interior, where ψ'(ε_i) = σ, or clamped, where ε_i does not move
    with σ) dG_i/dσ = −ε_i, so dΔG₊A/dσ = ε₅ − ε₄ and so on; a barrier clamped at 0 has slope 0.

    Returns:
        (ΔG₊A, ΔG_A₊, ΔG₋A, ΔG_A₋) [J/m^3], all >= 0, then their derivatives d/dσ [m^3/m^3 = -].
    """
    E_A = kp[K_EA]
    E_M = kp[K_EM]
    eps_T = kp[K_EPST]
    dsig = kp[K_DSIG]
    sig_A, sig_M, eps_A, eps_M, dbeta = landscape(T, kp)
    w = eps_M - eps_A
    e1 = min(-eps_T + sigma / E_M, -eps_M)
    e2 = min(max(-eps_A - (sigma + sig_A) * w / dsig, -eps_M), -eps_A)
    e3 = min(max(sigma / E_A, -eps_A), eps_A)
    e4 = min(max(eps_A + (sig_A - sigma) * w / dsig, eps_A), eps_M)
    e5 = max(eps_T + sigma / E_M, eps_M)
    g1 = helmholtz(e1, E_A, E_M, eps_T, dsig, sig_A, eps_A, eps_M, dbeta) - sigma * e1
    g2 = helmholtz(e2, E_A, E_M, eps_T, dsig, sig_A, eps_A, eps_M, dbeta) - sigma * e2
    g3 = helmholtz(e3, E_A, E_M, eps_T, dsig, sig_A, eps_A, eps_M, dbeta) - sigma * e3
    g4 = helmholtz(e4, E_A, E_M, eps_T, dsig, sig_A, eps_A, eps_M, dbeta) - sigma * e4
    g5 = helmholtz(e5, E_A, E_M, eps_T, dsig, sig_A, eps_A, eps_M, dbeta) - sigma * e5
    # roundoff must never make a barrier negative (MODEL.md §6.3.1)
    d_pa, d_ap, d_ma, d_am = g4 - g5, g4 - g3, g2 - g1, g2 - g3
    return (
        max(d_pa, 0.0),
        max(d_ap, 0.0),
        max(d_ma, 0.0),
        max(d_am, 0.0),
        e5 - e4 if d_pa > 0.0 else 0.0,
        e3 - e4 if d_ap > 0.0 else 0.0,
        e1 - e2 if d_ma > 0.0 else 0.0,
        e3 - e2 if d_am > 0.0 else 0.0,
    )


@hot
def barriers(sigma, T, kp):
    """Energy barriers of the Gibbs energy G = ψ − σε at stress σ (MODEL.md §3.3).

    Returns:
        (ΔG₊A, ΔG_A₊, ΔG₋A, ΔG_A₋) [J/m^3], all >= 0.
    """
    b = barriers_and_slopes(sigma, T, kp)
    return b[0], b[1], b[2], b[3]


@hot
def _rate(lam, dg, inv_tau):
    """τ⁻¹ exp(−min(λ ΔG, 700)) (MODEL.md §3.4, §6.3.1)."""
    return inv_tau * math.exp(-min(lam * dg, EXP_CLAMP))


@hot
def rates(sigma, T, kp):
    """Thermally activated transition probabilities (MODEL.md §3.4).

    Returns:
        (p₊A, p_A₊, p₋A, p_A₋) [1/s], each in [0, 1/τ].
    """
    dGpA, dGAp, dGmA, dGAm = barriers(sigma, T, kp)
    lam = kp[K_VLKB] / T
    inv_tau = kp[K_INVTAU]
    return (
        _rate(lam, dGpA, inv_tau),
        _rate(lam, dGAp, inv_tau),
        _rate(lam, dGmA, inv_tau),
        _rate(lam, dGAm, inv_tau),
    )


@hot
def rates_and_slopes(sigma, T, kp, out):
    """The four rates of :func:`rates` and their partial derivatives, written into ``out`` (12,).

    out[0:4] = (p₊A, p_A₊, p₋A, p_A₋) [1/s]; out[4:8] = ∂p/∂σ [1/(s Pa)]; out[8:12] = ∂p/∂T [1/(s K)].
    With p = τ⁻¹ exp(−λΔG), λ = V_L/(k_B T): ∂p/∂σ = −λ p ∂ΔG/∂σ and ∂p/∂T = −λ p (∂ΔG/∂T − ΔG/T);
    ∂ΔG/∂T is a forward difference over ``SLOPE_DT`` (only the linearly implicit step uses these
    slopes, as a Jacobian: its accuracy is checked by the step's error estimate, not assumed).
    """
    b = barriers_and_slopes(sigma, T, kp)
    bt = barriers(sigma, T + SLOPE_DT, kp)
    lam = kp[K_VLKB] / T
    inv_tau = kp[K_INVTAU]
    for k in range(4):
        p = _rate(lam, b[k], inv_tau)
        out[k] = p
        out[4 + k] = -lam * p * b[4 + k]
        out[8 + k] = -lam * p * ((bt[k] - b[k]) / SLOPE_DT - b[k] / T)


@hot
def latent_heats(sigma, kp):
    """Transformation enthalpies L± = h_A − h_M± (MODEL.md §3.8) [J/m^3], > 0 in the working range."""
    base = kp[K_DU] + 0.5 * kp[K_KE] * sigma * sigma
    se = sigma * kp[K_EPST]
    return base + se, base - se


@hot
def compliance(xp, xm, kp):
    """Phase-mixed compliance (x₊ + x₋)/E_M + x_A/E_A [1/Pa] of the constitutive law (§3.6)."""
    xa = 1.0 - xp - xm
    return (xp + xm) / kp[K_EM] + xa / kp[K_EA]


@hot
def stress(eps, xp, xm, kp):
    """Constitutive law with slack (MODEL.md §3.6): σ = max((ε − ε_T(x₊−x₋)) / compliance, 0) [Pa]."""
    s = (eps - kp[K_EPST] * (xp - xm)) / compliance(xp, xm, kp)
    return s if s > 0.0 else 0.0


@hot
def resistivity(xp, xm, kp):
    """Resistivity mixing ρ_e = λ_A x_A + λ_M₊ x₊ + λ_M₋ x₋ [Ω m] (MODEL.md §3.7)."""
    return kp[K_LAMA] * (1.0 - xp - xm) + kp[K_LAMP] * xp + kp[K_LAMM] * xm


@hot
def phase_step(xp, xm, h, ppA, pAp, pmA, pAm):
    """Implicit Euler of the phase kinetics §3.5 with rates frozen over h (MODEL.md §6.1 c).

    Solves the 2x2 system exactly (Cramer). (I − hK)^{-1} of a rate generator is non-negative, so
    the update is unconditionally stable and keeps the fractions in [0, 1] up to roundoff, which is
    clipped (§6.3.5).
    """
    a11 = 1.0 + h * (ppA + pAp)
    a12 = h * pAp
    a21 = h * pAm
    a22 = 1.0 + h * (pmA + pAm)
    b1 = xp + h * pAp
    b2 = xm + h * pAm
    det = a11 * a22 - a12 * a21
    return clip_fractions((b1 * a22 - a12 * b2) / det, (a11 * b2 - a21 * b1) / det)


@hot
def clip_fractions(xp, xm):
    """Fractions back into the simplex x₊, x₋ ∈ [0, 1], x₊ + x₋ <= 1 after roundoff (MODEL.md §6.3.5)."""
    xp = min(max(xp, 0.0), 1.0)
    xm = min(max(xm, 0.0), 1.0)
    s = xp + xm
    if s > 1.0:  # x_A would be a tiny negative
        xp /= s
        xm /= s
    return xp, xm
