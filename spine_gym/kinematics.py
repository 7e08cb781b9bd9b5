"""Constant-curvature kinematics of a chained spine: forward kinematics of arcs and the inverse
kinematics that the chain controllers use (numpy only).

A module whose sections all carry the same bending moment is a circular arc (SPATIAL.md §7.4:
gravity off, no tip load, the wire moment is a follower moment constant over the module). Its
**bending vector** b = (Θ cos β, Θ sin β) (SPATIAL.md §2: tip-tangent polar angle Θ from the
module's base tangent, azimuth β in the base frame) fixes the arc completely:

* displacement in the base frame: ``L ((1 − cos Θ)/Θ² b_x, (1 − cos Θ)/Θ² b_y, sin Θ / Θ)``;
* frame rotation: Rodrigues about the in-plane axis ω = (−b_y, b_x, 0) by Θ
  (``R = I + (sin Θ/Θ) [ω]× + ((1 − cos Θ)/Θ²) [ω]×²``), i.e. parallel transport without twist
  (the torsionally rigid tube of SPATIAL.md §1).

:func:`arc_chain_tip` composes the modules bottom to top (base at the origin, tangent +z, material
axes = global x, y). :func:`arc_chain_ik` inverts it for a target tip position. A chain of K
modules has 2K bending components for a 3-D target, so the inverse is chosen in a documented
two-parameter family: **every module bends in the vertical plane through the target** (azimuth
φ = atan2(y, x) of the target, signed in-plane angles), with the in-plane angles linear along the
chain, ``θ_k = p + q (k − (K − 1)/2)``. For K = 2 this is the exact two-link solution in that
plane (θ_0 = p − q/2, θ_1 = p + q/2); for K = 1 only p is free (a single arc reaches a surface,
the closest point is returned); for K > 2 the bends grow or shrink linearly along the chain. The
two parameters are found by damped Gauss–Newton (Levenberg–Marquardt) from the single-arc guess
``p = 2 atan2(r, z) / K``. The real spine sags under gravity and loads, so the model's modules are
not exact arcs; the controllers close the loop on each module's measured bending.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ArcIKResult", "arc_chain_ik", "arc_chain_tip", "arc_module"]

_SMALL = 1e-8  # [rad] below this the arc functions use their series (as MODEL.md §4.3)


def _arc_functions(theta: float) -> tuple[float, float]:
    """(sin Θ/Θ, (1 − cos Θ)/Θ²), with series below :data:`_SMALL`."""
    if theta < _SMALL:
        return 1.0 - theta * theta / 6.0, 0.5 - theta * theta / 24.0
    return math.sin(theta) / theta, (1.0 - math.cos(theta)) / (theta * theta)


def arc_module(bending: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Displacement (3,) [m] and rotation (3, 3) of one arc module in its base frame.

    Args:
        bending: bending vector (Θ cos β, Θ sin β) [rad].
        length: module bending length [m].
    """
    bx, by = float(bending[0]), float(bending[1])
    s1, c1 = _arc_functions(math.hypot(bx, by))
    disp = length * np.array([c1 * bx, c1 * by, s1])
    w = np.array([[0.0, 0.0, bx], [0.0, 0.0, by], [-bx, -by, 0.0]])  # [ω]× for ω = (−b_y, b_x, 0)
    return disp, np.eye(3) + s1 * w + c1 * (w @ w)


def _check_chain(bending, lengths) -> tuple[np.ndarray, np.ndarray]:
    b = np.asarray(bending, dtype=np.float64)
    ls = np.atleast_1d(np.asarray(lengths, dtype=np.float64))
    if b.ndim != 2 or b.shape[1] != 2 or b.shape[0] < 1:
        raise ValueError(f"bending must have shape (n_modules, 2) [rad], got {b.shape}")
    if ls.shape != (b.shape[0],):
        raise ValueError(f"lengths must have shape ({b.shape[0]},) (one per module), got {ls.shape}")
    if not (np.all(np.isfinite(b)) and np.all(np.isfinite(ls)) and np.all(ls > 0.0)):
        raise ValueError(f"bending must be finite and lengths finite and > 0 [m], got {b!r}, {ls!r}")
    return b, ls


def arc_chain_tip(bending, lengths) -> tuple[np.ndarray, np.ndarray]:
    """Tip position (3,) [m] and tip frame (3, 3) (columns d1, d2, t) of a chain of arcs.

    Args:
        bending: (K, 2) module bending vectors [rad], each in its module's base frame, bottom first.
        lengths: (K,) module bending lengths [m].

    Raises:
        ValueError: wrong shapes, non-finite values or a length <= 0.
    """
    b, ls = _check_chain(bending, lengths)
    pos, frame = np.zeros(3), np.eye(3)
    for bk, lk in zip(b, ls, strict=True):
        disp, rot = arc_module(bk, lk)
        pos = pos + frame @ disp
        frame = frame @ rot
    return pos, frame


@dataclass(frozen=True)
class ArcIKResult:
    """Solution of :func:`arc_chain_ik`.

    Attributes:
        bending: (K, 2) module bending vectors [rad] (bottom first).
        position: (3,) tip position they reach [m] (forward kinematics).
        error: distance from the target [m] (> 0 for a target outside the family's reach).
        iterations: Gauss–Newton iterations used.
    """

    bending: np.ndarray
    position: np.ndarray
    error: float
    iterations: int


def _family(pq: np.ndarray, s: np.ndarray, phi: float) -> np.ndarray:
    theta = pq[0] + pq[1] * s
    return np.stack([theta * math.cos(phi), theta * math.sin(phi)], axis=1)


def arc_chain_ik(target, lengths, *, tol: float = 1e-10, max_iter: int = 60) -> ArcIKResult:
    """Module bending vectors whose arcs put the tip at ``target`` (the family of the module docstring).

    Args:
        target: (3,) tip position [m] in the base frame (z up along the straight spine).
        lengths: (K,) module bending lengths [m], bottom first.
        tol: stop when the position error is below ``tol`` [m] or the step below tol / length.
        max_iter: Gauss–Newton iterations, >= 1.

    Returns:
        :class:`ArcIKResult` (the closest point of the family if the target is out of its reach).

    Raises:
        ValueError: a non-finite target, wrong shapes, lengths <= 0, bad tol / max_iter.
    """
    x = np.asarray(target, dtype=np.float64)
    if x.shape != (3,) or not np.all(np.isfinite(x)):
        raise ValueError(f"target must be a finite (3,) position [m], got {target!r}")
    _, ls = _check_chain(np.zeros((np.size(lengths), 2)), lengths)
    if not (isinstance(tol, int | float) and 0.0 < tol < 1.0):
        raise ValueError(f"tol must be in (0, 1) m, got {tol!r}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, int) or max_iter < 1:
        raise ValueError(f"max_iter must be an integer >= 1, got {max_iter!r}")
    k = ls.size
    s = np.arange(k) - 0.5 * (k - 1)
    phi = math.atan2(x[1], x[0])
    r = math.hypot(x[0], x[1])
    pq = np.array([2.0 * math.atan2(r, x[2]) / k, 0.0])
    lam = 1e-3

    def residual(v):
        return arc_chain_tip(_family(v, s, phi), ls)[0] - x

    res = residual(pq)
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 - the count is reported
        if np.linalg.norm(res) < tol:
            break
        h = 1e-7
        jac = np.stack([(residual(pq + h * e) - res) / h for e in np.eye(2)], axis=1)
        jtj, g = jac.T @ jac, jac.T @ res
        while True:
            step = -np.linalg.solve(jtj + lam * (np.diag(np.diag(jtj)) + 1e-12 * np.eye(2)), g)
            trial = residual(pq + step)
            if np.linalg.norm(trial) < np.linalg.norm(res) or lam > 1e8:
                break
            lam *= 10.0
        if np.linalg.norm(trial) < np.linalg.norm(res):
            pq, res, lam = pq + step, trial, max(lam / 10.0, 1e-9)
        if np.linalg.norm(step) < tol / ls.sum():
            break
    b = _family(pq, s, phi)
    pos = arc_chain_tip(b, ls)[0]
    return ArcIKResult(bending=b, position=pos, error=float(np.linalg.norm(pos - x)), iterations=it)
