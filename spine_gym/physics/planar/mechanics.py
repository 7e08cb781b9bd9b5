"""Wire mechanics of one planar shape (MODEL.md §3.6, §4.4, §4.8): what the composite solve and the
coupled time step evaluate, with no iteration of their own.

For a shape Δθ and the phase fractions: the strains and stresses of both wires and the moment
G = n_w A_w a (σ_R − σ_L) they produce (:func:`wire_mechanics`), the loop gain dG/dM of the shape
response s = dΔθ/dM (:func:`moment_gain`, both in one pass: :func:`mechanics_and_gain`), and dσ/dx
of the composite equilibrium under fixed loads (:func:`stress_sensitivity`, the Jacobian of the
coupled step). The solve itself is :mod:`.composite`.
"""

from __future__ import annotations

from .._jit import hot
from ..columns import K_A, K_AW, K_EPST, K_KE, K_L0, K_LREF, K_LS, K_NSEG, K_NW
from ..sma import compliance, stress
from .tube import segment_lengths, wire_lengths


@hot
def wire_mechanics(dth, xpr, xmr, xpl, xml, kp):
    """Strains, stresses and the moment they produce, for a given shape (MODEL.md §3.6, §4.4, §4.8).

    Returns:
        (ε_R, ε_L, σ_R [Pa], σ_L [Pa], G = n_w A_w a (σ_R − σ_L) [N m]).
    """
    lr, ll = wire_lengths(dth, kp)
    return _wire_state(lr, ll, xpr, xmr, xpl, xml, kp)


@hot
def _wire_state(lr, ll, xpr, xmr, xpl, xml, kp):
    """(ε_R, ε_L, σ_R, σ_L, G) of :func:`wire_mechanics` from the wire lengths L_R, L_L [m]."""
    lref = kp[K_LREF]
    er = lr / lref - 1.0
    el = ll / lref - 1.0
    sr = stress(er, xpr, xmr, kp)
    sl = stress(el, xpl, xml, kp)
    return er, el, sr, sl, kp[K_NW] * kp[K_AW] * kp[K_A] * (sr - sl)


@hot
def mechanics_and_gain(dth, s, xpr, xmr, xpl, xml, kp):
    """:func:`wire_mechanics` and :func:`moment_gain` of one shape in one pass over its segments
    (the coupled Newton needs both every iteration; the same arithmetic, bit for bit).

    Returns:
        (ε_R, ε_L, σ_R, σ_L, G, dG/dM).
    """
    ls = kp[K_LS]
    a = kp[K_A]
    lr = kp[K_L0] - kp[K_NSEG] * ls
    ll = lr
    sum_c = 0.0
    sum_k = 0.0
    for i in range(dth.shape[0]):
        x = dth[i]
        dr, dl = segment_lengths(x, ls, a)
        lr += dr
        ll += dl
        pc, pk = _segment_response(x, s[i], ls, a)
        sum_c += pc
        sum_k += pk
    er, el, sr, sl, gm = _wire_state(lr, ll, xpr, xmr, xpl, xml, kp)
    gain = moment_gain(sum_c - sum_k, sum_c + sum_k, sr, sl, xpr, xmr, xpl, xml, kp)
    return er, el, sr, sl, gm, gain


@hot
def length_per_moment(dth, s, kp):
    """dL_R/dM and dL_L/dM [m/(N m)] of the shape response s = dΔθ/dM (MODEL.md §4.8).

    ∂L_R/∂Δθ_n = c'_n − a cos(Δθ_n/2), ∂L_L/∂Δθ_n = c'_n + a cos(Δθ_n/2), with the small-angle
    forms c' ≈ −ls Δθ/12 and cos ≈ 1 − Δθ²/8 (a Newton step or a Jacobian only needs ~1 %).
    """
    a = kp[K_A]
    ls = kp[K_LS]
    sum_c = 0.0
    sum_k = 0.0
    for i in range(dth.shape[0]):
        pc, pk = _segment_response(dth[i], s[i], ls, a)
        sum_c += pc
        sum_k += pk
    return sum_c - sum_k, sum_c + sum_k


@hot
def _segment_response(x, s_n, ls, a):
    """One segment's terms (c'_n s_n, a cos(Δθ_n/2) s_n) of :func:`length_per_moment`, small-angle forms."""
    return (-ls * x / 12.0) * s_n, a * (1.0 - x * x / 8.0) * s_n


@hot
def _taut_stiffness(sigma, xp, xm, kp):
    """Tangent modulus dσ/dε [Pa] of a wire for the Newton slopes: 1/compliance, 0 when slack."""
    return 1.0 / compliance(xp, xm, kp) if sigma > 0.0 else 0.0


@hot
def moment_gain(dl_r, dl_l, sr, sl, xpr, xmr, xpl, xml, kp):
    """dG/dM = Σ_n ∂G/∂Δθ_n s_n ≤ 0: how the wire moment answers a change of the applied moment.

    G = n_w A_w a (σ_R − σ_L) with dσ_w = E*_w dL_w / L_ref, from dL_R/dM and dL_L/dM of the shape
    response s (:func:`length_per_moment`, summed in :func:`mechanics_and_gain`); a slack wire
    (σ = 0) has zero tangent stiffness.
    """
    k_r = _taut_stiffness(sr, xpr, xmr, kp)
    k_l = _taut_stiffness(sl, xpl, xml, kp)
    pref = kp[K_NW] * kp[K_AW] * kp[K_A] / kp[K_LREF]
    return pref * (k_r * dl_r - k_l * dl_l)


@hot
def stress_sensitivity(dth, s, sr, sl, xpr, xmr, xpl, xml, kp, out):
    """dσ_w/dx of the composite equilibrium (§5) under fixed loads, written into ``out`` (2, 4).

    Rows: σ_R, σ_L; columns: x₊R, x₋R, x₊L, x₋L. At fixed strain the constitutive law §3.6 gives
    ∂σ/∂x₊ = −E* (ε_T + σ k_E) and ∂σ/∂x₋ = E* (ε_T − σ k_E) (E* = 1/compliance, 0 when slack);
    the moment then moves by dM = n_w A_w a (dσ_R − dσ_L)|_ε / (1 − dG/dM) and each strain by
    (dε_w/dM) dM (:func:`length_per_moment`). Used as the Jacobian of the coupled time step.
    """
    dl_r, dl_l = length_per_moment(dth, s, kp)
    e_r = dl_r / kp[K_LREF]
    e_l = dl_l / kp[K_LREF]
    k_r = _taut_stiffness(sr, xpr, xmr, kp)
    k_l = _taut_stiffness(sl, xpl, xml, kp)
    eps_t = kp[K_EPST]
    k_e = kp[K_KE]
    ar_p = -k_r * (eps_t + sr * k_e)
    ar_m = k_r * (eps_t - sr * k_e)
    al_p = -k_l * (eps_t + sl * k_e)
    al_m = k_l * (eps_t - sl * k_e)
    kg = kp[K_NW] * kp[K_AW] * kp[K_A]
    f = kg / (1.0 - kg * (k_r * e_r - k_l * e_l))
    cr = k_r * e_r * f
    cl = k_l * e_l * f
    out[0, 0] = ar_p * (1.0 + cr)
    out[0, 1] = ar_m * (1.0 + cr)
    out[0, 2] = -cr * al_p
    out[0, 3] = -cr * al_m
    out[1, 0] = cl * ar_p
    out[1, 1] = cl * ar_m
    out[1, 2] = al_p * (1.0 - cl)
    out[1, 3] = al_m * (1.0 - cl)
