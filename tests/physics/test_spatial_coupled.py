"""The spatial core's coupled time step (MODEL.md §6.5 over arrays of wires).

Accuracy is checked against the fine-step reference of MODEL.md §6.2 (frozen rates, fixed 0.1-ms
sub-steps, :data:`spine_gym.params.FINE_REFERENCE`) on the same layout, never against the coupled
step's own output; the planar equivalence of SPATIAL.md §7.1 against the planar core's coupled run.
"""

import numpy as np
import pytest

from spine_gym import SolverOptions, SpineLayout, simulate
from spine_gym.experiments import (
    ALTERNATE_REFERENCE,
    ALTERNATE_SWING_TIMES,
    ANGLE_TOL_DEG,
    HYSTERESIS_REFERENCE,
    SWING_TOL_DEG,
    alternate_voltages,
    hysteresis_voltages,
)
from spine_gym.params import FINE_REFERENCE
from spine_gym.physics.stability import lu_factor, lu_solve

DURATION = 20.0  # [s] the timed run of benchmarks/bench_physics.py (MODEL.md §10.2, 0–20 s)
GATE_DEG = 0.5  # every output within 0.5° of the fine-step reference


def _drive(layout: SpineLayout) -> np.ndarray:
    """bench_physics' 20-s drive: §10.2's right-wire voltage on wire 0 of the bottom module and on
    wire 1 of the second (a 3-D bend), scaled to the wire length; the other wires unpowered."""
    vr = hysteresis_voltages()[0][: int(round(DURATION / 0.01))]
    v = np.zeros((vr.shape[0], layout.n_wires))
    scale = layout.voltage_scale
    v[:, 0] = vr * scale[0]
    if layout.n_modules > 1:
        v[:, 5] = vr * scale[5]
    return v


@pytest.fixture(scope="module", params=["module", "chain"])
def reference_run(request):
    layout = SpineLayout.seed() if request.param == "module" else SpineLayout.chain(2)
    v = _drive(layout)
    return layout, v, simulate(DURATION, v, layout=layout, solver=FINE_REFERENCE)


def _max_error(layout, v, ref, solver) -> float:
    r = simulate(DURATION, v, layout=layout, solver=solver)
    return float(np.abs(r.tip_bending_deg - ref.tip_bending_deg).max())


def test_default_is_the_coupled_step_and_meets_the_accuracy_gate(reference_run):
    layout, v, ref = reference_run
    assert SolverOptions().scheme == "coupled"
    r = simulate(DURATION, v, layout=layout)
    assert np.abs(r.tip_bending_deg - ref.tip_bending_deg).max() < GATE_DEG
    for k in range(layout.n_modules):
        assert np.abs(r.module_bending_deg[:, k] - ref.module_bending_deg[:, k]).max() < GATE_DEG
    # the point of the scheme: far fewer sub-steps than the frozen step's rate × h <= c rule
    frozen = simulate(DURATION, v, layout=layout, solver=SolverOptions(scheme="frozen"))
    assert r.substeps < 0.3 * frozen.substeps


def test_coupled_step_converges_to_the_fine_reference_as_tol_x_tightens(reference_run):
    layout, v, ref = reference_run
    errors = [_max_error(layout, v, ref, SolverOptions(tol_x=tol)) for tol in (1e-4, 1e-6, 1e-8)]
    assert errors[0] > errors[1] > errors[2], errors
    # 1e-8: within the fine reference's own first-order error (0.1-ms frozen steps)
    assert errors[2] < 0.01, errors


def _planar_pair(layout, vr, vl):
    psi = [w.psi_deg for w in layout.modules[0].wires]
    v = np.zeros((vr.shape[0], layout.n_wires))
    v[:, psi.index(0.0)] = vr
    v[:, psi.index(180.0)] = vl
    duration = vr.shape[0] * 0.01
    return simulate(duration, vr, vl), simulate(duration, v, layout=layout)


@pytest.mark.parametrize("neutral_wires", [False, True])
def test_planar_equivalence_of_the_coupled_steps(neutral_wires):
    """SPATIAL.md §7.1 with the default (coupled) step in both cores. Their linearisations differ
    at the level of the small-angle forms of the length slopes and the quiet wires leave the
    spatial system, so the step sequences differ slightly: measured 1.7e-5° on the 50-s hysteresis
    run and up to 29 s of the alternate drive, 0.006° in its snap-through swing after 29 s."""
    layout = SpineLayout.planar(neutral_wires=neutral_wires)
    vr, vl = hysteresis_voltages()
    p, s = _planar_pair(layout, vr, vl)
    assert np.abs(s.tip_bending_deg[:, 0] - p.angle_deg).max() < 1e-4
    np.testing.assert_allclose(s.temperature[:, 0], p.temperature_right, atol=1e-3)
    got = np.array([s.tip_bending_deg[s.at(t), 0] for t in HYSTERESIS_REFERENCE])
    np.testing.assert_allclose(got, list(HYSTERESIS_REFERENCE.values()), atol=ANGLE_TOL_DEG)
    vr, vl = alternate_voltages()
    p, s = _planar_pair(layout, vr, vl)
    before = p.time <= 29.0  # the snap-through swing starts after 29 s (MODEL.md §10.3)
    assert np.abs(s.tip_bending_deg[before, 0] - p.angle_deg[before]).max() < 1e-4
    assert np.abs(s.tip_bending_deg[:, 0] - p.angle_deg).max() < 0.1
    for t, want in ALTERNATE_REFERENCE.items():
        tol = SWING_TOL_DEG if t in ALTERNATE_SWING_TIMES else ANGLE_TOL_DEG
        assert abs(s.tip_bending_deg[s.at(t), 0] - want) <= tol, (t, want)


def test_energy_balance_closes_with_the_coupled_step_on_a_chain():
    layout = SpineLayout.chain(2)
    r = simulate(12.0, (2.6, 0.0, 0.0, 0.0, 0.0, 1.4, 0.0, 0.0), layout=layout, tip_force=(0.2, 0.1, -0.3))
    assert r.substeps < 1500  # the coupled step, not the frozen one (which needs thousands)
    p = layout.params
    volume = np.array([p.wire_area * m.L0 * w.n_w for m in layout.modules for w in m.wires])
    stored = p.rho * p.c * volume * (r.temperature - r.temperature[0])
    budget = r.joule_energy - r.convective_loss + r.latent_heat
    np.testing.assert_allclose(stored, budget, rtol=1e-9, atol=1e-9)


def test_lu_factors_solve_several_right_hand_sides_like_numpy():
    rng = np.random.default_rng(3)
    for n in (2, 4, 8, 16):
        a = rng.normal(size=(n, n)) + n * np.eye(n)[rng.permutation(n)]  # pivoting needed
        lu = a.copy()
        piv = np.zeros(n, dtype=np.int64)
        assert lu_factor(lu, piv)
        for _ in range(2):
            b = rng.normal(size=n)
            x = b.copy()
            lu_solve(lu, piv, x)
            np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-10, atol=1e-12)
    assert not lu_factor(np.zeros((3, 3)), np.zeros(3, dtype=np.int64))
