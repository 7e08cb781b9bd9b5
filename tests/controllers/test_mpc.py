"""Snapshot/restore, the batched rollout kernel, the phase-fraction estimator and MPPI."""

import gymnasium as gym
import numpy as np
import pytest

import spine_gym  # noqa: F401 - registers SmaSpine-v0
from spine_gym.agents.runtime import VALIDATION_SEED_BASE, load_tuned
from spine_gym.agents.scenarios import HARD_LIKE_KWARGS
from spine_gym.controllers.registry import GUARD_MARGIN_K
from spine_gym.controllers import (
    DisturbanceConfig,
    MPPIConfig,
    MPPIController,
    PhaseEstimator,
    PIDController,
    austenite_from_resistance,
)
from spine_gym.envs.loads import LoadSchedule
from spine_gym.envs.targets import TargetProfile
from spine_gym.physics import columns as L
from spine_gym.physics.planar import columns as PL
from spine_gym.physics.planar.rollout import rollout_many, rollout_many_serial

NOISY = {
    "sensor_noise": {"angle": 0.2, "temperature": 0.5, "resistance": 0.002},
    "domain_randomization": True,
}


def _env(**kw):
    return gym.make("SmaSpine-v0", **{"episode_duration": 20.0, **kw}).unwrapped


def _roll(env, actions):
    out = []
    for a in actions:
        obs, r, te, tr, info = env.step(a)
        out.append((obs.copy(), r, te, tr, info["energy_J"], info["angle_deg"], tuple(info["temperature"])))
    return out


def _same(a, b):
    return all(np.array_equal(x[0], y[0]) and x[1:] == y[1:] for x, y in zip(a, b, strict=True))


# ---------------------------------------------------------------- snapshot / restore
def test_snapshot_restore_round_trips_bit_identically_with_noise_and_randomisation():
    env = _env(**NOISY)
    env.reset(seed=11)
    rng = np.random.default_rng(0)
    _roll(env, rng.uniform(-1, 1, (30, 2)))  # somewhere inside the episode, wires warm
    snap = env.snapshot()
    actions = rng.uniform(-1, 1, (40, 2))
    first = _roll(env, actions)
    env.restore(snap)
    assert np.array_equal(env.state, snap.state)
    assert _same(first, _roll(env, actions))
    # into another env of the same configuration, after it ran its own episode
    other = _env(**NOISY)
    other.reset(seed=99)
    _roll(other, rng.uniform(-1, 1, (5, 2)))
    other.restore(snap)
    assert other.model_params == env.model_params
    assert _same(first, _roll(other, actions))
    # the snapshot is a copy: neither stepping nor restoring changed it
    env.restore(snap)
    assert _same(first, _roll(env, actions))


def test_vector_env_snapshot_restore_round_trips_and_accepts_single_env_snapshots():
    venv = gym.make_vec("SmaSpine-v0", num_envs=2, episode_duration=20.0, parallel=False, **NOISY)
    venv.reset(seed=3)
    rng = np.random.default_rng(1)
    for _ in range(10):
        venv.step(rng.uniform(-1, 1, (2, 2)))
    snaps = [venv.snapshot(i) for i in range(2)]
    actions = rng.uniform(-1, 1, (20, 2, 2))
    first = [venv.step(a)[0] for a in actions]
    for i in range(2):
        venv.restore(i, snaps[i])
    assert all(np.array_equal(a, venv.step(b)[0]) for a, b in zip(first, actions, strict=True))
    single = _env(**NOISY)
    single.reset(seed=3)
    for i in range(2):
        venv.restore(i, snaps[0])
    obs = venv.step(actions[0])[0]
    single.restore(snaps[0])
    assert np.array_equal(obs[0], single.step(actions[0, 0])[0])
    with pytest.raises(ValueError, match="sub-env index"):
        venv.snapshot(2)
    venv.close()


def test_restore_rejects_a_snapshot_of_another_configuration():
    env = _env()
    env.reset(seed=0)
    other = _env(episode_duration=10.0)
    other.reset(seed=0)
    with pytest.raises(ValueError, match="does not fit"):
        other.restore(env.snapshot())
    with pytest.raises(ValueError, match="SpineSnapshot"):
        env.restore({"states": env.state})


# ---------------------------------------------------------------- batched rollouts
@pytest.mark.parametrize("kernel", [rollout_many, rollout_many_serial])
def test_rollout_batch_equals_single_env_rollouts_with_the_same_voltages(kernel):
    # a tip-force pulse inside the horizon exercises the re-solve of the mechanics
    loads = LoadSchedule(tip_force_events=((2.5, 3.5, (0.4, -0.1)),), payload=0.03)
    env = _env()
    env.reset(seed=5, options={"target": 20.0, "loads": loads})
    rng = np.random.default_rng(2)
    _roll(env, rng.uniform(-1, 1, (20, 2)))
    snap = env.snapshot()
    n, h = 6, 25
    actions = rng.uniform(-1, 1, (n, h, 2))
    volts = (actions + 1.0) * 0.5 * env.v_max  # the env's own mapping (SmaSpineEnv docstring)
    k = snap.step_index
    lv = np.zeros((h, env.model_params.n_seg, 2))
    lv[:, 0, :] = snap.arrays["forces"][k : k + h]
    resolve = snap.arrays["resolve_plan"][k : k + h].copy()
    assert resolve.any()
    work = np.empty((n, snap.state.shape[0]))
    angle, temp, joule = np.empty((n, h)), np.empty((n, h, 2)), np.empty((n, h, 2))
    status = np.empty(n, dtype=np.int64)
    cfg = env.config
    kernel(
        np.array(snap.state),  # writable copies, as the MPC passes them (read-only: another compile)
        np.array(snap.kp),
        cfg.solver.to_kernel(),
        np.ascontiguousarray(volts[:, :, 0]),
        np.ascontiguousarray(volts[:, :, 1]),
        lv,
        resolve,
        cfg.physics_dt,
        cfg.n_sub,
        work,
        angle,
        temp,
        joule,
        status,
    )
    assert (status == L.OK).all()
    side = snap.arrays["wvol"][0]  # wire volume of one side
    for i in range(n):
        env.restore(snap)
        e0 = snap.state[[PL.X_QJR, PL.X_QJL]].sum() * side
        energy = 0.0
        for j in range(h):
            _, _, _, _, info = env.step(actions[i, j])
            energy += info["energy_J"]
            assert info["angle_deg"] == angle[i, j] * (180.0 / np.pi)
            assert tuple(info["temperature"]) == tuple(temp[i, j])
        assert np.array_equal(work[i], env.state)
        assert energy == pytest.approx(joule[i, -1].sum() * side - e0, rel=1e-12)


# ---------------------------------------------------------------- estimator
def test_austenite_from_resistance_inverts_the_resistivity_mixing_law():
    p = spine_gym.ModelParams()
    ohm = p.L0 / p.wire_area
    xa = np.array([0.0, 0.3, 1.0])
    r = (p.lam_A * xa + p.lam_M * (1.0 - xa)) * ohm  # MODEL.md §3.7
    np.testing.assert_allclose(austenite_from_resistance(r, p), xa, atol=1e-12)
    assert austenite_from_resistance(np.array([0.0, 1e3]), p).tolist() == [0.0, 1.0]


def test_estimator_recovers_the_phase_fractions_on_seeded_episodes():
    """Max |x̂ − x| over every fraction and step of two 30-s PID episodes with the env's default
    random targets, payloads and tip forces; measured 0.0061 (x_A exact to roundoff: the
    resistance pins it; the error is the x₊/x₋ split of the martensite)."""
    tuned = load_tuned()["pid"]
    worst = 0.0
    for seed in (3, 7):
        env = _env(episode_duration=30.0)
        pid = PIDController(**tuned, v_max=env.v_max, dt=env.control_period, temperature_limit=418.0)
        est = PhaseEstimator(env.config)
        obs, _ = env.reset(seed=seed)
        est.reset()
        x_a_max = 0.0
        while True:
            est.update(obs)
            x = env.state[[PL.X_PR, PL.X_MR, PL.X_PL, PL.X_ML]]
            worst = max(worst, float(np.abs(est.fractions - x).max()))
            x_a_max = max(x_a_max, float(1.0 - x[0] - x[1]), float(1.0 - x[2] - x[3]))
            a, _ = pid.predict(obs)
            obs, _, te, tr, _ = env.step(a)
            if te or tr:
                break
        assert x_a_max > 0.1  # the episode did transform a wire
    assert worst < 0.02


def test_estimator_rejects_a_wrong_observation():
    est = PhaseEstimator(_env().config)
    est.reset()
    with pytest.raises(ValueError, match="shape"):
        est.update(np.zeros(4))


# ---------------------------------------------------------------- MPPI
FAST = MPPIConfig(n_samples=32, horizon=3.0)


PUSH = LoadSchedule(tip_force_events=((7.0, 10.0, (-0.5, 0.0)),), payload=0.05)


def _episode(env, ctrl, target, loads):
    obs, _ = env.reset(seed=0, options={"target": target, "loads": loads})
    ctrl.reset()
    errors, energy = [], 0.0
    while True:
        a, _ = ctrl.predict(obs)
        obs, _, te, tr, info = env.step(a)
        errors.append(info["tracking_error_deg"])
        energy += info["energy_J"]
        if te or tr:
            return np.array(errors), energy


@pytest.mark.parametrize(
    "target, loads",
    [(TargetProfile.constant(20.0), PUSH), (TargetProfile.step((0.0, 4.0), (0.0, -25.0)), LoadSchedule())],
    ids=["constant_pushed", "step"],
)
def test_mpc_oracle_tracks_better_than_pid(target, loads):
    """Short 15-s episodes: a constant target under a payload and a tip push, a step without
    loads. RMSE over the episode and, by a clear margin, after the first 5 s (the rise from the
    straight spine is at the wires' physical limit for both)."""
    env = _env(episode_duration=15.0)
    guard = env.temperature_limit - 5.0
    pid = PIDController(
        **load_tuned()["pid"], v_max=env.v_max, dt=env.control_period, temperature_limit=guard
    )
    mpc = MPPIController(env.config, "oracle", env=env, settings=FAST, temperature_limit=guard)
    e_pid, _ = _episode(env, pid, target, loads)
    e_mpc, _ = _episode(env, mpc, target, loads)
    rmse = lambda e: float(np.sqrt(np.mean(e**2)))  # noqa: E731
    late = slice(50, None)  # t > 5 s: after the first rise, the push acts at 7-10 s
    print(
        f"RMSE mpc {rmse(e_mpc):.3f} pid {rmse(e_pid):.3f}; "
        f"t > 5 s: mpc {rmse(e_mpc[late]):.3f} pid {rmse(e_pid[late]):.3f}"
    )
    assert rmse(e_mpc) < rmse(e_pid)
    assert rmse(e_mpc[late]) < 0.7 * rmse(e_pid[late])


def test_mpc_estimated_needs_no_env_and_oracle_needs_one():
    env = _env()
    obs, _ = env.reset(seed=1)
    est = MPPIController(env.config, "estimated", settings=MPPIConfig(n_samples=8, horizon=1.0))
    a, state = est.predict(obs, episode_start=np.array([True]))
    assert a.shape == (2,) and a.dtype == np.float32 and np.all(np.abs(a) <= 1.0) and state is None
    oracle = MPPIController(env.config, "oracle", settings=MPPIConfig(n_samples=8, horizon=1.0))
    with pytest.raises(ValueError, match="oracle mode needs the env"):
        oracle.predict(obs)
    with pytest.raises(ValueError, match="mode must be one of"):
        MPPIController(env.config, "magic")
    with pytest.raises(ValueError, match="n_samples"):
        MPPIConfig(n_samples=2)
    with pytest.raises(ValueError, match="horizon must be a whole multiple"):
        MPPIController(env.config, settings=MPPIConfig(horizon=0.25))
    with pytest.raises(ValueError, match="one env"):
        est.predict(np.stack([obs, obs]))
    with pytest.raises(ValueError, match="config differs"):
        oracle.bind(_env(v_max=4.0))


@pytest.mark.parametrize("name", ["mpc_oracle", "mpc_oracle_causal", "mpc_estimated"])
def test_mpc_runs_behind_predict_in_the_evaluation_path(name):
    from spine_gym.agents.runtime import build_controller, make_env, run_episode

    probe = make_env()
    ctrl = build_controller(name, probe)  # built for the default 60-s env ...
    env = make_env({"episode_duration": 2.0})  # ... and bound to each episode's env by run_episode
    tr = run_episode(env, ctrl, seed=4)
    assert len(tr.time) == 20 and ctrl.env is env.unwrapped
    assert np.all(np.isfinite(tr.angle_deg)) and np.all(np.abs(tr.action) <= 1.0)


def _predict_pulse(env, settings: MPPIConfig, volts: np.ndarray) -> np.ndarray:
    """Angle [deg] the MPC's rollout predicts for one voltage sequence (H, 2) from the env's state."""
    snap = env.snapshot()
    h = volts.shape[0]
    dt = env.config.physics_dt if settings.plan_physics_dt is None else settings.plan_physics_dt
    work = np.empty((1, snap.state.shape[0]))
    angle, temp, joule = np.empty((1, h)), np.empty((1, h, 2)), np.empty((1, h, 2))
    status = np.empty(1, dtype=np.int64)
    rollout_many_serial(
        np.array(snap.state),  # writable copies, as the MPC passes them (read-only: another compile)
        np.array(snap.kp),
        settings.plan_solver(env.config.solver).to_kernel(),
        np.ascontiguousarray(volts[None, :, 0]),
        np.ascontiguousarray(volts[None, :, 1]),
        np.zeros((h, env.model_params.n_seg, 2)),
        np.zeros(h, dtype=np.bool_),
        dt,
        int(round(env.control_period / dt)),
        work,
        angle,
        temp,
        joule,
        status,
    )
    assert status[0] == L.OK
    return angle[0] * (180.0 / np.pi)  # as the env reports it


def test_default_planning_rollouts_are_the_env_bit_for_bit():
    """A 3-s 5-V pulse on the right wire (the wire transforms), then 2.5 V for 3 s, no loads: the
    planning default (0.1-s steps = the env's default physics step, the env's coupled scheme and
    its error control) predicts exactly the env's angles; the frozen scheme at c = 0.03 (the
    planning default before the env's step became the control period) stays within 3.5 deg."""
    env = _env()
    env.reset(seed=0, options={"target": 20.0, "loads": LoadSchedule()})
    actions = np.full((60, 2), -1.0)
    actions[:30, 0], actions[30:, 0] = 1.0, 0.0
    volts = (actions + 1.0) * 0.5 * env.v_max
    snap = env.snapshot()
    planned = _predict_pulse(env, MPPIConfig(), volts)
    frozen = _predict_pulse(env, MPPIConfig(plan_scheme="frozen", plan_step_c=0.03), volts)
    truth = np.array([env.step(a)[4]["angle_deg"] for a in actions])
    env.restore(snap)
    assert truth.max() > 10.0
    assert np.array_equal(planned, truth)
    assert 0.0 < np.abs(frozen - truth).max() < 3.5


def test_planning_sub_step_settings_are_validated_and_reach_the_rollout_solver():
    env = _env()
    s = MPPIConfig(plan_step_c=0.05, plan_h_min=1e-3).plan_solver(env.config.solver)
    assert (s.step_c, s.h_min, s.method) == (0.05, 1e-3, env.config.solver.method)
    assert MPPIConfig(plan_step_c=None, plan_h_min=None).plan_solver(env.config.solver) == env.config.solver
    with pytest.raises(ValueError, match=r"plan_step_c must be in \(0, 1\]"):
        MPPIConfig(plan_step_c=0.0)
    with pytest.raises(ValueError, match="plan_h_min"):
        MPPIConfig(plan_h_min=0.2)  # longer than the 0.1-s planning step
    with pytest.raises(ValueError, match="plan_h_min"):
        fine = _env(physics_dt=0.01).config  # the rollouts take the env's 0.01-s step
        MPPIController(fine, settings=MPPIConfig(plan_physics_dt=None, plan_h_min=0.05))


def test_estimator_identifies_ambient_temperature_and_martensite_resistivity_of_a_randomised_plant():
    """MODEL.md §3.10: the spine starts at T_E with x_A = 0, so R = λ_M L0 / A_w (§3.7); on three
    randomised plants (T_E ± 10 K, λ_M × [0.95, 1.05]) the first observation gives both (to
    float32 rounding of the observation), and with ``identify=False`` the nominal values stay."""
    for seed in (1, 2, 3):
        env = _env(domain_randomization=True)
        obs, _ = env.reset(seed=seed)
        truth = env.model_params
        est = PhaseEstimator(env.config)
        est.reset()
        est.update(obs)
        assert truth.T_E != spine_gym.ModelParams().T_E
        assert est.params.T_E == pytest.approx(truth.T_E, abs=1e-4)
        assert est.params.lam_M == pytest.approx(truth.lam_M, rel=1e-6)
        assert est.kp[L.K_TE] == est.params.T_E
        plain = PhaseEstimator(env.config, identify=False)
        plain.reset()
        plain.update(obs)
        assert plain.params == env.config.params


# ---------------------------------------------------------------- disturbance estimate
STEP_30 = TargetProfile.step((0.0, 12.0), (30.0, -30.0))


def _pid_estimate(env, est, seed, loads):
    """Run the tuned PID through a +30 deg -> -30 deg step (12 s each) with ``est`` updated on every
    observation; the estimator at the end of the episode."""
    pid = PIDController(**load_tuned()["pid"], v_max=env.v_max, dt=env.control_period, temperature_limit=413.0)
    obs, _ = env.reset(seed=seed, options={"target": STEP_30, "loads": loads})
    est.reset()
    while True:
        est.update(obs)
        a, _ = pid.predict(obs)
        obs, _, te, tr, _ = env.step(a)
        if te or tr:
            return est


def test_disturbance_filter_identifies_the_austenite_resistivity_of_a_randomised_plant():
    """The env randomises λ_A by x U(0.95, 1.05) (not observable at the start, unlike λ_M): after
    the wires transform, the angle residual pins it; measured |λ̂_A/λ_A − 1| <= 0.0024 on three
    seeds, bound 0.005 (the nominal value is off by more than that on these plants)."""
    env = _env(episode_duration=24.0, domain_randomization=True)
    for seed in (2, 3):
        est = _pid_estimate(env, PhaseEstimator(env.config), seed, LoadSchedule())
        truth = env.model_params.lam_A
        assert abs(env.config.params.lam_A / truth - 1.0) > 0.005
        assert abs(est.lam_a / truth - 1.0) < 0.005
        assert np.array_equal(est.tip_force, [0.0, 0.0])  # forces=False: not estimated


def test_disturbance_filter_converges_to_an_unseen_constant_payload():
    """A 70-g payload on the nominal plant (λ_A known: lam_a_std tiny): the equivalent tip force
    converges to the payload's weight (0, −m g) = (0, −0.687 N); measured (−0.008, −0.658) N,
    bound 0.1 N. With λ_A free the same episode explains the residual by λ_A (−0.3 %) instead:
    at a held angle the angle cannot tell the two apart (docs/agents.md)."""
    env = _env(episode_duration=24.0)
    cfg = DisturbanceConfig(forces=True, lam_a_std=1e-6)
    est = _pid_estimate(env, PhaseEstimator(env.config, disturbance=cfg), 1, LoadSchedule(payload=0.07))
    truth = np.array([0.0, -0.07 * env.model_params.g])
    assert np.linalg.norm(est.tip_force - truth) < 0.1
    assert np.linalg.norm(PhaseEstimator(env.config).tip_force) == 0.0
    with pytest.raises(ValueError, match="angle_std must be a number in"):
        DisturbanceConfig(angle_std=0.0)
    with pytest.raises(ValueError, match="disturbance must be a DisturbanceConfig"):
        MPPIConfig(disturbance="on")


def test_mpc_estimated_tracks_a_randomised_loaded_plant_better_with_the_disturbance_estimate():
    """A 30-s validation episode of the hard group's kind of plants and loads (HARD_LIKE_KWARGS,
    seed VALIDATION_SEED_BASE + 3, never the suite): the estimated MPC with its λ_A estimate
    against the same MPC without (measured 13.0 vs 15.3 deg RMSE)."""
    env = _env(**HARD_LIKE_KWARGS, episode_duration=30.0)
    guard = env.temperature_limit - 5.0
    rmse = {}
    for name, dist in (("with", DisturbanceConfig()), ("without", None)):
        mpc = MPPIController(
            env.config, "estimated", settings=MPPIConfig(disturbance=dist), temperature_limit=guard
        )
        mpc.reset()
        obs, _ = env.reset(seed=VALIDATION_SEED_BASE + 3)
        err = []
        while True:
            a, _ = mpc.predict(obs)
            obs, _, te, tr, info = env.step(a)
            err.append(info["tracking_error_deg"])
            if te or tr:
                break
        rmse[name] = float(np.sqrt(np.mean(np.square(err))))
    print(rmse)
    assert rmse["with"] < 0.93 * rmse["without"]


# ---------------------------------------------------------------- oracle_causal: privileged but causal
LATER_PUSH = LoadSchedule(tip_force_events=((2.0, 4.0, (0.6, 0.2)),), payload=0.05)
CAUSAL = MPPIConfig(n_samples=8, horizon=3.0)


def _pushed_env_at(k: int):
    """An env 20 s long with a 0.6-N push from 2 s to 4 s and a 50-g payload, after ``k`` steps at
    1 V each side, and its last observation."""
    env = _env()
    target = TargetProfile.step((0.0, 2.5), (0.0, 20.0))
    obs, _ = env.reset(seed=3, options={"loads": LATER_PUSH, "target": target})
    for _ in range(k):
        obs, *_ = env.step(np.array([-0.6, -0.6], dtype=np.float32))
    return env, obs


def test_oracle_causal_plans_with_the_current_load_held_not_the_scheduled_push():
    """At t = 0.5 s the push (2-4 s) is inside the 3-s horizon: the oracle's loads carry it, the
    causal oracle's are the payload weight alone at every step; during the push (t = 2.5 s) the
    causal loads are push + weight held, also past the push's end at 4 s; at the push's onset
    step (k = 20) the first step re-solves the mechanics, no later one does."""
    weight = np.array([0.0, -0.05 * 9.81])
    push = np.array([0.6, 0.2])
    # (step, held load, steps of the oracle's horizon where the load changes: onset 20, end 40)
    for k, held, changes in ((5, weight, [15]), (20, weight + push, [0, 20]), (25, weight + push, [15])):
        env, obs = _pushed_env_at(k)
        causal = MPPIController(env.config, "oracle_causal", env=env, settings=CAUSAL)
        oracle = MPPIController(env.config, "oracle", env=env, settings=CAUSAL)
        _, _, loads, resolve, *_ = causal._problem(obs)
        _, _, future, future_resolve, *_ = oracle._problem(obs)
        assert loads.shape == (30, env.model_params.n_seg, 2)
        np.testing.assert_allclose(loads[:, 0, :], np.broadcast_to(held, (30, 2)), rtol=0, atol=1e-12)
        assert not np.any(loads[:, 1:, :])
        assert not np.allclose(future[:, 0, :], loads[:, 0, :])  # the oracle sees the push change
        assert np.flatnonzero(future_resolve).tolist() == changes
        assert np.flatnonzero(resolve).tolist() == ([0] if k == 20 else [])


def test_oracle_causal_targets_are_the_estimated_modes_preview_targets():
    """Same observations, same targets over the horizon as the estimated mode (observed target and
    its 1-s preview); the step at 2.5 s is beyond the preview at t = 0.5 s, so the causal targets
    stay 0 while the oracle's jump to 20 deg."""
    env, _ = _pushed_env_at(0)
    obs, _ = env.reset(seed=3, options={"target": TargetProfile.sine(25.0, 20.0)})
    causal = MPPIController(env.config, "oracle_causal", env=env, settings=CAUSAL)
    est = MPPIController(env.config, "estimated", settings=CAUSAL)
    for _ in range(6):  # the second call on extrapolates the preview's rate
        t_causal = causal._problem(obs)[4]
        t_est = est._problem(obs)[4]
        assert np.array_equal(t_causal, t_est)
        obs, *_ = env.step(np.array([-0.6, -0.6], dtype=np.float32))
    assert np.ptp(t_causal) > 10.0  # a moving sine target, not a constant
    env, obs = _pushed_env_at(5)
    causal = MPPIController(env.config, "oracle_causal", env=env, settings=CAUSAL)
    oracle = MPPIController(env.config, "oracle", env=env, settings=CAUSAL)
    assert np.array_equal(causal._problem(obs)[4], np.zeros(30))
    assert oracle._problem(obs)[4].max() == pytest.approx(20.0)


def test_mpc_mode_errors_name_every_allowed_mode_and_causal_needs_the_env():
    env = _env()
    obs, _ = env.reset(seed=1)
    with pytest.raises(ValueError) as err:
        MPPIController(env.config, "causal")
    for mode in ("oracle", "oracle_causal", "estimated"):
        assert repr(mode) in str(err.value)
    with pytest.raises(ValueError, match="oracle_causal mode needs the env"):
        MPPIController(env.config, "oracle_causal", settings=CAUSAL).predict(obs)


def test_energy_weighted_oracle_builds_either_privileged_entry_and_rejects_others():
    from spine_gym.agents.runtime import ORACLE_NAMES, energy_weighted_oracle

    env = _env()
    assert ORACLE_NAMES == ("mpc_oracle", "mpc_oracle_causal")
    ctrl = energy_weighted_oracle(env, 2.0, "mpc_oracle_causal")
    assert ctrl.mode == "oracle_causal" and ctrl.settings.w_energy == 2.0 and ctrl.env is env
    assert energy_weighted_oracle(env, 0.5).mode == "oracle"
    with pytest.raises(ValueError, match="name must be one of"):
        energy_weighted_oracle(env, 1.0, "mpc_estimated")



def test_energy_weighted_oracle_has_the_registry_entrys_guard():
    """The oracle's own guard is the one its registry entry gets (the env's limit minus the margin),
    and none where the plant cuts hot wires itself (``SmaSpine-v2``)."""
    from spine_gym.agents.runtime import build_controller, energy_weighted_oracle

    env = _env()
    expected = build_controller("mpc_oracle", env).temperature_limit
    assert energy_weighted_oracle(env, 1.0).temperature_limit == expected == env.temperature_limit - GUARD_MARGIN_K
    cut = gym.make("SmaSpine-v2").unwrapped
    assert cut.thermal_cutoff is not None and energy_weighted_oracle(cut, 1.0).temperature_limit is None
