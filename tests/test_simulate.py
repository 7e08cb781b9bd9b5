"""Whole-model behaviour against MODEL.md §8–§10 (reference trajectories, invariants, errors)."""

import math

import numpy as np
import pytest

from spine_gym import ModelParams, SimulationError, SolverOptions, simulate
from spine_gym.capacity import CapacityProtocol, capacity_metrics, metrics_from_result, run_protocol
from spine_gym.params import FINE_REFERENCE

HYST_V = lambda t: 3.2 if t < 20.0 - 1e-9 else 0.0  # noqa: E731  §10.2
ALT_VR = HYST_V
ALT_VL = lambda t: 3.2 if t >= 20.0 - 1e-9 else 0.0  # noqa: E731  §10.3


@pytest.fixture(scope="module")
def hysteresis():
    return simulate(50.0, HYST_V, 0.0)


@pytest.fixture(scope="module")
def alternate():
    return simulate(40.0, ALT_VR, ALT_VL)


# MODEL.md §10.2
HYST_T = [4, 5, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30, 34, 38, 42, 44, 45, 46, 47, 48, 50]
HYST_A = [0.00, 0.00, 2.13, 7.51, 17.73, 23.38, 26.91, 30.00, 32.70, 35.06, 35.07, 34.62, 31.03, 27.73,
          24.70, 19.34, 14.82, 11.01, 9.34, 7.02, 3.56, 0.19, 0.00, 0.00]  # fmt: skip


def test_hysteresis_trajectory_within_half_degree(hysteresis):
    got = np.array([hysteresis.angle_deg[hysteresis.at(t)] for t in HYST_T])
    np.testing.assert_allclose(got, HYST_A, atol=0.5)


def test_hysteresis_state_at_20s(hysteresis):
    k = hysteresis.at(20.0)
    assert hysteresis.temperature_right[k] == pytest.approx(401.9, abs=1.0)
    assert hysteresis.stress_right[k] / 1e6 == pytest.approx(428, abs=3)
    assert hysteresis.stress_left[k] / 1e6 == pytest.approx(360, abs=3)
    assert hysteresis.x_austenite_right[k] == pytest.approx(0.652, abs=0.01)
    assert hysteresis.strain_right[k] == pytest.approx(0.0284, abs=3e-4)
    assert hysteresis.strain_left[k] == pytest.approx(0.0674, abs=3e-4)
    assert hysteresis.temperature_right.max() == pytest.approx(401.9, abs=1.0)


def test_hysteresis_timing(hysteresis):
    t, a = hysteresis.time, hysteresis.angle_deg
    onset = t[np.argmax(a > 0.5)]
    assert onset == pytest.approx(5.5, abs=0.2)  # §10.2: onset at 5.5 s
    peak20 = a[hysteresis.at(20)]
    t90 = t[np.argmax(a >= 0.9 * peak20)]
    assert t90 == pytest.approx(17.1, abs=0.3)
    # after switch-off it holds ~3 s, then falls below 10 % of the peak 26.0 s after switch-off
    assert a[hysteresis.at(23)] > 0.98 * peak20
    below = t[(t > 20) & (a < 0.1 * peak20)][0] - 20.0
    assert below == pytest.approx(26.0, abs=0.5)


# MODEL.md §10.3 (the five swing times are tested at 1.0°, as the spec says)
ALT_T = [10, 20, 24, 26, 28, 29, 29.5, 30, 30.5, 31, 31.5, 32, 33, 34, 35, 37, 40]
ALT_A = [17.73, 35.06, 34.62, 31.03, 27.73, 26.18, 22.48, 16.86, 10.60, 5.60, -0.55, -5.36, -16.10, -25.76,
         -28.67, -31.53, -35.17]  # fmt: skip
SWING = {29.5, 30.0, 30.5, 31.0, 31.5}


def test_alternate_drive_trajectory(alternate):
    for t, ref in zip(ALT_T, ALT_A, strict=True):
        tol = 1.0 if t in SWING else 0.5
        assert alternate.angle_deg[alternate.at(t)] == pytest.approx(ref, abs=tol), f"t = {t} s"


def test_alternate_swing_duration(alternate):
    t, a = alternate.time, alternate.angle_deg
    t20 = t[(t > 20) & (a < 20)][0]
    tm20 = t[(t > 20) & (a < -20)][0]
    assert tm20 - t20 == pytest.approx(3.65, abs=0.5)  # §10.3: +20° → −20° takes 3.65 s
    zero = t[(t > 20) & (a < 0)][0]
    assert zero == pytest.approx(31.5, abs=0.3)


def test_phase_fractions_are_a_partition(hysteresis, alternate):
    for r in (hysteresis, alternate):
        for side in ("right", "left"):
            xs = np.stack([getattr(r, f"x_{k}_{side}") for k in ("plus", "minus", "austenite")])
            assert np.all(xs >= -1e-12) and np.all(xs <= 1 + 1e-12)
            np.testing.assert_allclose(xs.sum(axis=0), 1.0, atol=1e-12)


def test_initial_state_is_the_seed_state(hysteresis):
    assert hysteresis.x_plus_right[0] == pytest.approx(0.9528, abs=1e-4)
    assert hysteresis.x_minus_left[0] == pytest.approx(0.0472, abs=1e-4)
    assert hysteresis.angle_deg[0] == 0.0
    assert hysteresis.temperature_right[0] == 293.0
    assert hysteresis.stress_right[0] == pytest.approx(0.0, abs=1.0)
    # §8: R = 1.874 Ω in martensite
    assert hysteresis.resistance_right[0] == pytest.approx(1.874, abs=1e-3)


def test_equal_voltages_do_not_bend():
    r = simulate(30.0, 3.2, 3.2)
    assert np.max(np.abs(r.angle_deg)) < 1e-9
    assert r.temperature_right[-1] > 380  # both wires transformed


def test_swapping_wires_mirrors_the_angle(hysteresis):
    m = simulate(50.0, 0.0, HYST_V)
    np.testing.assert_allclose(m.angle_deg, -hysteresis.angle_deg, atol=1e-9)
    np.testing.assert_allclose(m.temperature_left, hysteresis.temperature_right, atol=1e-9)
    np.testing.assert_allclose(m.tip_x, -hysteresis.tip_x, atol=1e-12)


def test_energy_balance_closes(hysteresis, alternate):
    # ρ c V (T_end − T_0) = Joule − convection + latent, per wire, exactly for the discrete scheme
    for r in (hysteresis, alternate):
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


def test_joule_energy_matches_electrical_power(hysteresis):
    r = hysteresis
    # ∫ V²/R dt from the sampled outputs (R changes within a step, so ~0.1 % agreement)
    integral = np.sum(0.5 * (r.power_right[1:] + r.power_right[:-1]) * np.diff(r.time))
    assert integral == pytest.approx(r.joule_energy_right[-1], rel=2e-3)
    assert r.joule_energy_left[-1] == 0.0


def test_heating_before_transformation_follows_first_order_lag():
    # §8: no transformation in the first seconds, so T(t) = T_E + ΔT_ss (1 − e^{−t/τ_th}) with
    # ΔT_ss = j/(α S_V) = 189 K and τ_th = ρc/(α S_V) = 16.9 s (martensite resistance)
    # (per-output stepping, h <= 10 ms: 0.02 K; the default dense output takes quiet sub-steps of
    # up to 50 ms, implicit Euler's first-order lag error ≈ h ΔT / (2 τ_th): measured 0.04 K)
    p = ModelParams()
    r = simulate(3.0, 3.2, 0.0, solver=SolverOptions(dense_output=False))
    dense = simulate(3.0, 3.2, 0.0)
    j = 3.2**2 / (p.lam_M * p.L0**2)
    asv = p.alpha * 4 / p.d
    tau = p.rho * p.c / asv
    assert j / asv == pytest.approx(189, abs=1)
    assert tau == pytest.approx(16.9, abs=0.1)
    exact = p.T_E + j / asv * (1 - np.exp(-r.time / tau))
    np.testing.assert_allclose(r.temperature_right, exact, atol=0.02)
    np.testing.assert_allclose(dense.temperature_right, exact, atol=0.1)
    assert np.max(np.abs(r.angle_deg)) < 1e-9 and np.max(np.abs(dense.angle_deg)) < 1e-9


@pytest.fixture(scope="module")
def fine_reference_12s():
    ref = simulate(12.0, 3.2, 0.0, solver=FINE_REFERENCE)
    assert ref.angle_deg[ref.at(10)] == pytest.approx(17.76, abs=0.05)  # §6.2 reference value
    return ref


def test_frozen_scheme_converges_to_fine_step_reference_as_step_shrinks(fine_reference_12s):
    ref = fine_reference_12s
    errs = []
    for c in (0.03, 0.01, 0.001):
        r = simulate(12.0, 3.2, 0.0, solver=SolverOptions(scheme="frozen", step_c=c))
        errs.append(np.max(np.abs(r.angle_deg - ref.angle_deg)))
    assert errs[1] < 0.5  # the §6.1 scheme at c = 0.01 is within the 0.5° gate of the reference
    assert errs[2] < errs[0] and errs[2] < 0.1


def test_coupled_scheme_converges_to_fine_step_reference_as_tolerance_tightens(fine_reference_12s):
    # the default step stepped to every output: within the 0.5° gate, and its error falls towards 0
    # as tol_x tightens (and as the sub-steps are capped: first order in h), while the number of
    # sub-steps grows (with dense output: tests/physics/test_dense_output.py)
    ref = fine_reference_12s
    errs, subs = [], []
    for tol in (1e-4, 1e-7, 1e-8):
        r = simulate(12.0, 3.2, 0.0, solver=SolverOptions(tol_x=tol, dense_output=False))
        errs.append(np.max(np.abs(r.angle_deg - ref.angle_deg)))
        subs.append(r.substeps)
    assert SolverOptions().tol_x == 1e-4 and SolverOptions().scheme == "coupled"
    assert errs[0] < 0.1
    assert errs[2] < errs[1] < errs[0] and errs[2] < 0.3 * errs[0]
    assert subs[0] < subs[1] < subs[2]
    capped = [
        simulate(12.0, 3.2, 0.0, solver=SolverOptions(h_max=h, dense_output=False)) for h in (1e-3, 1e-4)
    ]
    e_cap = [np.max(np.abs(r.angle_deg - ref.angle_deg)) for r in capped]
    assert e_cap[1] < 0.2 * e_cap[0] < 0.2 * errs[0]


def test_fixed_10ms_steps_are_wrong_as_model_md_warns():
    # §6.2: fixed h = 10 ms with τ = 0.01 s gives 36.1° at 10 s instead of 17.76° (frozen rates)
    r = simulate(10.0, 3.2, 0.0, solver=SolverOptions(scheme="frozen", step_c=math.inf, h_max=0.01))
    assert r.angle_deg[-1] > 30.0


def test_composite_solvers_give_the_same_trajectory():
    # the seed's bisection and the default coupled Newton agree to within the time-discretisation
    # error (both converge to the same fine-step limit; MODEL.md §5.2)
    opts = dict(scheme="frozen", step_c=0.003)
    runs = {
        m: simulate(25.0, HYST_V, 0.0, solver=SolverOptions(method=m, **opts))
        for m in ("newton", "illinois", "bisect")
    }
    a = runs["newton"].angle_deg
    for m in ("illinois", "bisect"):
        assert np.max(np.abs(a - runs[m].angle_deg)) < 0.12, m
        k = runs[m].at(20)
        assert runs[m].angle_deg[k] == pytest.approx(a[k], abs=2e-3)
    assert runs["newton"].shape_passes * 5 < runs["bisect"].shape_passes


def test_tip_force_capacity_load_reproduces_reference():
    # §6.2: ΔΘ under a sudden 1 N load ≈ 4.846°, from a 60 s heated state
    m = capacity_metrics()
    assert m.stable_angle_deg == pytest.approx(51.34, abs=0.3)
    assert m.responding_time_s == pytest.approx(35.90, abs=0.3)
    assert m.responding_time_swing_s == pytest.approx(26.54, abs=0.3)
    assert m.load_deflection_deg == pytest.approx(4.85, abs=0.05)
    assert m.actuating_ability == pytest.approx(0.206, abs=0.003)


@pytest.mark.parametrize(
    "params, stable, ability",
    [
        (ModelParams(a=0.006), 79.03, 0.057),
        (ModelParams(a=0.010), 64.80, 0.112),
        (ModelParams(n_w=3), 55.59, 0.355),
    ],
)
def test_design_study_reference_rows(params, stable, ability):
    m = capacity_metrics(params)
    assert m.stable_angle_deg == pytest.approx(stable, abs=0.5)
    assert m.actuating_ability == pytest.approx(ability, rel=0.03)


def test_design_trends_of_the_seed():
    # §10.4 / seed: smaller a → larger stable angle without a slower response; more wires → more ability
    a_small, a_base = capacity_metrics(ModelParams(a=0.008)), capacity_metrics(ModelParams(a=0.014))
    assert a_small.stable_angle_deg > a_base.stable_angle_deg + 10
    assert a_small.responding_time_s <= a_base.responding_time_s + 0.5
    n = [capacity_metrics(ModelParams(n_w=k)) for k in (1, 2)]
    assert n[1].actuating_ability > n[0].actuating_ability * 1.3
    assert n[1].stable_angle_deg > n[0].stable_angle_deg
    assert abs(n[1].responding_time_s - n[0].responding_time_s) < 1.0


def test_capacity_metrics_of_a_short_protocol_are_consistent():
    proto = CapacityProtocol(t_stable=20, t_respond=20, t_load=10)
    r = run_protocol(protocol=proto)
    m = metrics_from_result(r, proto)
    assert m.stable_angle_deg == pytest.approx(abs(r.angle_deg[r.at(20)]))
    assert m.actuating_ability == pytest.approx(1 / m.load_deflection_deg)
    with pytest.raises(ValueError, match="t_load"):
        CapacityProtocol(t_load=-1)


def test_alternative_calibration_reference():
    # §7 alternative: Θ(20 s) = 34.4°
    from spine_gym import alternative

    r = simulate(20.0, 3.2, 0.0, params=alternative())
    assert r.angle_deg[-1] == pytest.approx(34.4, abs=0.5)


# ------------------------------------------------------------------ inputs and failures
def test_inputs_as_constant_array_and_callable_agree():
    n = 300
    t = np.arange(n) * 0.01
    v = np.where(t < 2.0, 3.2, 1.0)
    a = simulate(3.0, v, 0.0)
    b = simulate(3.0, lambda s: 3.2 if s < 2.0 - 1e-9 else 1.0, np.zeros(n))
    np.testing.assert_array_equal(a.angle_deg, b.angle_deg)
    np.testing.assert_array_equal(a.temperature_right, b.temperature_right)
    assert set(a.to_dict()) >= {"time", "angle_deg", "temperature_right", "stress_left", "resistance_left"}
    assert len(a) == n + 1 and a.time[-1] == pytest.approx(3.0)


def test_continuing_from_a_final_state_equals_one_run():
    # stepped to every output, a continued run is one run (the state keeps the proposed sub-step);
    # with dense output the end of the first run ends a sub-step that one run would have crossed:
    # then they agree to the local error (MODEL.md §6.5)
    stepped = SolverOptions(dense_output=False)
    for solver, atol in ((stepped, 1e-12), (SolverOptions(), 0.02)):
        one = simulate(8.0, 3.2, 0.0, solver=solver)
        first = simulate(4.0, 3.2, 0.0, solver=solver)
        second = simulate(4.0, 3.2, 0.0, state=first.final_state, solver=solver)
        np.testing.assert_allclose(second.angle_deg[-1], one.angle_deg[-1], atol=atol)
        assert second.time[0] == pytest.approx(4.0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(duration=-1.0), "duration"),
        (dict(dt=0.0), "dt"),
        (dict(voltage_right=-1.0), "voltage_right must be in"),
        (dict(voltage_left=np.nan), "voltage_left must be finite"),
        (dict(voltage_right=np.ones(7)), "voltage_right must be a constant"),
        (dict(tip_force=(0.0, 1.0, 2.0)), "tip_force"),
        (dict(params="baseline"), "params must be a ModelParams"),
    ],
)
def test_bad_inputs_raise_clear_errors(kwargs, match):
    args = dict(duration=1.0, voltage_right=1.0, voltage_left=0.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        simulate(args.pop("duration"), args.pop("voltage_right"), args.pop("voltage_left"), **args)


def test_forced_non_convergence_raises_never_nan():
    # iteration caps far too small for a spine bent by a load: the solver reports failure, simulate raises
    with pytest.raises(SimulationError, match="did not converge") as exc:
        simulate(
            2.0, 3.2, 0.0, tip_force=(0.5, -1.0), solver=SolverOptions(max_shape_iter=2, max_root_iter=1)
        )
    assert exc.value.time == 0.0
    # a tip load far beyond buckling (§4.9) is reported, not turned into NaN
    with pytest.raises(SimulationError, match="buckling"):
        simulate(1.0, 0.0, 0.0, tip_force=(0.05, -60.0))


def test_too_many_substeps_is_reported():
    with pytest.raises(SimulationError, match="sub-steps"):
        simulate(8.0, 3.2, 0.0, solver=SolverOptions(max_substeps=3))


def test_responding_time_is_inf_when_not_reached_before_the_load():
    # a 5 s right-wire phase is far too short to swing back to +0.9 θ_s (it takes ~36 s)
    proto = CapacityProtocol(t_stable=30, t_respond=5, t_load=40)
    m = metrics_from_result(run_protocol(protocol=proto), proto)
    assert m.stable_angle_deg > 20
    assert m.responding_time_s == math.inf
