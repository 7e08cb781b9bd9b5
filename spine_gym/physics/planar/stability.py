"""Stability of a planar equilibrium (MODEL.md §4.9 with §5), cf. :mod:`.spatial.stability`.

The planar shape is the fixed point Δθ = f(Δθ, G(Δθ)) of :func:`.tube.shape_pass` with the wire
moment G following the shape through the two wire lengths; :func:`.stability.unstable_modes` on the
(N × N) Jacobian of that map (:func:`equilibrium_jacobian`) decides whether a converged fixed point
is stable (see :mod:`.stability` for the criterion). :func:`.composite.composite` and the sub-step
kernels of :mod:`.composite` and :mod:`.integrate` call :func:`is_buckled_in` when :func:`needs_stability_check` (the
Dunkerley screen :func:`.tube.load_ratio`, O(N)) says the loads might buckle the bare tube.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import hot, jit
from ..columns import K_A, K_AW, K_EI, K_EPST, K_LREF, K_LS, K_NW
from ..sma import SLACK_TOL, compliance
from ..stability import BUCKLING_SCREEN, chord_slope, unstable_modes
from .tube import load_ratio, shape_jacobian, wire_lengths


@hot
def needs_stability_check(vforce, kp):
    """False when the loads cannot buckle the spine in any shape (Dunkerley screen, §4.9).

    The screen :func:`tube.load_ratio` is a lower bound for the bare tube (the wires only add
    stiffness); below ``BUCKLING_SCREEN`` the O(N³) stability test of :func:`.composite.composite` is skipped,
    so the unloaded and lightly loaded spine (the §10 runs, the env's default loads) pay nothing.
    """
    return load_ratio(vforce, kp) > BUCKLING_SCREEN


@hot
def _tangent_moduli(er, el, xpr, xmr, xpl, xml, kp):
    """Tangent moduli dσ/dε [Pa] of the right and left wire for the stability check (§3.6).

    A taut wire (ε above its stress-free strain ε_T (x₊ − x₋)) has 1/compliance, a slack one 0.
    A wire exactly at its stress-free strain (within ``SLACK_TOL``, e.g. the initial straight
    spine of §3.10) resists bending only in the direction that stretches it. If the other wire is
    taut or slack, the weaker direction is the one in which it does not count; if both sit at the
    threshold, each direction is resisted by one of them and the weaker is the softer wire.
    """
    ex_r = er - kp[K_EPST] * (xpr - xmr)
    ex_l = el - kp[K_EPST] * (xpl - xml)
    kr = 1.0 / compliance(xpr, xmr, kp) if ex_r > SLACK_TOL else 0.0
    kl = 1.0 / compliance(xpl, xml, kp) if ex_l > SLACK_TOL else 0.0
    if abs(ex_r) <= SLACK_TOL and abs(ex_l) <= SLACK_TOL:
        kr_t = 1.0 / compliance(xpr, xmr, kp)
        kl_t = 1.0 / compliance(xpl, xml, kp)
        if kr_t <= kl_t:
            kr = kr_t
        else:
            kl = kl_t
    return kr, kl


@hot
def equilibrium_jacobian(dth, xpr, xmr, xpl, xml, vforce, kp, jac):
    """Jacobian of the coupled shape map Δθ ↦ f(Δθ, G(Δθ)) (MODEL.md §4.9 with §5), into ``jac``.

    The tube part (wire moment fixed) is :func:`tube.shape_jacobian`. The wire moment G = n_w A_w a
    (σ_R − σ_L) follows the shape through the wire lengths (§4.8): ∂ε_R/∂Δθ_n = (c'_n − a cos(Δθ_n/2))
    / L_ref, ∂ε_L/∂Δθ_n = (c'_n + a cos(Δθ_n/2)) / L_ref, and enters every segment angle with
    ∂f_i/∂M_w = ls/(E I). A rank-one term: the wires stiffen the modes that turn the top disk.
    """
    shape_jacobian(dth, vforce, kp, jac)
    lr, ll = wire_lengths(dth, kp)
    lref = kp[K_LREF]
    kr, kl = _tangent_moduli(lr / lref - 1.0, ll / lref - 1.0, xpr, xmr, xpl, xml, kp)
    if kr == 0.0 and kl == 0.0:
        return
    a = kp[K_A]
    ls = kp[K_LS]
    pref = kp[K_NW] * kp[K_AW] * a / lref * ls / kp[K_EI]
    n = dth.shape[0]
    for j in range(n):
        cs = chord_slope(dth[j], ls)
        lever = a * math.cos(0.5 * dth[j])
        col = pref * (kr * (cs - lever) - kl * (cs + lever))
        for i in range(n):
            jac[i, j] += col


@jit
def is_buckled(dth, xpr, xmr, xpl, xml, vforce, kp):
    """True if the equilibrium ``dth`` under ``vforce`` is unstable (a load past buckling).

    See :mod:`.stability` for the criterion; O(N³), so callers screen with
    :func:`needs_stability_check` first.
    """
    n = dth.shape[0]
    return is_buckled_in(dth, xpr, xmr, xpl, xml, vforce, kp, np.empty((2, n, n)))


@hot
def is_buckled_in(dth, xpr, xmr, xpl, xml, vforce, kp, mats):
    """:func:`is_buckled` with the scratch ``mats`` (2, N, N) (no allocation: the sub-step kernels)."""
    equilibrium_jacobian(dth, xpr, xmr, xpl, xml, vforce, kp, mats[0])
    return unstable_modes(mats[0], mats[1]) > 0
