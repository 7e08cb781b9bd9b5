"""The env's and the MPC's kernels agree on the two-wire planar spine whichever core runs it.

``SpineLayout.planar()`` on the spatial core against the planar core, both with the default coupled
step, at the gates of tests/physics/test_spatial_coupled.py (SPATIAL.md §8.3; that file compares
``simulate``): |ΔT| < 1e-3 K, and |ΔΘ| < 0.1°, the gate of drives that switch the wires through
their transformation onsets (the two steps linearise slightly differently and the onsets amplify
it; 1e-4° is the smooth drive's). Here the env's control periods (each core's ``control.step_spine``,
an episode from rest) and the MPC's rollouts (``rollout.rollout_many``, from a warm transformed state), random
voltages on both wires; ``benchmarks/bench_planar_on_spatial.py`` measured 1.2e-3° and 3e-8° on
larger runs of the same kind, and times them.
"""

import numpy as np

from spine_gym import ModelParams, SolverOptions, SpineLayout, simulate
from spine_gym.physics.columns import OK
from spine_gym.physics.planar import columns as PL
from spine_gym.physics.planar import control as planar_control
from spine_gym.physics.planar import rollout as planar_rollout
from spine_gym.physics.planar.record import OUT_ANGLE, OUT_SIZE
from spine_gym.physics.spatial import columns as SL
from spine_gym.physics.spatial import control as spatial_control
from spine_gym.physics.spatial import rollout as spatial_rollout
from spine_gym.physics.spatial.integrate import init_state
from spine_gym.physics.spatial.record import record_size
from spine_gym.physics.spatial.work import sizes
from spine_gym.simulate import initial_state

GATE_SWITCHING_DEG, GATE_TEMP_K = 0.1, 1e-3
DT = 0.1  # [s] the envs' control period
LAYOUT = SpineLayout.planar()
KP, KW, KM = LAYOUT.to_kernel()
KS = SolverOptions().to_kernel()
NW, NM, NS = sizes(KW, KM)
BEND = SL.sens_offset(NW, NM, NS) + 2 * NM  # record row: tip bending vector [rad]
TEMP = SL.wire_offset(SL.F_T, NW)  # record row: wire temperatures [K]


def _assert_agree(theta_planar, t_planar, rec):
    """Θ [rad] (...) and (right, left) temperatures (..., 2) of the planar core against spatial rows."""
    d_theta = np.degrees(np.abs(rec[..., BEND] - theta_planar)).max()
    d_temp = np.abs(rec[..., TEMP : TEMP + 2] - t_planar).max()
    assert d_theta < GATE_SWITCHING_DEG and d_temp < GATE_TEMP_K, (d_theta, d_temp)


def test_control_periods_of_both_cores_agree_over_an_episode_of_random_voltages():
    b, periods = 4, 100
    volts = np.random.default_rng(1).uniform(0.0, 5.0, (periods, b, 2))
    planar = np.tile(initial_state(ModelParams()), (b, 1))
    spatial = np.zeros((b, LAYOUT.state_size()))
    for s in spatial:
        assert init_state(s, KP, KS, KW, KM, np.zeros((NS, 3))) == OK
    kp_planar = ModelParams().to_kernel()
    meas, rec = np.empty((periods, b, OUT_SIZE)), np.empty((periods, b, record_size(NW, NM, NS)))
    for k, i in np.ndindex(periods, b):  # each spine's control periods, as the envs step them
        v_r, v_l = volts[k, i]
        backup, first = np.empty_like(planar[i]), k == 0
        st = planar_control.step_spine(
            planar[i], backup, kp_planar, KS, v_r, v_l, np.zeros((NS, 2)), first, DT, 1, meas[k, i]
        )
        assert st == OK
        backup = np.empty_like(spatial[i])
        st = spatial_control.step_spine(
            spatial[i], backup, KP, KS, KW, KM, volts[k, i], np.zeros((NS, 3)), first, DT, 1, rec[k, i]
        )
        assert st == OK
    _assert_agree(meas[..., OUT_ANGLE], meas[..., [PL.X_TR, PL.X_TL]], rec)


def test_mpc_rollouts_of_both_cores_agree_from_a_warm_state():
    b, h = 8, 20
    volts = np.random.default_rng(2).uniform(0.0, 5.0, (b, h, 2))
    v = np.full(1000, 3.2)  # 10 s of the right wire at 3.2 V: transformed, warm
    start_p = simulate(10.0, v, np.zeros(1000)).final_state
    start_s = simulate(10.0, np.stack([v, np.zeros(1000)], axis=1), layout=LAYOUT).final_state
    no_resolve = np.zeros(h, dtype=np.bool_)
    angle, temp, joule = np.empty((b, h)), np.empty((b, h, 2)), np.empty((b, h, 2))
    status = np.empty(b, dtype=np.int64)
    planar_rollout.rollout_many_serial(
        start_p, ModelParams().to_kernel(), KS, volts[:, :, 0].copy(), volts[:, :, 1].copy(),
        np.zeros((h, NS, 2)), no_resolve, DT, 1, np.empty((b, start_p.shape[0])), angle, temp, joule, status
    )
    assert (status == OK).all()
    rec = np.empty((b, h, record_size(NW, NM, NS)))
    spatial_rollout.rollout_many_serial(
        start_s, KP, KS, KW, KM, volts, np.zeros((h, NS, 3)), no_resolve, DT, 1,
        np.empty((b, start_s.shape[0])), rec, status
    )
    assert (status == OK).all()
    _assert_agree(angle, temp, rec)
