"""Sub-steps across held output steps with dense output (MODEL.md §6.5, ``physics.dense``).

Accuracy is checked against the fine-step reference of MODEL.md §6.2 (:data:`FINE_REFERENCE`), never
against the dense run's own output; the MODEL.md §10.2–§10.4 rows and the energy balance with the
new default are the existing tests of ``tests/test_simulate.py`` (they run the default options). Here:
the gate at every output, the equivalence with per-output stepping where the inputs change at every
output, the outputs at sub-step ends, convergence, and the options.
"""

import numpy as np
import pytest

from spine_gym import SimulationError, SolverOptions, SpineLayout, simulate
from spine_gym.experiments import hysteresis_voltages
from spine_gym.params import FINE_REFERENCE, ModelParams
from spine_gym.physics import columns as L
from spine_gym.physics import dense
from spine_gym.physics.planar import integrate, record
from spine_gym.physics.planar import columns as PL

GATE_DEG = 0.5  # every output within 0.5° of the fine-step reference
STEPPED = SolverOptions(dense_output=False)


@pytest.fixture(scope="module")
def hysteresis_runs():
    """The 50-s §10.2 run: fine reference, default (dense) and per-output stepping."""
    vr, vl = hysteresis_voltages()
    return {
        name: simulate(50.0, vr, vl, solver=s)
        for name, s in (("fine", FINE_REFERENCE), ("dense", SolverOptions()), ("stepped", STEPPED))
    }


def test_default_dense_output_is_within_the_gate_at_every_output(hysteresis_runs):
    fine, d, s = hysteresis_runs["fine"], hysteresis_runs["dense"], hysteresis_runs["stepped"]
    assert SolverOptions().dense_output and SolverOptions().dense_h_max == 0.05
    assert len(d.angle_deg) == len(fine.angle_deg) == 5001  # every output is reported
    assert np.abs(d.angle_deg - fine.angle_deg).max() < GATE_DEG
    # measured 0.15°: a third of the gate (per-output stepping: 0.03°)
    assert np.abs(d.angle_deg - fine.angle_deg).max() < 0.3
    assert np.abs(d.temperature_right - fine.temperature_right).max() < 1.0
    # the point of it: the sub-steps are no longer cut at every 10-ms output
    assert d.substeps < 0.3 * s.substeps
    # the 20-s run is the first span of the 50-s run (the voltage switches off at 20 s)
    vr, vl = hysteresis_voltages()
    r20 = simulate(20.0, vr[:2000], vl[:2000])
    np.testing.assert_array_equal(r20.angle_deg, d.angle_deg[:2001])
    assert np.abs(r20.angle_deg - fine.angle_deg[:2001]).max() < GATE_DEG


def test_energy_balance_holds_at_interpolated_outputs(hysteresis_runs):
    # ρ c V (T − T_0) = Joule − convection + latent is linear in the state: it holds between the
    # ends of a sub-step as exactly as at them, so at every output of the dense run
    r = hysteresis_runs["dense"]
    p = r.params
    for side in ("right", "left"):
        temp = getattr(r, f"temperature_{side}")
        stored = p.rho * p.c * p.wire_volume * p.n_w * (temp - temp[0])
        budget = (
            getattr(r, f"joule_energy_{side}")
            - getattr(r, f"convective_loss_{side}")
            + getattr(r, f"latent_heat_{side}")
        )
        np.testing.assert_allclose(stored, budget, rtol=1e-9, atol=1e-9)
    # Joule heat is accumulated at a constant power within a sub-step: linear between outputs
    # inside one, and never decreasing
    assert np.all(np.diff(r.joule_energy_right) >= 0.0)


def test_dense_run_equals_per_output_stepping_when_inputs_change_every_output():
    rng = np.random.default_rng(7)
    n = 300
    vr = 3.2 + 0.1 * rng.random(n)  # a new voltage at every output step: every span is one step
    vl = np.zeros(n)
    a = simulate(n * 0.01, vr, vl)
    b = simulate(n * 0.01, vr, vl, solver=STEPPED)
    np.testing.assert_array_equal(a.final_state, b.final_state)
    for name in ("angle_deg", "temperature_right", "stress_left", "joule_energy_right", "tip_x"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.substeps == b.substeps
    lay = SpineLayout.seed()
    v = np.zeros((n, lay.n_wires))
    v[:, 0] = vr
    sa = simulate(n * 0.01, v, layout=lay)
    sb = simulate(n * 0.01, v, layout=lay, solver=STEPPED)
    np.testing.assert_array_equal(sa.final_state, sb.final_state)
    np.testing.assert_array_equal(sa.tip_bending_deg, sb.tip_bending_deg)


def test_output_at_the_span_end_is_the_state_one_long_output_step_gives():
    # a span of m held outputs takes the sub-steps of ONE output step of length m dt (only its end
    # cuts a sub-step): recording the outputs inside must not change them, and the last output is
    # that step's state itself
    p = ModelParams()
    kp, ks = p.to_kernel(), SolverOptions().to_kernel()
    start = simulate(5.3, 3.2, 0.0).final_state  # at the onset: the sub-steps vary
    vf = np.zeros((p.n_seg, 2))
    m, dt = 40, 0.01
    held, long = start.copy(), start.copy()
    out = np.empty((m, record.OUT_SIZE))
    st, done, nsub, _ = integrate.advance_held(held, kp, ks, 3.2, 0.0, vf, dt, m, False, out, 0)
    assert (st, done) == (L.OK, m)
    st2, nsub2, _ = integrate.advance(long, kp, ks, 3.2, 0.0, vf, m * dt, False)
    assert st2 == L.OK and nsub2 == nsub < m  # fewer sub-steps than outputs
    heads = slice(0, PL.X_TIME)  # the model time differs: m additions of dt against one of m dt
    np.testing.assert_array_equal(held[heads], long[heads])
    np.testing.assert_array_equal(held[PL.X_HEAD :], long[PL.X_HEAD :])
    row = np.empty(record.OUT_SIZE)
    record.record(held, kp, row)
    np.testing.assert_array_equal(out[-1], row)
    assert held[PL.X_TIME] == pytest.approx(start[PL.X_TIME] + m * dt, abs=1e-12)
    np.testing.assert_allclose(out[:, PL.X_TIME], start[PL.X_TIME] + dt * np.arange(1, m + 1), atol=1e-12)


def test_outputs_inside_a_sub_step_are_the_linear_interpolant():
    # the rule of physics.dense: where output j falls in the sub-step [e0, e1] of a span of n_out
    f = dense.output_fraction
    assert f(1, 5, 0.01, 0.0, 0.025, False) == pytest.approx(0.4)
    assert f(2, 5, 0.01, 0.0, 0.025, False) == pytest.approx(0.8)
    assert f(3, 5, 0.01, 0.0, 0.025, False) == -1.0  # after the sub-step
    assert f(2, 5, 0.01, 0.005, 0.02, False) == 1.0  # at its end
    assert f(5, 5, 0.01, 0.02, 0.049999, False) == -1.0  # the last output only at the span's end
    assert f(5, 5, 0.01, 0.02, 0.05, True) == 1.0
    a, b, out = np.array([1.0, -2.0, 5.0]), np.array([3.0, 2.0, 5.0]), np.empty(3)
    dense.interpolate(a, b, 0.25, out)
    np.testing.assert_allclose(out, [1.5, -1.0, 5.0])
    dense.interpolate(a, b, 0.3, out)
    assert out[2] == 5.0  # an unchanged quantity stays exactly unchanged
    # spans: runs of equal voltages and loads
    volts = np.array([[1.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 0.0], [2.0, 0.0]])
    loads = np.zeros((5, 3, 2))
    loads[4, 0, 1] = -0.1
    assert [dense.held_steps(volts, loads, k) for k in (0, 2, 4)] == [2, 2, 1]
    assert dense.held_steps(volts, loads[:1], 2) == 3  # constant loads


def test_dense_output_converges_to_the_fine_reference_as_its_step_shrinks(hysteresis_runs):
    fine = hysteresis_runs["fine"].angle_deg[:1201]
    errs, subs = [], []
    for tol, h in ((1e-4, 0.1), (1e-4, 0.05), (1e-5, 0.01), (1e-7, 0.01)):
        r = simulate(12.0, 3.2, 0.0, solver=SolverOptions(tol_x=tol, dense_h_max=h))
        errs.append(np.abs(r.angle_deg - fine).max())
        subs.append(r.substeps)
    assert errs[0] > errs[1] > errs[2] > errs[3], errs
    assert errs[3] < 0.2 * errs[1], errs
    assert subs[0] < subs[1] < subs[2] < subs[3], subs


def test_span_of_a_loaded_run_resolves_the_mechanics_and_reports_failures_at_their_time():
    # tip-force pulses: the spans end where the load changes; dense and stepped stay together
    force = lambda t: (0.3, -0.5) if 3.0 <= t < 4.0 else (0.0, 0.0)  # noqa: E731
    a = simulate(6.0, 3.2, 0.0, tip_force=force)
    b = simulate(6.0, 3.2, 0.0, tip_force=force, solver=STEPPED)
    assert np.abs(a.angle_deg - b.angle_deg).max() < 0.1
    assert a.substeps < b.substeps
    # a load past buckling in the middle of a run is reported at the step it is applied
    with pytest.raises(SimulationError, match="buckling") as exc:
        simulate(2.0, 0.0, 0.0, tip_force=lambda t: (0.05, -60.0) if t >= 1.0 else (0.0, 0.0))
    assert exc.value.time == pytest.approx(1.0)


def test_dense_options_are_validated_and_reach_the_kernel():
    assert SolverOptions().to_kernel()[L.S_DENSE] == 0.05
    assert STEPPED.to_kernel()[L.S_DENSE] == 0.0
    with pytest.raises(ValueError, match="dense_output must be True or False"):
        SolverOptions(dense_output=1)
    with pytest.raises(ValueError, match="dense_h_max"):
        SolverOptions(dense_h_max=0.0)
