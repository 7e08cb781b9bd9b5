"""Stability of a spatial equilibrium (SPATIAL.md §8.3; MODEL.md §4.9 in 3-D), cf. :mod:`.planar.stability`.

The spatial shape is the fixed point ω = f(ω, G(ω)) of :func:`.tube.shape_pass` with the
module wire moments G following the shape through the wire lengths (SPATIAL.md §3–§4). As in the
plane, a converged fixed point can be an exact but unstable equilibrium (the straight column under
an axial load past buckling), and :func:`.stability.unstable_modes` on the (2N × 2N) Jacobian of
that map decides it. With the flexibility C = diag(ls_i/(E_t I)) (both angles of a segment share
it) the inertia argument of :mod:`.stability` holds unchanged.

The Jacobian has two parts:

* tube (wire moments fixed): central finite differences of the shape pass, 4N passes of O(N);
  it is affine in the moments, so any fixed M_w gives the same derivative;
* wires: ∂out_i/∂ω_l = (ls_i/(E_t I)) ∂G_k/∂ω_l for segment i in module k (the pass is linear in
  M_w with that coefficient), ∂G_k/∂ω_l = Σ_j n_w,j A_w a_j E_j e_j (∂L_j/∂ω_l)ᵀ / L_ref,j over the
  taut wires j of module k (E_j = 1/compliance), with the exact gradient of
  L_j = (L0 − N_k ls) + Σ_n f_n (ls − a_j e_j·ω_n).

Wires at their stress-free strain (the straight spine at rest, MODEL.md §3.10) resist bending
only in the directions u that stretch them (e_j·u < 0): the piecewise form
Q_k(u) = Σ_j d_j (e_j·u)² [e_j·u < 0], d_j = n_w,j A_w a_j² E_j / L_ref,j. It is bounded below by
the quadratic form Σ over antiparallel pairs (j, q) of such wires of min(d_j, d_q) (e_j·u)²
(whichever way u points, one wire of the pair is stretched); an unpaired one counts for nothing.
This is exact for the seed's four equal wires (Q isotropic) and is i14's planar rule of
:func:`planar.stability._tangent_moduli` in a planar layout: a threshold wire opposite a taut or slack one
adds nothing, two at the threshold add the softer one. "At the threshold" means a strain excess
over the stress-free strain within [−(SLACK_TOL + 2 s_k / L_ref), SLACK_TOL], s_k = Σ ls Δθ²/24 the
second-order shortening of the module's chords: a wire perpendicular to an in-plane bend goes
slack by exactly that much, and an out-of-plane sway of order s_k/a re-tightens it, so taking it
as slack would report a sideways mode of that negligible amplitude as buckling.

Cost: only runs when :func:`needs_stability_check` (a Dunkerley screen O(N)) says the loads
might buckle the bare tube, so unloaded runs pay one O(N) screen per output step.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import hot, jit
from ..columns import K_AW, K_EI, K_EPST, K_G
from ..sma import SLACK_TOL, compliance
from ..stability import BUCKLING_SCREEN, chord_slope, dunkerley_weight, unstable_modes
from .columns import M_LS, M_MDISK, M_MSEG, M_NSEG, M_SEG0, W_A, W_EX, W_EY, W_LREF, W_MOD, W_NW
from .tube import chord_sums, rot_coeffs, shape_pass, wire_length

FD_STEP = 1e-6  # [rad] central-difference step of the tube Jacobian (truncation ~1e-12, roundoff ~1e-10)
PAIR_TOL = 1e-9  # two wires of a module are antiparallel if their e vectors cancel to this


@jit
def load_ratio(vforce, kp, km):
    """Dunkerley screen of the loads on the bare tube (:func:`.stability.dunkerley_weight`), 3-D.

    Σ |F| h² · 4/(π² E_t I) over the vertex forces (with the disk at each module's top vertex)
    and the segment weights at their centres, h the arc length from the clamp. Below 1 the tube
    cannot buckle in any shape (cf. :func:`planar.tube.load_ratio`); O(N).
    """
    g = kp[K_G]
    s = 0.0
    h = 0.0  # arc length of the current vertex above the clamp, built bottom-up
    for k in range(km.shape[0]):
        seg0 = int(km[k, M_SEG0])
        ls = km[k, M_LS]
        w = km[k, M_MSEG] * g
        for i in range(seg0 + int(km[k, M_NSEG]) - 1, seg0 - 1, -1):
            hc = h + 0.5 * ls
            s += w * hc * hc
            h += ls
            fx = vforce[i, 0]
            fy = vforce[i, 1]
            fz = vforce[i, 2] - (km[k, M_MDISK] * g if i == seg0 else 0.0)
            if fx != 0.0 or fy != 0.0 or fz != 0.0:  # most vertices carry no load: no square root
                s += math.sqrt(fx * fx + fy * fy + fz * fz) * h * h
    return s * dunkerley_weight(kp[K_EI])


@jit
def needs_stability_check(vforce, kp, km):
    """False when the loads cannot buckle the spatial spine in any shape (cf. the planar solver's)."""
    return load_ratio(vforce, kp, km) > BUCKLING_SCREEN


@jit
def stability_work(nw, nm, ns):
    """Scratch of :func:`is_buckled_in` (allocated once, no allocation in the test):
    (mats (2, 2N, 2N), rows (3, N, 2), frames (N + 1, 3, 3), chords (N, 3), sums (K, 3),
    dg (2, 2N), wires (3, W), none (W,) bool, all False (no wire taken at its threshold: the
    plain test), at (W,) bool (the wires :func:`is_buckled_at` takes at their threshold))."""
    return (
        np.empty((2, 2 * ns, 2 * ns)),
        np.empty((3, ns, 2)),
        np.empty((ns + 1, 3, 3)),
        np.empty((ns, 3)),
        np.empty((nm, 3)),
        np.empty((2, 2 * ns)),
        np.empty((3, nw)),
        np.zeros(nw, dtype=np.bool_),
        np.zeros(nw, dtype=np.bool_),
    )


@hot
def tube_jacobian(omega, mw, vforce, kp, km, jac, rows, frames, chords):
    """∂ shape_pass / ∂ω at fixed wire moments by central differences, into ``jac`` (2N × 2N).

    Row/column 2i + b is component b of segment i. Scratch: ``rows`` (3, N, 2) (the passes at
    ω ± step, the perturbed ω), ``frames``, ``chords`` (of the passes).
    """
    n = omega.shape[0]
    plus = rows[0]
    minus = rows[1]
    trial = rows[2]
    for i in range(n):
        trial[i, 0] = omega[i, 0]
        trial[i, 1] = omega[i, 1]
    for c in range(2 * n):
        i = c // 2
        b = c % 2
        trial[i, b] = omega[i, b] + FD_STEP
        shape_pass(trial, mw, vforce, kp, km, frames, chords, plus)
        trial[i, b] = omega[i, b] - FD_STEP
        shape_pass(trial, mw, vforce, kp, km, frames, chords, minus)
        trial[i, b] = omega[i, b]
        for r in range(n):
            jac[2 * r, c] = (plus[r, 0] - minus[r, 0]) / (2.0 * FD_STEP)
            jac[2 * r + 1, c] = (plus[r, 1] - minus[r, 1]) / (2.0 * FD_STEP)


@jit
def length_gradient(w1, w2, ls, a, ex, ey):
    """Exact ∂ℓ/∂ω of one segment's share ℓ = f(Δθ) (ls − a e·ω) of a wire length (SPATIAL.md §4).

    ∂ℓ/∂ω = (f'/Δθ) (ls − a e·ω) ω − f a e, f = 2 sin(Δθ/2)/Δθ,
    f' = :func:`spine_gym.physics.stability.chord_slope` / ls.
    """
    th2 = w1 * w1 + w2 * w2
    th = math.sqrt(th2)
    fp_th = -(1.0 / 12.0 - th2 / 480.0) if th < 1e-2 else chord_slope(th, 1.0) / th
    f = rot_coeffs(th2)[2]
    lever = fp_th * (ls - a * (ex * w1 + ey * w2))
    return lever * w1 - f * a * ex, lever * w2 - f * a * ey


@jit
def chord_shortening(omega, seg0, nk, ls):
    """Σ_n ls Δθ_n²/24 over a module's segments [m]: the second-order shortening of its chords."""
    s = 0.0
    for i in range(seg0, seg0 + nk):
        s += omega[i, 0] ** 2 + omega[i, 1] ** 2
    return ls * s / 24.0


@hot
def add_wire_term(omega, xp, xm, kp, kw, km, jac, sums, dg, wires, at):
    """Add the wires' stiffening term of the coupled map to ``jac`` (see the module docstring).

    ``at`` (W,) bool: wires taken at their threshold whatever their strain (:func:`is_buckled_at`;
    all False for the plain test). Scratch: ``sums`` (K, 3) (chord sums), ``dg`` (2, 2N)
    (∂G_k/∂ω of the current module), ``wires`` (3, W) (the module's threshold wires: d_j, e_j).
    """
    nw = kw.shape[0]
    ns = omega.shape[0]
    ei = kp[K_EI]
    aw = kp[K_AW]
    chord_sums(omega, km, sums)
    d = wires[0]
    e1 = wires[1]
    e2 = wires[2]
    for k in range(km.shape[0]):
        seg0 = int(km[k, M_SEG0])
        nk = int(km[k, M_NSEG])
        ls = km[k, M_LS]
        short = chord_shortening(omega, seg0, nk, ls)
        for b in range(2):
            for c in range(2 * ns):
                dg[b, c] = 0.0
        m = 0
        for j in range(nw):
            if int(kw[j, W_MOD]) != k:
                continue
            lref = kw[j, W_LREF]
            ex_strain = wire_length(j, sums, kw, km) / lref - 1.0 - kp[K_EPST] * (xp[j] - xm[j])
            a = kw[j, W_A]
            ex = kw[j, W_EX]
            ey = kw[j, W_EY]
            stiff = kw[j, W_NW] * aw * a / (compliance(xp[j], xm[j], kp) * lref)
            if ex_strain > SLACK_TOL and not at[j]:  # taut: exact gradient
                for i in range(seg0, seg0 + nk):
                    g1, g2 = length_gradient(omega[i, 0], omega[i, 1], ls, a, ex, ey)
                    dg[0, 2 * i] += stiff * ex * g1
                    dg[0, 2 * i + 1] += stiff * ex * g2
                    dg[1, 2 * i] += stiff * ey * g1
                    dg[1, 2 * i + 1] += stiff * ey * g2
            elif at[j] or ex_strain >= -(SLACK_TOL + 2.0 * short / lref):  # at the threshold (see above)
                d[m] = stiff * a
                e1[m] = ex
                e2[m] = ey
                m += 1
        # threshold wires: each antiparallel pair counts min(d_j, d_q) e eᵀ (straight gradient −a e)
        for j in range(m):
            for q in range(j + 1, m):
                if abs(e1[j] + e1[q]) <= PAIR_TOL and abs(e2[j] + e2[q]) <= PAIR_TOL:
                    w = min(d[j], d[q])
                    for i in range(seg0, seg0 + nk):
                        dg[0, 2 * i] -= w * e1[j] * e1[j]
                        dg[0, 2 * i + 1] -= w * e1[j] * e2[j]
                        dg[1, 2 * i] -= w * e2[j] * e1[j]
                        dg[1, 2 * i + 1] -= w * e2[j] * e2[j]
        f = ls / ei
        for i in range(seg0, seg0 + nk):
            for b in range(2):
                for c in range(2 * ns):
                    jac[2 * i + b, c] += f * dg[b, c]


@jit
def is_buckled(omega, mw, xp, xm, vforce, kp, kw, km):
    """True if the spatial equilibrium ``omega`` under ``vforce`` is unstable (a load past buckling).

    O(N³) (the LU of :func:`.stability.unstable_modes`); callers screen with
    :func:`needs_stability_check` first. :func:`is_buckled_in` with its scratch allocated here.
    """
    return is_buckled_in(
        omega, mw, xp, xm, vforce, kp, kw, km, stability_work(kw.shape[0], km.shape[0], omega.shape[0])
    )


@hot
def is_buckled_in(omega, mw, xp, xm, vforce, kp, kw, km, work):
    """:func:`is_buckled` on the scratch ``work`` of :func:`stability_work` (no allocation)."""
    return is_buckled_at(omega, mw, xp, xm, vforce, kp, kw, km, work, work[7])


@hot
def is_buckled_at(omega, mw, xp, xm, vforce, kp, kw, km, work, at):
    """:func:`is_buckled_in` with the wires flagged in ``at`` (W,) taken at their threshold, taut
    or not: they resist bending only as antiparallel pairs (module docstring). With a taut wire
    about to go slack, this is the stability of the shape just past the slack kink (a wire at its
    threshold stretched by the shape keeps its tension, one slackened by it adds nothing)."""
    mats, rows, frames, chords, sums, dg, wires = work[0], work[1], work[2], work[3], work[4], work[5], work[6]
    tube_jacobian(omega, mw, vforce, kp, km, mats[0], rows, frames, chords)
    add_wire_term(omega, xp, xm, kp, kw, km, mats[0], sums, dg, wires, at)
    return unstable_modes(mats[0], mats[1]) > 0
