"""Buckling: detection in the solver, the critical-load function, the env and design tools.

The critical loads are checked against the column theory of MODEL.md §4.9 (Euler's clamped-free
π² E I / (4 L²); with the tube's weight, an independent shooting solution of the continuum column
E I θ'' + (P + q (L − s)) θ = 0, θ(0) = 0, θ'(L) = 0), not against the code's own output. No test
relies on the symmetric loophole: every status is checked with and without a lateral nudge.
"""

import math
import re

import numpy as np
import pytest

from spine_gym import ModelParams, SolverOptions, simulate
from spine_gym.buckling import critical_load, euler_tip_load
from spine_gym.capacity import CapacityProtocol
from spine_gym.design.space import evaluate_design
from spine_gym.envs import SmaSpineEnv
from spine_gym.envs.loads import LoadSchedule
from spine_gym.envs.planar import EnvConfig
from spine_gym.layout import SpineLayout
from spine_gym.physics import columns as L
from spine_gym.physics.planar import columns as PL
from spine_gym.physics.planar.stability import equilibrium_jacobian
from spine_gym.physics.planar.tube import load_ratio, shape_jacobian, shape_pass
from spine_gym.physics.spatial import columns as SL
from spine_gym.physics.spatial.stability import load_ratio as spatial_load_ratio
from spine_gym.physics.spatial.stability import needs_stability_check
from spine_gym.physics.stability import BUCKLING_SCREEN, unstable_modes
from spine_gym.simulate import SimulationError
from spine_gym.simulate_spatial import simulate_spatial

P0 = ModelParams()
NUDGE = 0.01  # [N] lateral tip force that breaks the symmetry of the straight spine


def continuum_tip_load(ei: float, length: float, q: float, p_top: float) -> float:
    """Critical tip force [N] of a clamped-free continuum column with self-weight q [N/m] and a
    dead load p_top [N] already at its tip, by shooting on θ'(L) = 0 (RK4, 4000 steps, vectorised
    over trial loads and refined three times)."""

    def slope_at_top(p: np.ndarray) -> np.ndarray:
        n = 4000
        h = length / n
        th = np.zeros_like(p)
        dth = np.ones_like(p)

        def acc(s, th):
            return -(p + p_top + q * (length - s)) * th / ei

        for k in range(n):
            s = k * h
            k1t, k1d = dth, acc(s, th)
            k2t, k2d = dth + 0.5 * h * k1d, acc(s + 0.5 * h, th + 0.5 * h * k1t)
            k3t, k3d = dth + 0.5 * h * k2d, acc(s + 0.5 * h, th + 0.5 * h * k2t)
            k4t, k4d = dth + h * k3d, acc(s + h, th + h * k3t)
            th = th + h / 6 * (k1t + 2 * k2t + 2 * k3t + k4t)
            dth = dth + h / 6 * (k1d + 2 * k2d + 2 * k3d + k4d)
        return dth

    lo, hi = 0.0, 2.0 * math.pi**2 * ei / (4 * length**2)
    for _ in range(3):
        grid = np.linspace(lo, hi, 41)
        f = slope_at_top(grid)
        k = int(np.nonzero(np.sign(f[1:]) != np.sign(f[:-1]))[0][0])
        lo, hi = grid[k], grid[k + 1]
    return 0.5 * (lo + hi)


def tip_loads(n_seg: int, fx: float, fy: float) -> np.ndarray:
    vf = np.zeros((n_seg, 2))
    vf[0] = fx, fy
    return vf


# ---------------------------------------------------------------- kernels


def test_shape_jacobian_matches_finite_differences_of_the_shape_pass():
    kp = P0.to_kernel()
    rng = np.random.default_rng(3)
    dth = rng.normal(0.0, 0.06, 13)
    vf = rng.normal(0.0, 1.0, (13, 2))
    jac = np.empty((13, 13))
    shape_jacobian(dth, vf, kp, jac)
    fd = np.empty((13, 13))
    up, dn = np.empty(13), np.empty(13)
    for j in range(13):
        d = dth.copy()
        d[j] += 1e-6
        shape_pass(d, 0.1, vf, kp, up)
        d[j] -= 2e-6
        shape_pass(d, 0.1, vf, kp, dn)
        fd[:, j] = (up - dn) / 2e-6
    assert np.abs(jac - fd).max() < 1e-8 * np.abs(fd).max()


def test_unstable_mode_count_agrees_with_the_eigenvalues():
    """The pivot count (inertia) flips exactly where the least stable eigenvalue of I − J does."""
    r = simulate(20.0, 3.2, 0.0)
    kp = P0.to_kernel()
    st = r.final_state
    bent = st[PL.X_HEAD : PL.X_HEAD + 13].copy()
    work = np.empty((13, 13))
    for dth in (np.zeros(13), bent):
        for fy in np.linspace(0.0, -40.0, 81):
            jac = np.empty((13, 13))
            equilibrium_jacobian(
                dth, st[PL.X_PR], st[PL.X_MR], st[PL.X_PL], st[PL.X_ML], tip_loads(13, 0, fy), kp, jac
            )
            lam = np.linalg.eigvals(np.eye(13) - jac).real.min()
            if abs(lam) > 1e-6:
                assert (unstable_modes(jac, work) > 0) == (lam < 0.0), (fy, lam)


def test_dunkerley_screen_is_conservative_for_the_bare_tube_in_any_shape():
    """Loads scaled to the screen ratio never buckle the tube without wires, bent or straight."""
    rng = np.random.default_rng(7)
    work = np.empty((13, 13))
    for p in (P0, P0.replace(E_t=10e6), P0.replace(m_seg=0.0, m_top=0.0)):
        kp = p.to_kernel()
        for _ in range(60):
            vf = rng.normal(0.0, 1.0, (13, 2)) * (rng.random((13, 1)) < 0.3)
            vf[0] = rng.normal(0.0, 1.0, 2)
            base = load_ratio(np.zeros((13, 2)), kp)
            if base >= BUCKLING_SCREEN:
                continue
            vf *= (BUCKLING_SCREEN - base) / (load_ratio(vf, kp) - base) * 0.999
            dth = rng.normal(0.0, 0.1, 13)
            jac = np.empty((13, 13))
            shape_jacobian(dth, vf, kp, jac)
            assert unstable_modes(jac, work) == 0


# ---------------------------------------------------------------- critical load vs MODEL.md §4.9


@pytest.mark.parametrize("n_seg", [13, 26])
def test_bare_massless_tube_buckles_at_the_euler_load(n_seg):
    p = P0.replace(n_seg=n_seg, ls=0.455 / n_seg, m_seg=0.0, m_top=0.0)
    euler = math.pi**2 * p.E_t * p.I_tube / (4 * 0.455**2)
    got = critical_load(p, wires=False).tip_force
    # segmentation error of the segmented line: O(1/N²), 0.24 % at N = 13
    assert 0.0 < got / euler - 1.0 < 0.5 / n_seg**2


def test_bare_tube_with_its_weight_matches_the_continuum_column():
    ei = P0.E_t * P0.I_tube
    q = P0.m_seg * P0.g / P0.ls
    exact = continuum_tip_load(ei, 0.455, q, P0.m_top * P0.g)
    got = critical_load(P0, wires=False)
    assert got.tip_force == pytest.approx(exact, rel=0.005)
    assert got.payload == pytest.approx(got.tip_force / P0.g, rel=1e-9)
    # §4.9's reading (the load ratios add up) is the lower bound Dunkerley gives: ~2 % below
    assert 0.0 < got.tip_force / euler_tip_load(P0) - 1.0 < 0.03
    # the baseline numbers §4.9 quotes: q L³/(E I) = 2.0, top disk P L²/(E I) = 0.27, 1 N → 1.35
    assert q * 0.455**3 / ei == pytest.approx(2.0, abs=0.05)
    assert (P0.m_top * P0.g + 1.0) * 0.455**2 / ei == pytest.approx(1.35, abs=0.02)


# ---------------------------------------------------------------- the solver reports it


def _status(tip, params=P0, solver=None, duration=0.3):
    try:
        simulate(duration, 0.0, 0.0, tip_force=tip, params=params, solver=solver)
    except SimulationError as e:
        return e.status
    return L.OK


@pytest.mark.parametrize("wires", [True, False])
def test_just_below_and_above_the_critical_load_with_and_without_a_nudge(wires):
    # without wires: wires of 1 µm (n_w A_w a² E ≈ 1e-5 of the tube's stiffness)
    p = P0 if wires else P0.replace(d=1e-6)
    p_cr = critical_load(p).tip_force
    if not wires:
        assert p_cr == pytest.approx(critical_load(P0, wires=False).tip_force, rel=1e-4)
    else:
        assert 5.0 < p_cr < 6.0  # a wire at its stress-free length resists either way
    for f, expected in ((0.97 * p_cr, L.OK), (1.03 * p_cr, L.ERR_BUCKLING)):
        assert _status((0.0, -f), p) == expected, f
        assert _status((NUDGE, -f), p) == expected, f
        assert _status((-NUDGE, -f), p) == expected, f


def test_far_past_buckling_is_reported_not_held_straight():
    # 50 N down on a straight spine must not come back straight and OK
    with pytest.raises(SimulationError, match="buckling") as exc:
        simulate(2.0, 0.0, 0.0, tip_force=(0.0, -50.0))
    assert exc.value.status == L.ERR_BUCKLING and exc.value.time == 0.0


def test_a_load_applied_later_buckles_the_spine_during_the_run():
    tip = np.zeros((100, 2))
    tip[50:] = (NUDGE, -8.0)
    with pytest.raises(SimulationError) as exc:
        simulate(1.0, 0.0, 0.0, tip_force=tip)
    assert exc.value.status == L.ERR_BUCKLING and exc.value.time == pytest.approx(0.5)


def test_bracketed_solvers_report_buckling_too_and_name_their_limit():
    # past the combined critical load every method says buckling
    assert _status((NUDGE, -7.0), solver=SolverOptions(method="illinois")) == L.ERR_BUCKLING
    # between the bare tube's and the spine's critical load the tube-only shape iteration at a
    # fixed wire moment cannot converge: reported as such (the default solver holds the load)
    assert _status((NUDGE, -3.0)) == L.OK
    assert _status((NUDGE, -3.0), solver=SolverOptions(method="bisect")) == L.ERR_SHAPE
    assert "method='newton'" in L.STATUS_TEXT[L.ERR_SHAPE]


# ---------------------------------------------------------------- env and design tools


def test_env_docstring_states_the_safe_tip_force_of_the_default_design():
    doc = " ".join(SmaSpineEnv.__doc__.split())
    m = re.search(r"holds a downward tip force below ([\d.]+) N \(a payload below ([\d.]+) kg\)", doc)
    assert m, "the env docstring must state the straight spine's critical tip force and payload"
    straight = critical_load(P0)
    assert float(m.group(1)) == pytest.approx(straight.tip_force, abs=0.005)
    assert float(m.group(2)) == pytest.approx(straight.payload, abs=0.0005)
    m = re.search(r"A tip force up to ([\d.]+) N is safe in every state.*buckles at ([\d.]+) N straight", doc)
    assert m, "the env docstring must state the state-independent safe tip force"
    # Dunkerley's bound: the tip force (with the top disk) that brings the load ratio to 1
    p_euler = math.pi**2 * P0.E_t * P0.I_tube / (4 * 0.455**2)
    safe = (1.0 - load_ratio(np.zeros((13, 2)), P0.to_kernel())) * p_euler
    assert float(m.group(1)) == pytest.approx(safe, abs=0.005)
    assert float(m.group(2)) == pytest.approx(critical_load(P0, wires=False).tip_force, abs=0.005)


def test_env_default_loads_cannot_buckle_the_tube_even_without_wires():
    cfg = EnvConfig()
    kp = cfg.params.to_kernel()
    worst = tip_loads(13, 0.0, -(cfg.tip_force_range[1] + cfg.payload_range[1] * P0.g))
    assert load_ratio(worst, kp) < BUCKLING_SCREEN  # not even checked: a sound lower bound holds
    assert critical_load(P0, wires=False).tip_force > -worst[0, 1]


def test_env_reports_a_payload_past_buckling():
    limit = critical_load(P0).payload
    env = SmaSpineEnv(tip_force_range=None)
    env.reset(seed=0, options={"loads": LoadSchedule(payload=0.97 * limit)})
    with pytest.raises(ValueError, match="buckling"):
        env.reset(seed=0, options={"loads": LoadSchedule(payload=1.03 * limit)})


def test_design_that_buckles_under_the_protocol_load_is_marked_so():
    # loaded while still straight (the wires have not pulled yet): 8 N is past the 5.6 N critical
    proto = CapacityProtocol(t_stable=1.0, t_respond=1.0, t_load=2.0, tip_force=8.0)
    rec = evaluate_design(P0, proto)
    assert rec["status"].startswith("buckled: ") and math.isnan(rec["stable_angle_deg"])
    assert evaluate_design(P0, CapacityProtocol(t_stable=1.0, t_respond=1.0, t_load=2.0))["status"] == "ok"


def test_a_tube_its_own_weight_buckles_is_reported_everywhere():
    soft = P0.replace(E_t=3e6)  # q L³/(E I) = 16.7 > 7.84: the bare tube buckles (§4.9), wires or not
    assert soft.m_seg * soft.g / soft.ls * 0.455**3 / (soft.E_t * soft.I_tube) > 7.84
    margin = critical_load(soft)
    assert not margin.stable and margin.tip_force == 0.0
    assert evaluate_design(soft, CapacityProtocol())["status"].startswith("buckled: ")


# ---------------------------------------------------------------- the spatial core (SPATIAL.md §8.3)


def straight_column_critical_load(layout: SpineLayout) -> float:
    """Critical downward tip force [N] of a straight layout at rest, from MODEL.md §4.9 / SPATIAL.md §2–§4.

    A plain-numpy linearisation in one bending plane, independent of the kernels: tilts δ of the
    segments, the disks (at the modules' top vertices, the top disk with the tip force P) and the
    segment weights (chord midpoints) give M_v = Σ_{loads above v} w (x_load − x_v), and
    δ_new,i = ls_i ½ (M_i + M_{i+1})/(E_t I) − ls_i/(E_t I) D_k Σ_{l in module k} δ_l, the wires'
    moment at rest: wires at their stress-free length, fully martensite (E_M), each antiparallel
    pair resisting with the one it stretches, D_k = Σ_pairs n_w A_w a² E_M (e·plane)² / L_ref.
    The critical P is where I − A(P) first has a non-positive eigenvalue (bisection).
    """
    pr = layout.params
    ei = pr.E_t * pr.I_tube
    kp, kw, km = layout.to_kernel()
    n = layout.n_seg
    ls = np.empty(n)
    w_seg = np.empty(n)
    w_vert = np.zeros(n + 1)
    mod = np.empty(n, dtype=int)
    dk = np.zeros(km.shape[0])
    for k in range(km.shape[0]):
        s0, nk = int(km[k, SL.M_SEG0]), int(km[k, SL.M_NSEG])
        ls[s0 : s0 + nk] = km[k, SL.M_LS]
        w_seg[s0 : s0 + nk] = km[k, SL.M_MSEG] * pr.g
        w_vert[s0] += km[k, SL.M_MDISK] * pr.g
        mod[s0 : s0 + nk] = k
        rows = np.flatnonzero(kw[:, SL.W_MOD] == k)
        for i in rows:  # the pair partner of wire i: e_q = −e_i
            for q in rows:
                if q > i and np.allclose(kw[q, [SL.W_EX, SL.W_EY]], -kw[i, [SL.W_EX, SL.W_EY]], atol=1e-9):
                    d = [kw[j, SL.W_NW] * kw[j, SL.W_A] ** 2 / kw[j, SL.W_LREF] for j in (i, q)]
                    dk[k] += min(d) * kp[L.K_AW] * kp[L.K_EM] * kw[i, SL.W_EX] ** 2  # x plane
    tilt = np.triu(np.ones((n, n)), 1) + 0.5 * np.eye(n)
    x = np.zeros((n + 1, n))
    for v in range(n - 1, -1, -1):
        x[v] = x[v + 1] + ls[v] * tilt[v]
    xc = x[1:] + 0.5 * ls[:, None] * tilt
    same = (mod[:, None] == mod[None, :]).astype(float)
    wire = (ls / ei * dk[mod])[:, None] * same

    def tangent(p: float) -> np.ndarray:
        wv = w_vert.copy()
        wv[0] += p
        mom = np.zeros((n + 1, n))
        for v in range(1, n + 1):
            mom[v] = (wv[:v, None] * (x[:v] - x[v])).sum(0) + (w_seg[:v, None] * (xc[:v] - x[v])).sum(0)
        return np.eye(n) - ((0.5 * ls / ei)[:, None] * (mom[:-1] + mom[1:]) - wire)

    lo, hi = 0.0, 100.0
    assert np.linalg.eigvals(tangent(lo)).real.min() > 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.linalg.eigvals(tangent(mid)).real.min() > 0.0 else (lo, mid)
    return 0.5 * (lo + hi)


def _spatial_status(layout, tip, duration=0.3):
    try:
        r = simulate_spatial(duration, np.zeros(layout.n_wires), layout=layout, tip_force=tip)
    except SimulationError as e:
        return e.status, None
    return L.OK, r.tip_theta_deg[-1]


def test_reference_column_reproduces_the_planar_critical_load():
    # the seed's four-wire module at rest is isotropic: its critical load is the planar one
    p_cr = straight_column_critical_load(SpineLayout.seed())
    assert p_cr == pytest.approx(critical_load(P0).tip_force, rel=1e-6)


@pytest.mark.parametrize("layout", [SpineLayout.seed(), SpineLayout.chain(2)], ids=["module", "chain2"])
def test_spatial_just_below_and_above_the_critical_load_with_and_without_a_nudge(layout):
    p_cr = straight_column_critical_load(layout)
    for f, expected in ((0.97 * p_cr, L.OK), (1.03 * p_cr, L.ERR_BUCKLING)):
        st0, _ = _spatial_status(layout, (0.0, 0.0, -f))
        stx, thx = _spatial_status(layout, (NUDGE, 0.0, -f))
        sty, thy = _spatial_status(layout, (0.0, NUDGE, -f))
        assert (st0, stx, sty) == (expected,) * 3, (f, p_cr)
        if expected == L.OK:  # a nudge in x and one in y bend the isotropic spine alike
            assert thx > 0.1 and thx == pytest.approx(thy, rel=1e-6)


def test_spatial_two_wire_layout_buckles_sideways_at_the_bare_tube_load():
    # wires at 0°/180° only: nothing resists bending about the other axis, so the straight spine
    # buckles out of its plane at the bare tube's load although the plane's critical load is 5.6 N
    p_tube = critical_load(P0, wires=False).tip_force
    lay = SpineLayout.planar()
    assert _spatial_status(lay, (0.0, 0.0, -0.97 * p_tube))[0] == L.OK
    assert _spatial_status(lay, (0.0, 0.0, -1.03 * p_tube))[0] == L.ERR_BUCKLING
    assert _spatial_status(lay, (0.0, NUDGE, -1.03 * p_tube))[0] == L.ERR_BUCKLING


def test_spatial_load_applied_later_buckles_the_spine_during_the_run():
    lay = SpineLayout.seed()
    tip = np.zeros((100, 3))
    tip[50:] = (0.0, NUDGE, -8.0)
    with pytest.raises(SimulationError, match="buckling") as exc:
        simulate_spatial(1.0, np.zeros(lay.n_wires), layout=lay, tip_force=tip)
    assert exc.value.status == L.ERR_BUCKLING and exc.value.time == pytest.approx(0.5)


def test_spatial_dunkerley_screen_is_conservative_and_skips_light_loads():
    lay = SpineLayout.chain(2)
    kp, kw, km = lay.to_kernel()
    vf = np.zeros((lay.n_seg, 3))
    assert not needs_stability_check(vf, kp, km)  # own weight: the hot path pays no check
    vf[0] = (0.0, 0.0, -straight_column_critical_load(lay))
    assert spatial_load_ratio(vf, kp, km) >= 1.0 > BUCKLING_SCREEN  # a lower bound on buckling
