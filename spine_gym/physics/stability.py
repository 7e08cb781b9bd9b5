"""Stability of a quasi-static equilibrium of a segmented line (MODEL.md §4.9), generic kernels.

The shape of the spine is the fixed point Δθ = f(Δθ) of the shape map of §4.9 (with the wire
moment following the shape through the constitutive law, §5). A fixed point can be an exact but
*unstable* equilibrium: the straight spine under a downward tip force past buckling is one, and a
solver started on it returns it unchanged because nothing breaks the symmetry. Convergence alone
therefore says nothing about stability; these kernels decide it from the linearisation.

With J = ∂f/∂Δθ at the equilibrium, the tangent matrix A = I − J is, for the segmented line,
A = C·H with C = diag(ls/(E I)) > 0 (the flexibility that turns moments into angles, §4.7) and H
the tangent stiffness (bending stiffness minus the geometric stiffness of the loads plus the wire
stiffness). Because C is diagonal and positive, the leading principal minors of A and H have the
same signs, so the number of negative pivots of an unpivoted LU factorisation of A is the number
of negative eigenvalues of H (Sylvester's law of inertia): 0 means stable, >= 1 means the load is
past buckling. The check needs only J, so any segmented model (planar or spatial, with any
number of angles per segment) can use it.

:func:`dunkerley_weight` feeds a cheap, conservative screen: Dunkerley's lower bound on the
buckling load of a clamped column under point loads, used to skip the check where buckling is
impossible (both cores check above ``BUCKLING_SCREEN``). :func:`chord_slope` is the derivative
of a segment's chord both cores' stability Jacobians take.
"""

from __future__ import annotations

import math

from ._jit import hot

PIVOT_TOL = 1e-12  # |pivot| below this counts as singular (I − J has a unit diagonal scale)
BUCKLING_SCREEN = 0.9  # Dunkerley load ratio above which converged shapes are tested for stability


@hot
def unstable_modes(jac, work):
    """Number of unstable modes of the equilibrium whose fixed-point map has Jacobian ``jac``.

    Args:
        jac: (n, n) Jacobian ∂f/∂Δθ of the shape map at the equilibrium (any angle layout).
        work: (n, n) scratch, overwritten with the LU factors of I − J.

    Returns:
        The count of pivots of I − J that are <= 0 (a singular pivot counts: the critical load
        itself is not stable). 0 means the equilibrium is stable.
    """
    n = jac.shape[0]
    for i in range(n):
        for j in range(n):
            work[i, j] = (1.0 if i == j else 0.0) - jac[i, j]
    count = 0
    for k in range(n):
        p = work[k, k]
        if p <= PIVOT_TOL:
            count += 1
            if abs(p) <= PIVOT_TOL:  # go on with a tiny pivot of the same sign (inertia count)
                p = -PIVOT_TOL if p < 0.0 else PIVOT_TOL
                work[k, k] = p
        for i in range(k + 1, n):
            f = work[i, k] / p
            if f != 0.0:
                for j in range(k + 1, n):
                    work[i, j] -= f * work[k, j]
    return count


@hot
def dunkerley_weight(ei):
    """4 / (π² E I) [1/(N m²)]: a point load F at arc length h above the clamp of a clamped-free
    column of bending stiffness E I adds F h² · this to Dunkerley's sum (MODEL.md §4.9).

    F h² · 4/(π² E I) = F / P_cr(h), with P_cr(h) = π² E I / (4 h²) the Euler load of the column
    below the load (the part above carries no axial force). Over all loads of a column without
    wires the sum is a lower bound on the combined critical load factor: the column cannot buckle
    while it is below 1 (only the axial component of a force destabilises, and it is at most the
    magnitude). Self-weight spread as point loads at the segment centres gives q L³/(E I) = 3π²/4
    ≈ 7.40 against the exact 7.84 of §4.9.
    """
    return 4.0 / (math.pi * math.pi * ei)


@hot
def euler_critical_load(height, ei):
    """Euler load π² E I / (4 h²) [N] of a clamped-free column of length ``height`` [m] (§4.9)."""
    return 1.0 / (height * height * dunkerley_weight(ei))


@hot
def solve_in_place(a, b):
    """Solve a x = b by Gaussian elimination with partial pivoting; ``a`` is destroyed, x → ``b``.

    Small dense systems (one row per segment angle, or per wire-moment component) inside jitted
    code, without LAPACK; a 2 × 2 system (one spatial module's Newton step, every sub-step) by
    Cramer's rule.

    Returns:
        False if ``a`` is singular to working precision (``b`` then undefined), else True.
    """
    n = a.shape[0]
    if n == 2:
        det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        if det == 0.0 or not math.isfinite(det):
            return False
        x0 = (a[1, 1] * b[0] - a[0, 1] * b[1]) / det
        b[1] = (a[0, 0] * b[1] - a[1, 0] * b[0]) / det
        b[0] = x0
        return True
    for k in range(n):
        piv = _pivot_row(a, k)
        if piv < 0:
            return False
        if piv != k:
            _swap_rows(a, k, piv)
            t = b[k]
            b[k] = b[piv]
            b[piv] = t
        for i in range(k + 1, n):
            f = a[i, k] / a[k, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]
                b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        acc = b[k]
        for j in range(k + 1, n):
            acc -= a[k, j] * b[j]
        b[k] = acc / a[k, k]
    return True


@hot
def lu_factor(a, piv):
    """LU factorisation with partial pivoting of ``a`` in place (L below the diagonal, unit
    diagonal implied; U on and above), row exchanges into ``piv``: for one matrix and several
    right-hand sides (:func:`lu_solve`) where :func:`solve_in_place` would eliminate again.

    Returns:
        False if ``a`` is singular to working precision.
    """
    n = a.shape[0]
    for k in range(n):
        p = _pivot_row(a, k)
        if p < 0:
            return False
        piv[k] = p
        if p != k:
            _swap_rows(a, k, p)
        for i in range(k + 1, n):
            f = a[i, k] / a[k, k]
            a[i, k] = f
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]
    return True


@hot
def _pivot_row(a, k):
    """The row p >= k with the largest |a[p, k]| (the first of equals), or -1 if that is 0 or not
    finite (``a`` singular to working precision): the partial pivoting of both eliminations."""
    p = k
    big = abs(a[k, k])
    for i in range(k + 1, a.shape[0]):
        if abs(a[i, k]) > big:
            big = abs(a[i, k])
            p = i
    if big == 0.0 or not math.isfinite(big):
        return -1
    return p


@hot
def _swap_rows(a, k, p):
    """Exchange the whole rows k and p of ``a``."""
    for j in range(a.shape[1]):
        t = a[k, j]
        a[k, j] = a[p, j]
        a[p, j] = t


@hot
def lu_solve(lu, piv, b):
    """Solve a x = b in place (x → ``b``) with the factors of :func:`lu_factor`."""
    n = lu.shape[0]
    for k in range(n):  # P b (the exchanges swapped whole rows, multipliers included: P A = L U)
        p = piv[k]
        if p != k:
            t = b[k]
            b[k] = b[p]
            b[p] = t
    for k in range(n):
        for i in range(k + 1, n):
            b[i] -= lu[i, k] * b[k]
    for k in range(n - 1, -1, -1):
        acc = b[k]
        for j in range(k + 1, n):
            acc -= lu[k, j] * b[j]
        b[k] = acc / lu[k, k]


@hot
def chord_slope(dth, ls):
    """dc/dΔθ of the chord of §4.3 [m/rad] (series −ls(Δθ/12 − Δθ³/480) near 0, no cancellation)."""
    if abs(dth) < 1e-2:
        return -ls * dth * (1.0 / 12.0 - dth * dth / 480.0)
    h = 0.5 * dth
    return ls * (math.cos(h) / dth - 2.0 * math.sin(h) / (dth * dth))
