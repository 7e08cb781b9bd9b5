"""3-D segmented-line bending of a chain of modules (SPATIAL.md §1–§4), numpy + numba only.

Frames: the section frame (d1, d2, t) of vertex j is stored as ``frames[j]`` (rows: d1, d2, t in
global coordinates; global z up, x toward wire 0, y toward wire 1). The base frame ``frames[N]``
is the identity. Segment i rotates the whole frame about the axis k = (ω1 d1 + ω2 d2)/Δθ by
Δθ = |ω_i| (Rodrigues; parallel transport, no twist — the tube is taken as torsionally rigid,
SPATIAL.md §1). In the lower section's material axes the rotation is

    d1' = (1 − b ω2²) d1 + b ω1 ω2 d2 − a ω2 t
    d2' = b ω1 ω2 d1 + (1 − b ω1²) d2 + a ω1 t
    t'  = a ω2 d1 − a ω1 d2 + (1 − b Δθ²) t,        a = sin Δθ/Δθ, b = (1 − cos Δθ)/Δθ²,

and the chord is r = ls (a t + b (ω2 d1 − ω1 d2)): length (2 ls/Δθ) sin(Δθ/2) along
R(k, Δθ/2) t as §2 states (the integral of the arc's tangent). b is computed as
½ (sin(Δθ/2)/(Δθ/2))², free of cancellation. a, b and f are even in Δθ: below 0.5 rad they come
from their series in Δθ² (:func:`rot_coeffs`), which needs no square root, sine or cosine.

Indexing as the planar core (:mod:`.planar.tube`): segment 0 is the top one, vertex 0 the tip, and the
loads ``vforce[j]`` (global x, y, z) [N] act at vertex j. Module tables: :mod:`.columns`.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import hot, jit
from ..columns import ERR_SHAPE, K_EI, K_G, OK
from .columns import M_LS, M_MDISK, M_MSEG, M_NSEG, M_SEG0, W_A, W_EX, W_EY, W_L0, W_MOD

SERIES_TH2 = 0.25  # [rad²] below this (Δθ < 0.5 rad) the rotation coefficients use their series
_TWELFTH = 1.0 / 12.0  # products with constants in the loops: a division costs several times more
_TWENTYFOURTH = 1.0 / 24.0

# Taylor coefficients of sin(h)/h and cos(h) in u = h², h = Δθ/2, to u⁶: the first omitted term is
# below 5e-20 for Δθ < 0.5 rad, so the series agree with sin/cos to round-off (SPATIAL.md §2).
_SINC = (1.0, -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0, -1.0 / 39916800.0, 1.0 / 6227020800.0)
_COS = (1.0, -1.0 / 2.0, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0, -1.0 / 3628800.0, 1.0 / 479001600.0)


@jit
def _series(u, c):
    """Σ_k c[k] u^k over the 7 coefficients of ``_SINC`` / ``_COS`` (Horner, written out: a loop
    over the tuple kept the compiler from vectorising :func:`_stage_coeffs`)."""
    return (((((c[6] * u + c[5]) * u + c[4]) * u + c[3]) * u + c[2]) * u + c[1]) * u + c[0]


@jit
def rot_coeffs(th2):
    """(a, b, f) = (sin Δθ/Δθ, (1 − cos Δθ)/Δθ², 2 sin(Δθ/2)/Δθ) from Δθ² [rad²].

    From f = sin(h)/(h) and cos(h), h = Δθ/2: a = f cos h, b = f²/2. All three are even in Δθ:
    below SERIES_TH2 they come from the series in h² (no square root, sine or cosine; exact to
    round-off, and free of the cancellation of 1 − cos at small angles), above from sin and cos.
    """
    if th2 < SERIES_TH2:
        u = 0.25 * th2
        f = _series(u, _SINC)
        c = _series(u, _COS)
    else:
        half = 0.5 * math.sqrt(th2)
        f = math.sin(half) / half
        c = math.cos(half)
    return f * c, 0.5 * f * f, f


@hot
def _stage_coeffs(omega, a_out, b_out):
    """(a, b) of :func:`rot_coeffs` for every segment i into ``a_out[i, 0]``, ``b_out[i, 0, 0]``.

    The series pass has no branch, so the compiler may run it on several segments at once (SIMD;
    the stores are strided, one per output row);
    the rare segments at or above SERIES_TH2 are then redone with sine and cosine. Bit for bit the
    numbers of :func:`rot_coeffs` (the same operations in the same order).
    """
    n = omega.shape[0]
    for i in range(n):
        w1 = omega[i, 0]
        w2 = omega[i, 1]
        a_out[i, 0] = 0.25 * (w1 * w1 + w2 * w2)  # u = (Δθ/2)², replaced by a below
    for i in range(n):
        u = a_out[i, 0]
        f = _series(u, _SINC)
        c = _series(u, _COS)
        a_out[i, 0] = f * c
        b_out[i, 0, 0] = 0.5 * f * f
    for i in range(n):
        w1 = omega[i, 0]
        w2 = omega[i, 1]
        th2 = w1 * w1 + w2 * w2
        if th2 >= SERIES_TH2:
            a, b, _ = rot_coeffs(th2)
            a_out[i, 0] = a
            b_out[i, 0, 0] = b


@hot
def kinematics(omega, km, frames, chords):
    """Bottom-up frames and chord vectors of every segment (SPATIAL.md §2).

    Args:
        omega: (N, 2) segment rotation vectors in the lower section's material axes [rad].
        km: module table.
        frames: (N + 1, 3, 3) output, section frames at the vertices (rows d1, d2, t); C-contiguous.
        chords: (N, 3) output, r_i = P_i − P_{i+1} [m]; C-contiguous.

    The coefficients (a_i, b_i) are staged first (:func:`_stage_coeffs`) in the outputs' own
    memory, in segment i's own rows: a_i in chords[i, 0], b_i in frames[i, 0, 0]. The chain's step
    i reads them before it writes chords[i] and frames[i], and no other step touches those rows.
    (No flat view of the outputs: numba's reshape is a ~9 ns helper call; without the two views
    a call took 155 instead of 159 ns for 13 segments.) The current frame is carried in scalars.
    """
    n = omega.shape[0]
    _stage_coeffs(omega, chords, frames)
    for r in range(3):
        for c in range(3):
            frames[n, r, c] = 1.0 if r == c else 0.0
    x0, x1, x2 = 1.0, 0.0, 0.0  # d1 of the frame below the segment (global components)
    y0, y1, y2 = 0.0, 1.0, 0.0  # d2
    z0, z1, z2 = 0.0, 0.0, 1.0  # t
    for k in range(km.shape[0]):
        seg0 = int(km[k, M_SEG0])
        ls = km[k, M_LS]
        for i in range(seg0 + int(km[k, M_NSEG]) - 1, seg0 - 1, -1):
            w1 = omega[i, 0]
            w2 = omega[i, 1]
            a = chords[i, 0]
            b = frames[i, 0, 0]
            c11 = 1.0 - b * w2 * w2
            c12 = b * w1 * w2
            c22 = 1.0 - b * w1 * w1
            c33 = 1.0 - b * (w1 * w1 + w2 * w2)
            aw1 = a * w1
            aw2 = a * w2
            chords[i, 0] = ls * (a * z0 + b * (w2 * x0 - w1 * y0))
            chords[i, 1] = ls * (a * z1 + b * (w2 * x1 - w1 * y1))
            chords[i, 2] = ls * (a * z2 + b * (w2 * x2 - w1 * y2))
            x0, x1, x2, y0, y1, y2, z0, z1, z2 = (
                c11 * x0 + c12 * y0 - aw2 * z0,
                c11 * x1 + c12 * y1 - aw2 * z1,
                c11 * x2 + c12 * y2 - aw2 * z2,
                c12 * x0 + c22 * y0 + aw1 * z0,
                c12 * x1 + c22 * y1 + aw1 * z1,
                c12 * x2 + c22 * y2 + aw1 * z2,
                aw2 * x0 - aw1 * y0 + c33 * z0,
                aw2 * x1 - aw1 * y1 + c33 * z1,
                aw2 * x2 - aw1 * y2 + c33 * z2,
            )
            frames[i, 0, 0], frames[i, 0, 1], frames[i, 0, 2] = x0, x1, x2
            frames[i, 1, 0], frames[i, 1, 1], frames[i, 1, 2] = y0, y1, y2
            frames[i, 2, 0], frames[i, 2, 1], frames[i, 2, 2] = z0, z1, z2


@jit
def _project(frame, mx, my, mz):
    """Material components (d1·M, d2·M) of a global moment M."""
    return (
        frame[0, 0] * mx + frame[0, 1] * my + frame[0, 2] * mz,
        frame[1, 0] * mx + frame[1, 1] * my + frame[1, 2] * mz,
    )


@hot
def loads_pass(omega, mw, vforce, kp, km, frames, chords, out):
    """Top-down forces and moments, new segment rotations (SPATIAL.md §3), given the kinematics.

    The load moment about the lower vertex of segment i accumulates r_i × F + ½ r_i × W_i (3-D
    MODEL.md §4.6); each end's section moment is module k's wire moment plus the load moment's
    components on that section's own (d1, d2); ω_i = ls ½ (m_up + m_low)/(E_t I) (§4.7).

    Returns:
        max over segments and components of |out − omega| [rad].
    """
    g = kp[K_G]
    k_ang_ei = 0.5 / kp[K_EI]
    fx = 0.0
    fy = 0.0
    fz = 0.0
    mx = 0.0
    my = 0.0
    mz = 0.0
    err = 0.0
    for k in range(km.shape[0] - 1, -1, -1):
        seg0 = int(km[k, M_SEG0])
        ls = km[k, M_LS]
        w_seg = km[k, M_MSEG] * g
        k_ang = ls * k_ang_ei
        mw1 = mw[k, 0]
        mw2 = mw[k, 1]
        fz -= km[k, M_MDISK] * g  # the disk at the module's top vertex
        for i in range(seg0, seg0 + int(km[k, M_NSEG])):
            fx += vforce[i, 0]
            fy += vforce[i, 1]
            fz += vforce[i, 2]
            u1, u2 = _project(frames[i], mx, my, mz)
            rx = chords[i, 0]
            ry = chords[i, 1]
            rz = chords[i, 2]
            # r × F about the lower vertex, plus ½ r × W with W = (0, 0, −w_seg)
            mx += ry * fz - rz * fy - 0.5 * ry * w_seg
            my += rz * fx - rx * fz + 0.5 * rx * w_seg
            mz += rx * fy - ry * fx
            l1, l2 = _project(frames[i + 1], mx, my, mz)
            n1 = k_ang * (2.0 * mw1 + u1 + l1)
            n2 = k_ang * (2.0 * mw2 + u2 + l2)
            d = max(abs(n1 - omega[i, 0]), abs(n2 - omega[i, 1]))
            if d > err:
                err = d
            out[i, 0] = n1
            out[i, 1] = n2
            fz -= w_seg
    return err


@hot
def shape_pass(omega, mw, vforce, kp, km, frames, chords, out):
    """One pass of the shape algorithm (MODEL.md §4.9 in 3-D): kinematics, then loads."""
    kinematics(omega, km, frames, chords)
    return loads_pass(omega, mw, vforce, kp, km, frames, chords, out)


@hot
def solve_shape(omega, mw, vforce, kp, km, tol, max_iter, frames, chords, new):
    """Fixed-point shape iteration for given wire moments, in place on ``omega`` (cf.
    planar.tube.solve_shape).

    Warm-started from the incoming ``omega``; under-relaxes (ω halved) when the update grows.

    Returns:
        (status, iterations): OK or ERR_SHAPE.
    """
    n = omega.shape[0]
    relax = 1.0
    err_prev = np.inf
    for it in range(1, max_iter + 1):
        err = shape_pass(omega, mw, vforce, kp, km, frames, chords, new)
        if not math.isfinite(err):
            return ERR_SHAPE, it
        if err > err_prev and it > 2 and relax > 0.05:
            relax *= 0.5
        for i in range(n):
            omega[i, 0] += relax * (new[i, 0] - omega[i, 0])
            omega[i, 1] += relax * (new[i, 1] - omega[i, 1])
        if err < tol:
            return OK, it
        err_prev = err
    return ERR_SHAPE, max_iter


@hot
def chord_sums(omega, km, sums):
    """Per module k: sums[k] = (Σ f_n, Σ f_n ω1_n, Σ f_n ω2_n) over its segments, f_n = 2 sin(Δθ_n/2)/Δθ_n.

    Every wire length of the module is linear in these three numbers (:func:`wire_length`), so one
    pass over the segments serves all of its wires.
    """
    for k in range(km.shape[0]):
        seg0 = int(km[k, M_SEG0])
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for i in range(seg0, seg0 + int(km[k, M_NSEG])):
            w1 = omega[i, 0]
            w2 = omega[i, 1]
            f = rot_coeffs(w1 * w1 + w2 * w2)[2]
            s0 += f
            s1 += f * w1
            s2 += f * w2
        sums[k, 0] = s0
        sums[k, 1] = s1
        sums[k, 2] = s2


@jit
def wire_length(j, sums, kw, km):
    """Exact pore-to-pore length [m] of wire group j (SPATIAL.md §4), given ``sums`` = chord_sums.

    L_j = (L0 − N_k ls) + Σ_{n in module k} f_n (ls − a_j e_j·ω_n), e_j = (−sin ψ_j, cos ψ_j)
        = (L0 − N_k ls) + ls Σ f_n − a_j e_j·Σ f_n ω_n.
    """
    k = int(kw[j, W_MOD])
    ls = km[k, M_LS]
    a = kw[j, W_A]
    lever = kw[j, W_EX] * sums[k, 1] + kw[j, W_EY] * sums[k, 2]
    return kw[j, W_L0] - km[k, M_NSEG] * ls + ls * sums[k, 0] - a * lever


@hot
def gain_sums(omega, sens, km, out):
    """Per module k and column c of S = dω/dM: the sums over the module's segments n of

        out[k, c, 0] = ω_n·S_n,c,   out[k, c, 1:3] = ω_n (ω_n·S_n,c)/12 − (1 − Δθ_n²/24) S_n,c,

    S_n,c = (S[2n, c], S[2n + 1, c]). A wire's length slope along column c is linear in them
    (:func:`length_slope`): one pass over the segments serves all of the module's wires.
    """
    ncol = sens.shape[1]
    for k in range(km.shape[0]):
        seg0 = int(km[k, M_SEG0])
        for c in range(ncol):
            p = 0.0
            q1 = 0.0
            q2 = 0.0
            for i in range(seg0, seg0 + int(km[k, M_NSEG])):
                w1 = omega[i, 0]
                w2 = omega[i, 1]
                s1 = sens[2 * i, c]
                s2 = sens[2 * i + 1, c]
                ws = w1 * s1 + w2 * s2
                wt = ws * _TWELFTH
                fa = 1.0 - (w1 * w1 + w2 * w2) * _TWENTYFOURTH
                p += ws
                q1 += w1 * wt - fa * s1
                q2 += w2 * wt - fa * s2
            out[k, c, 0] = p
            out[k, c, 1] = q1
            out[k, c, 2] = q2


@jit
def length_slope(j, gs, c, kw, km):
    """Σ_n ∂ℓ_n/∂ω_n · S_n,c of wire group j [m/(N m)], given ``gs`` = gain_sums (SPATIAL.md §4).

    ℓ_n = f_n (ls − a e·ω_n) is segment n's share of the wire length. With the small-angle forms
    f ≈ 1 − Δθ²/24, f'/Δθ ≈ −1/12, as the planar Newton uses (a Newton step only needs the slope
    to ~1 %): ∂ℓ/∂ω = −(ls − a e·ω) ω/12 − a (1 − Δθ²/24) e, so that
    ∂ℓ/∂ω · s = −(ls/12) ω·s + a e·(ω (ω·s)/12 − (1 − Δθ²/24) s).
    """
    k = int(kw[j, W_MOD])
    along = kw[j, W_EX] * gs[k, c, 1] + kw[j, W_EY] * gs[k, c, 2]
    return -km[k, M_LS] * _TWELFTH * gs[k, c, 0] + kw[j, W_A] * along


@hot
def positions(chords, out):
    """Vertex positions P_0 … P_N (rows, global x, y, z in m) from the chords; P_N = 0."""
    n = chords.shape[0]
    for c in range(3):
        out[n, c] = 0.0
    for i in range(n - 1, -1, -1):
        for c in range(3):
            out[i, c] = out[i + 1, c] + chords[i, c]


@hot
def tip_point(chords):
    """P_0 of :func:`positions` (the tip vertex, global x, y, z in m), bit for bit (the same sums
    in the same order), without the other vertices."""
    x = 0.0
    y = 0.0
    z = 0.0
    for i in range(chords.shape[0] - 1, -1, -1):
        x = x + chords[i, 0]
        y = y + chords[i, 1]
        z = z + chords[i, 2]
    return x, y, z


@jit
def bending_vector(base, top):
    """Bending vector (Θ cos β, Θ sin β) [rad] of frame ``top`` relative to frame ``base`` (§2).

    Θ is the polar angle of the top tangent from the base tangent, β its azimuth in (d1, d2).
    """
    t = top[2]
    v1 = t[0] * base[0, 0] + t[1] * base[0, 1] + t[2] * base[0, 2]
    v2 = t[0] * base[1, 0] + t[1] * base[1, 1] + t[2] * base[1, 2]
    c = t[0] * base[2, 0] + t[1] * base[2, 1] + t[2] * base[2, 2]
    s = math.sqrt(v1 * v1 + v2 * v2)
    if s == 0.0:
        return 0.0, 0.0
    theta = math.atan2(s, c)
    return theta * v1 / s, theta * v2 / s


def straight_load_factor(km: np.ndarray, ei: float, g: float) -> float:
    """Axial load / buckling load of the straight upright column under its own weight (SPATIAL.md §6).

    The spectral radius of the shape map (MODEL.md §4.9) linearised about the straight column:
    segment angles δ tilt the chords (φ_i = Σ_{j>i} δ_j + ½ δ_i, small angles), the weights of the
    disks (at the modules' top vertices) and of the segments (at their chord midpoints) then give
    the moments M_v = Σ_{loads above v} w (x_load − x_v), and δ_new = ls ½ (M_i + M_{i+1})/(E_t I).
    The loads scale linearly, so the column buckles when this factor reaches 1; it is also the
    contraction ratio of the plain shape iteration. Plain numpy (called once per layout).

    Args:
        km: module table (:mod:`.columns`).
        ei: tube bending stiffness E_t I [N m^2].
        g: gravity [m/s^2].
    """
    n = int(km[:, M_NSEG].sum())
    ls = np.empty(n)
    w_seg = np.empty(n)
    w_vert = np.zeros(n + 1)  # disk weights at the vertices
    for k in range(km.shape[0]):
        s0, nk = int(km[k, M_SEG0]), int(km[k, M_NSEG])
        ls[s0 : s0 + nk] = km[k, M_LS]
        w_seg[s0 : s0 + nk] = km[k, M_MSEG] * g
        w_vert[s0] += km[k, M_MDISK] * g
    tilt = np.triu(np.ones((n, n)), 1) + 0.5 * np.eye(n)  # φ = tilt @ δ
    x = np.zeros((n + 1, n))  # vertex abscissae x_v = Σ_{i >= v} ls_i φ_i
    for v in range(n - 1, -1, -1):
        x[v] = x[v + 1] + ls[v] * tilt[v]
    xc = x[1:] + 0.5 * ls[:, None] * tilt  # segment centres of mass
    mom = np.zeros((n + 1, n))
    for v in range(1, n + 1):
        mom[v] = (w_vert[:v, None] * (x[:v] - x[v])).sum(0) + (w_seg[:v, None] * (xc[:v] - x[v])).sum(0)
    a = (0.5 * ls / ei)[:, None] * (mom[:-1] + mom[1:])
    return float(np.max(np.abs(np.linalg.eigvals(a))))
