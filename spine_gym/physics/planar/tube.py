"""Segmented-line quasi-static bending of the tube (MODEL.md §4).

Segment n = 1 … N is stored at index n−1 (index 0 is the top segment, next to the top disk).
Vertex k = 0 … N is the ring centre P_k (P_0 the top-disk vertex, P_N the clamped base at (0, 0)).
Loads: ``vforce[k]`` is an external force (global x, y) [N] acting at vertex P_k, k = 0 … N−1;
``vforce[0]`` is the tip force. Gravity acts on each segment at its chord midpoint and on the
top disk at P_0. Angles are clockwise-positive, i.e. positive = bending toward +x (the right wire).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import hot, jit
from ..columns import ERR_SHAPE, K_A, K_EI, K_G, K_L0, K_LS, K_MSEG, K_MTOP, K_NSEG, OK
from ..stability import chord_slope, dunkerley_weight

SERIES_MAX = 0.3  # [rad] below this |angle| the sines and cosines of small angles are Taylor series
# Taylor coefficients (as multiplications: a division costs several times more, on the hot loop)
_S3, _S5, _S7, _S9, _S11 = -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0, -1.0 / 39916800.0
_C2, _C4, _C6, _C8, _C10, _C12 = (
    -0.5,
    1.0 / 24.0,
    -1.0 / 720.0,
    1.0 / 40320.0,
    -1.0 / 3628800.0,
    1.0 / 479001600.0,
)
# 2 sin(x/2)/x = Σ_k (−1)^k x^{2k} / (4^k (2k+1)!)
_K2, _K4, _K6, _K8, _K10 = -1.0 / 24.0, 1.0 / 1920.0, -1.0 / 322560.0, 1.0 / 92897280.0, -1.0 / 40874803200.0


@hot
def sincos_small(d):
    """(sin d, cos d), by their Taylor series for |d| <= SERIES_MAX (truncation < 1e-16) else libm.

    The segment angles and the angle steps between neighbouring segments are small; a polynomial
    costs a few multiplications where a libm call costs tens of nanoseconds, on the hottest loop.
    """
    if abs(d) > SERIES_MAX:
        return math.sin(d), math.cos(d)
    d2 = d * d
    sn = d + d * d2 * (_S3 + d2 * (_S5 + d2 * (_S7 + d2 * (_S9 + d2 * _S11))))
    cs = 1.0 + d2 * (_C2 + d2 * (_C4 + d2 * (_C6 + d2 * (_C8 + d2 * (_C10 + d2 * _C12)))))
    return sn, cs


@hot
def chord(dth, ls):
    """Chord length of an arc of length ls bent by dth [rad] (MODEL.md §4.3).

    2 ls sin(Δθ/2)/Δθ, by its series ls (1 − Δθ²/24 + Δθ⁴/1920 − …) for small angles (which also
    has no 0/0 at Δθ = 0).
    """
    if abs(dth) > 2.0 * SERIES_MAX:
        return 2.0 * ls / dth * math.sin(0.5 * dth)
    x2 = dth * dth
    return ls + ls * x2 * (_K2 + x2 * (_K4 + x2 * (_K6 + x2 * (_K8 + x2 * _K10))))


@hot
def shape_pass(dth, m_w, vforce, kp, out):
    """One pass of the iterative shape algorithm (MODEL.md §4.3–4.7).

    From the current angles ``dth`` (N,) compute inclinations and vertices bottom-up, then forces
    and moments top-down, and write the new segment angles into ``out`` (N,).

    Returns:
        max_n |out_n − dth_n| [rad].
    """
    n = dth.shape[0]
    ls = kp[K_LS]
    ei = kp[K_EI]
    g = kp[K_G]
    w_seg = kp[K_MSEG] * g
    # Inclination of segment n: φ_n = Σ_{k>n} Δθ_k + ½Δθ_n, the closed form of the bottom-up
    # recursion φ_N = ½Δθ_N, φ_n = φ_{n+1} + ½(Δθ_{n+1} + Δθ_n). Written top-down it lets one
    # loop build the chord vectors r_n = P_{n-1} − P_n and the moments without work arrays.
    # φ_{i+1} = φ_i − ½(Δθ_i + Δθ_{i+1}): sin/cos of φ by rotations through small angles.
    below = 0.0
    for i in range(n):
        below += dth[i]
    phi = below - 0.5 * dth[0]
    sp = math.sin(phi)
    cp = math.cos(phi)
    fx = 0.0
    fy = -kp[K_MTOP] * g
    m_prev = m_w
    err = 0.0
    k_ang = 0.5 * ls / ei
    for i in range(n):
        if i > 0:
            sd, cd = sincos_small(0.5 * (dth[i - 1] + dth[i]))
            sp, cp = sp * cd - cp * sd, cp * cd + sp * sd
        c = chord(dth[i], ls)
        rx = c * sp
        ry = c * cp
        fx += vforce[i, 0]
        fy += vforce[i, 1]
        # §4.6: (P_{n-1}-P_n) ⊗ F + (Q_n-P_n) ⊗ W_n, r ⊗ F = r_y F_x − r_x F_y, W_n = (0, −m g)
        m_next = m_prev + (ry * fx - rx * fy) + 0.5 * rx * w_seg
        new = k_ang * (m_prev + m_next)  # §4.7 trapezoid of the end moments
        d = abs(new - dth[i])
        if d > err:
            err = d
        out[i] = new
        fy -= w_seg
        m_prev = m_next
    return err


@jit
def solve_shape(dth, m_w, vforce, kp, tol, max_iter):
    """Fixed-point shape iteration for a given wire moment (MODEL.md §4.9), in place on ``dth``.

    Warm-started from the incoming ``dth``. If the update grows (near buckling) the iteration
    under-relaxes, Δθ ← Δθ + ω (Δθ_new − Δθ), halving ω each time (§6.3.7). :func:`solve_shape_in`
    with its scratch array allocated here.

    Returns:
        (status, iterations): status is OK or ERR_SHAPE when ``max_iter`` passes were not enough.
    """
    return solve_shape_in(dth, m_w, vforce, kp, tol, max_iter, np.empty(dth.shape[0]))


@hot
def solve_shape_in(dth, m_w, vforce, kp, tol, max_iter, new):
    """:func:`solve_shape` with the scratch ``new`` (N,) (no allocation: the sub-step kernels)."""
    n = dth.shape[0]
    omega = 1.0
    err_prev = np.inf
    for it in range(1, max_iter + 1):
        err = shape_pass(dth, m_w, vforce, kp, new)
        if not math.isfinite(err):
            return ERR_SHAPE, it
        if err > err_prev and it > 2 and omega > 0.05:
            omega *= 0.5
        for i in range(n):
            dth[i] += omega * (new[i] - dth[i])
        if err < tol:
            return OK, it
        err_prev = err
    return ERR_SHAPE, max_iter


@hot
def wire_lengths(dth, kp):
    """Right and left wire lengths [m] from the segment angles (MODEL.md §4.8)."""
    ls = kp[K_LS]
    a = kp[K_A]
    lr = kp[K_L0] - kp[K_NSEG] * ls
    ll = lr
    for i in range(dth.shape[0]):
        dr, dl = segment_lengths(dth[i], ls, a)
        lr += dr
        ll += dl
    return lr, ll


@hot
def segment_lengths(x, ls, a):
    """What a segment bent by ``x`` [rad] adds to the right and the left wire's length [m] (§4.8):
    its chord ∓ 2 a sin(x/2) (``a`` the wires' offset from the axis)."""
    sh = sincos_small(0.5 * x)[0]
    c = chord(x, ls)
    return c - 2.0 * a * sh, c + 2.0 * a * sh


@jit
def vertices(dth, kp):
    """Vertex coordinates P_0 … P_N (rows, global x/y in m) of the bent spine (MODEL.md §4.3)."""
    n = dth.shape[0]
    ls = kp[K_LS]
    p = np.zeros((n + 1, 2))
    phi = 0.0
    for i in range(n - 1, -1, -1):
        if i == n - 1:
            phi = 0.5 * dth[i]
        else:
            phi += 0.5 * (dth[i + 1] + dth[i])
        c = chord(dth[i], ls)
        p[i, 0] = p[i + 1, 0] + c * math.sin(phi)
        p[i, 1] = p[i + 1, 1] + c * math.cos(phi)
    return p


@hot
def tip_position(dth, kp):
    """Position (x, y) [m] of the top-disk vertex P_0 (no allocation; same geometry as vertices)."""
    n = dth.shape[0]
    ls = kp[K_LS]
    x = 0.0
    y = 0.0
    sp, cp = sincos_small(0.5 * dth[n - 1])
    for i in range(n - 1, -1, -1):
        if i < n - 1:  # φ_i = φ_{i+1} + ½(Δθ_{i+1} + Δθ_i): a rotation through a small angle
            sd, cd = sincos_small(0.5 * (dth[i + 1] + dth[i]))
            sp, cp = sp * cd + cp * sd, cp * cd - sp * sd
        c = chord(dth[i], ls)
        x += c * sp
        y += c * cp
    return x, y


@hot
def shape_jacobian(dth, vforce, kp, jac):
    """Jacobian ∂out/∂Δθ of :func:`shape_pass` at a fixed wire moment, written into ``jac`` (N, N).

    With h_i = r_y F_x − r_x (F_y − W/2) the moment increment of segment i (§4.6), φ_i = Σ_{k>i} Δθ_k
    + ½Δθ_i and r = c (sin φ, cos φ):

        ∂h_i/∂Δθ_j = δ_ij c'_i (cos φ_i F_x − sin φ_i G_i) − D_ij c_i (sin φ_i F_x + cos φ_i G_i),

    G_i = F_y − W/2, D_ij = ∂φ_i/∂Δθ_j (1 for j > i, ½ for j = i, 0 below). The second factor is
    c_i times the axial compression of the segment: the geometric stiffness of the loads. Then
    M_i = M_w + Σ_{k<=i} h_k and out_i = ls/(2EI) (M_{i−1} + M_i) (§4.7). The wire moment M_w is
    held fixed; its own dependence on the shape is added by the caller. Cost O(N²).
    """
    n = dth.shape[0]
    ls = kp[K_LS]
    w_seg = kp[K_MSEG] * kp[K_G]
    k_ang = 0.5 * ls / kp[K_EI]
    below = 0.0
    for i in range(n):
        below += dth[i]
    for j in range(n):  # row −1 of ∂M/∂Δθ (M_w fixed) is zero; the row of ∂M_i lives in jac[i]
        jac[0, j] = 0.0
    fx = 0.0
    fy = -kp[K_MTOP] * kp[K_G]
    for i in range(n):
        below -= dth[i]
        phi = below + 0.5 * dth[i]
        sp = math.sin(phi)
        cp = math.cos(phi)
        fx += vforce[i, 0]
        fy += vforce[i, 1]
        gi = fy - 0.5 * w_seg
        a_i = chord_slope(dth[i], ls) * (cp * fx - sp * gi)
        b_i = -chord(dth[i], ls) * (sp * fx + cp * gi)
        # jac[i] still holds ∂M_{i−1}/∂Δθ (copied from the row above); turn it into ∂M_i
        for j in range(n):
            prev = jac[i, j]
            d = b_i if j > i else (0.5 * b_i if j == i else 0.0)
            if j == i:
                d += a_i
            cur = prev + d
            if i + 1 < n:
                jac[i + 1, j] = cur
            jac[i, j] = k_ang * (prev + cur)
        fy -= w_seg


@hot
def load_ratio(vforce, kp):
    """Dunkerley screen of the loads on the tube without wires (see :func:`.stability.dunkerley_weight`).

    Σ over the load points (tip with the top disk, every vertex force, every segment weight at its
    centre) of |F| h² · 4/(π² E I), h the arc length from the clamp. Below 1 the tube cannot
    buckle, whatever its shape (the wires only add stiffness). One division: it runs every step.
    """
    n = vforce.shape[0]
    ls = kp[K_LS]
    g = kp[K_G]
    # segment weights at the centres, h = (j − ½) ls: Σ_{j=1..N} (j − ½)² = N (4N² − 1) / 12
    s = kp[K_MSEG] * g * ls * ls * n * (4.0 * n * n - 1.0) / 12.0
    for k in range(n):
        fx = vforce[k, 0]
        fy = vforce[k, 1] - (kp[K_MTOP] * g if k == 0 else 0.0)
        if fx != 0.0 or fy != 0.0:
            h = (n - k) * ls
            s += math.sqrt(fx * fx + fy * fy) * h * h
    return s * dunkerley_weight(kp[K_EI])
