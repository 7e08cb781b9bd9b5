"""Per-wire pieces of the coupled (linearly implicit) phase step, shared by both cores (MODEL.md §6.5).

The planar core (:mod:`.planar.substep`, two wires) and the spatial core (:mod:`.spatial.substep`, any
number of wires) build the same step from these: the kinetics F of §3.5, the quiet-step test, the
matrix of the linearly implicit Euler step of all wires' fractions (coupled through the composite
equilibrium's dσ/dx), the heating rate of §3.9 for the error estimate and the step-size factor of
the error control, and the error control's first try and accept/retry decision of a sub-step.
Rates and slopes come from :func:`.sma.rates_and_slopes` as (W, 12) rows. ``SECANT_MIN_DM`` is the
smallest moment change over a step from which both cores refresh their secant sensitivity.
"""

from __future__ import annotations

import math

from ._jit import hot
from .columns import K_ASV, K_RHOC, K_TE
from .sma import latent_heats, resistivity

SECANT_MIN_DM = 1e-6  # [N m] smallest moment change used to refresh the sensitivity s
X_ACTIVE = 1e-6  # a phase with fraction above this takes part in the step-size rule (§6.1 b)
STEP_GROW = 4.0  # largest factor by which the coupled scheme's error control lengthens a sub-step
STEP_SHRINK = 0.2  # smallest factor by which it shortens one
QUIET_RH = 1e-9  # fastest active transition × sub-step below which the coupled step is the frozen one
# [K] temperature error that counts as much as an error of 1 in a fraction: 1 K moves the
# instability stresses by ≈ 7 MPa (§3.1), as much as ≈ 0.3 % of transformation of a clamped wire
T_PER_FRACTION = 370.0


@hot
def step_rate(xp, xm, ppA, pAp, pmA, pAm):
    """Fastest active transition of one wire (MODEL.md §6.1 b)."""
    r = 0.0
    if xp > X_ACTIVE and ppA > r:
        r = ppA
    if xm > X_ACTIVE and pmA > r:
        r = pmA
    if 1.0 - xp - xm > X_ACTIVE and pAp + pAm > r:
        r = pAp + pAm
    return r


@hot
def kinetics(xp, xm, r):
    """dx₊/dt, dx₋/dt of MODEL.md §3.5 for the rates r[0:4] = (p₊A, p_A₊, p₋A, p_A₋)."""
    xa = 1.0 - xp - xm
    return -r[0] * xp + r[1] * xa, -r[2] * xm + r[3] * xa


@hot
def quiet(x0, rt, h):
    """True when no active phase of any wire transforms noticeably over h (rate · h <= QUIET_RH).

    ``x0`` holds (x₊, x₋) of every wire in turn, ``rt`` (W, 12) their rates and slopes. Then the
    rates, and their slopes with them (∂p/∂σ = −λ p ∂ΔG/∂σ), are so small that the coupling terms
    of :func:`linear_system` are below round-off: the frozen-rate implicit Euler step of §6.1 c is
    the same step, at a fraction of the cost (no sensitivity, no linear solve).
    """
    r = 0.0
    for w in range(rt.shape[0]):
        i = 2 * w
        r = max(r, step_rate(x0[i], x0[i + 1], rt[w, 0], rt[w, 1], rt[w, 2], rt[w, 3]))
    return r * h <= QUIET_RH


@hot
def linear_system(xs, rt, sens, h, a_t, b_t, amat, rhs):
    """Matrix and right-hand side of the linearly implicit Euler step of all wires' fractions.

    With F the phase kinetics §3.5 of the W wires, the implicit Euler step Δx = h F(x + Δx, σ', T')
    is linearised at the start of the sub-step: σ' = σ + S Δx (S = ``sens`` (W, 2W), the composite
    equilibrium's dσ/dx) and T'_w = T_w + a_t[w] + b_t[w] · Δx_w (the discrete heat balance).
    Then (I − h ∂F/∂x − h ∂F/∂σ S − h ∂F/∂T b_t) Δx = h (F + ∂F/∂T a_t), written into ``amat``
    (2W, 2W) and ``rhs`` (2W); ``xs`` holds (x₊, x₋) of every wire, ``rt`` (W, 12) each wire's
    rates and slopes (:func:`.sma.rates_and_slopes`).
    """
    n = amat.shape[0]
    for i in range(n):
        for j in range(n):
            amat[i, j] = 1.0 if i == j else 0.0
    for w in range(rt.shape[0]):
        i = 2 * w
        xp = xs[i]
        xm = xs[i + 1]
        xa = 1.0 - xp - xm
        r = rt[w]
        fs_p = -r[4] * xp + r[5] * xa  # ∂F/∂σ
        fs_m = -r[6] * xm + r[7] * xa
        ft_p = -r[8] * xp + r[9] * xa  # ∂F/∂T
        ft_m = -r[10] * xm + r[11] * xa
        amat[i, i] += h * (r[0] + r[1])
        amat[i, i + 1] += h * r[1]
        amat[i + 1, i] += h * r[3]
        amat[i + 1, i + 1] += h * (r[2] + r[3])
        for c in range(n):
            amat[i, c] -= h * fs_p * sens[w, c]
            amat[i + 1, c] -= h * fs_m * sens[w, c]
        for c in range(2):
            amat[i, i + c] -= h * ft_p * b_t[w, c]
            amat[i + 1, i + c] -= h * ft_m * b_t[w, c]
        rhs[i] = h * (-r[0] * xp + r[1] * xa + ft_p * a_t[w])
        rhs[i + 1] = h * (-r[2] * xm + r[3] * xa + ft_m * a_t[w])


@hot
def heating_rate(t, xp, xm, fp, fm, sigma, j_num, kp):
    """dT/dt of the heat balance §3.9 [K/s] for kinetics (fp, fm) = dx±/dt."""
    lp, lm = latent_heats(sigma, kp)
    j = j_num / resistivity(xp, xm, kp)
    return (j - kp[K_ASV] * (t - kp[K_TE]) + lp * fp + lm * fm) / kp[K_RHOC]


@hot
def heat_terms(t, sigma, xp, xm, j_num, h, kp):
    """(a, b₊, b₋) of the linearised discrete heat balance T' = T + a + b · Δx (MODEL.md §6.5)."""
    inv = 1.0 / (kp[K_RHOC] + h * kp[K_ASV])
    j = j_num / resistivity(xp, xm, kp)
    lp, lm = latent_heats(sigma, kp)
    return h * (j + kp[K_ASV] * (kp[K_TE] - t)) * inv, lp * inv, lm * inv


@hot
def step_factor(err):
    """Factor h_next / h of the error control for err = local error / tol_x: 0.9 err^−½ in
    [STEP_SHRINK, STEP_GROW]."""
    return min(STEP_GROW, max(STEP_SHRINK, 0.9 / math.sqrt(max(err, 1e-12))))


@hot
def first_try(h_proposed, rem, h_max):
    """The sub-step the coupled scheme tries first: the error control's last proposal (kept in the
    state; none yet: ``rem``, what is left of the output step), at most h_max."""
    h = h_proposed
    if not h > 0.0:
        h = rem
    return min(h, h_max)


@hot
def accept_or_retry(err, hh, h, h_min):
    """The error control's decision on a tried sub-step ``hh`` (``h`` before it was clipped to the
    output step), err = local error / tol_x (MODEL.md §6.5).

    Returns:
        (True, the next sub-step proposed: hh · :func:`step_factor`, kept at h if hh was only
        truncated at the end of the output step) if err <= 1 or hh is already h_min, else
        (False, the shorter sub-step to retry, >= h_min).
    """
    fac = step_factor(err)
    if err <= 1.0 or hh <= h_min:
        h_next = hh * fac
        if hh < h:  # truncated at the end of the output step: keep the larger proposal
            h_next = max(h_next, h)
        return True, h_next
    return False, max(hh * min(fac, 0.5), h_min)


@hot
def copy_rows(dst, src):
    """dst[:, :] = src for (W, 12) rate rows (an explicit loop: cheaper than a 2-D slice assignment,
    which an NRT-free kernel cannot lower anyway); both cores keep an accepted step's end rates so."""
    for j in range(src.shape[0]):
        for q in range(src.shape[1]):
            dst[j, q] = src[j, q]
