"""Sampling model-predictive control (MPPI) of ``SmaSpine3D-v0`` and ``SmaSpineChain-v0``.

The MPPI of :mod:`.mpc` (smooth voltage sequences, weighting by ``exp(−cost / λ)``, warm start
from the shifted plan, the same :class:`~.mpc.MPPIConfig`) generic over the wires of a
:class:`~spine_gym.layout.SpineLayout`: one voltage sequence per wire group (4 for the seed's
module, 4 per module for a chain). The rollouts are one call of
:func:`spine_gym.physics.spatial.rollout.rollout_many` on the spatial core the env runs
(:func:`spine_gym.physics.spatial.integrate.advance`); what they record is turned into the env's
readings by the env's own probe (tip bending vector [deg], tip position [mm], temperatures [K],
cumulative Joule heat [J]), so the cost uses the env's definitions:

* **tracking**: the env's tracked entry (its table's task: the tip bending vector for
  ``SmaSpine3D-v0``, the tip position for ``SmaSpineChain-v0``) against the target over the
  horizon, ``w_track Σ_h |e_h · REFERENCE_ERROR_SCALE / error_scale|²`` — the error in units of
  the env's reward ``error_scale`` (10° by default for the bending vector, as the planar angle;
  20 mm for the tip position), so one ``w_track`` serves every env;
* **energy**: ``w_energy ×`` the electrical energy of the rollout [J] (all wires, the env's
  Joule accounting);
* **over-temperature**: ``w_temp Σ_h Σ_wires max(0, T − T_lim)²`` with T_lim the env's limit
  minus ``temp_margin``.

Voltages are planned in seed-equivalent volts in [0, ``v_max``] for every wire; a chain module's
shorter wires get them times :attr:`SpineLayout.voltage_scale`, exactly as the env maps an
action (``volts = (a + 1) · volt_coef``), so the action of wire j is ``2 V_j / v_max − 1``.

State modes as the planar MPC: ``"oracle"`` (**privileged**: the env's true state through its
public ``snapshot()``, the episode's parameters, future targets and loads), ``"oracle_causal"``
(**privileged** state and parameters as ``"oracle"``, but the current load held over the horizon
and the targets from the observed target and its preview, as ``"estimated"``) and ``"estimated"``
(:class:`~.estimator.SpatialPhaseEstimator` per wire from the observed temperatures and
resistances; nominal parameters but T_E and λ_M identified; no loads; targets from the observed
target and its preview; the observed tracked entry minus the estimated one held over the horizon
as an output disturbance).
"""

from __future__ import annotations

import numpy as np

from ..envs import readout as ro
from ..envs.loads import LoadSchedule
from ..envs.planar import PlanarConfig
from ..envs.spatial import SpatialConfig
from ..envs.table import SENSOR_SOURCES
from ..physics.spatial import columns as SL
from ..physics.spatial.record import record, record_size
from ..physics.spatial.rollout import rollout_many as rollout_many_spatial
from ..physics.spatial.rollout import rollout_many_serial as rollout_many_spatial_serial
from ..physics.spatial.work import make_work
from .base import observation_batch, volts_to_action
from .estimator import SpatialPhaseEstimator
from .mpc import PLAN_FIELDS, PRIVILEGED_MODES, MPPIBase, MPPIConfig

__all__ = [
    "SpatialMPPIController",
    "SPATIAL_PLAN_FIELDS",
    "REFERENCE_ERROR_SCALE",
    "SpatialReadings",
    "drive_patterns",
]

N_DIRECTIONS = 8  # bending directions of the always-sampled full-drive patterns (drive_patterns)
REFERENCE_ERROR_SCALE = PlanarConfig.error_scale  # [deg] the planar env's default: errors are scaled to it
# [deg/s at the reference scale] faster preview changes are steps (held, not extrapolated): the
# suites' circles and figure-eights move the target by <= ~25 deg/s (3-D) or mm/s (chain), a step's
# preview jumps by >= 10 x that in one 0.1-s period
MAX_PREVIEW_RATE = 50.0
# config fields the plan depends on besides PLAN_FIELDS (the layout, the task's scale)
SPATIAL_PLAN_FIELDS = (*PLAN_FIELDS, "layout", "error_scale")


class SpatialReadings:
    """The env's readings of spatial record rows: its probe (:func:`.readout.spatial_probe`)
    with the record columns of its batch, and where the tracked entry, the temperatures and the
    Joule heat sit in a probe row (from the env's table).

    Args:
        env: a spatial env (its ``BATCH`` class and configuration give the column maps).
    """

    def __init__(self, env):
        cfg = env.config
        batch = type(env).BATCH(cfg, 1, parallel=False)
        lay = cfg.layout
        self.record_cols = batch.record_cols
        self.probe_cols = batch.probe_cols
        self.record_size = int(record_size(lay.n_wires, lay.n_modules, lay.n_seg))
        task = batch.table.task
        self.task = slice(
            int(self.probe_cols[SENSOR_SOURCES[task.source]]),
            int(self.probe_cols[SENSOR_SOURCES[task.source]]) + task.size,
        )
        nw = lay.n_wires
        self.temp = slice(int(self.probe_cols[ro.PB_TEMP]), int(self.probe_cols[ro.PB_TEMP]) + nw)
        self.joule = slice(int(self.probe_cols[ro.PB_JOULE]), int(self.probe_cols[ro.PB_JOULE]) + nw)
        # nominal per-wire constants (L0 / A_w, wire volume) of an unloaded nominal episode
        batch.reset_env(
            0, np.random.default_rng(0), {"params": cfg.params, "loads": LoadSchedule(dim=cfg.force_dim)}
        )
        self.ohm = batch.ohm[0].copy()
        self.wvol = batch.wvol[0].copy()

    def __call__(self, rec: np.ndarray, ohm: np.ndarray, wvol: np.ndarray) -> np.ndarray:
        """(M, probe width) probe rows of (M, R) record rows of one spine (``ohm``, ``wvol``: (W,))."""
        m = rec.shape[0]
        probe = np.empty((m, int(self.probe_cols[-1])))
        rows = np.arange(m, dtype=np.int64)
        ro.spatial_probe(
            rows,
            rec,
            self.record_cols,
            np.repeat(ohm[None, :], m, axis=0),  # fresh writable rows (a broadcast of one row is read-only,
            np.repeat(wvol[None, :], m, axis=0),  # and numba compiles another specialisation for it)
            self.probe_cols,
            probe,
        )
        return probe


def drive_patterns(layout, n_directions: int = N_DIRECTIONS) -> np.ndarray:
    """(n_directions, W) full-drive patterns always sampled: for each of ``n_directions``
    bending directions φ evenly spaced in the module frame, every wire within 45° of φ in every
    module (for the seed's module toward a wire, one wire; between two, both)."""
    psi = np.radians([w.psi_deg for m in layout.modules for w in m.wires])
    phi = 2.0 * np.pi * np.arange(n_directions) / n_directions
    return (np.cos(psi[None, :] - phi[:, None]) >= np.cos(np.pi / 4.0) - 1e-9).astype(np.float64)


class SpatialMPPIController(MPPIBase):
    """MPPI for a spatial env (see the module docstring); build it with :meth:`from_env`.

    Args:
        env: the spatial env it plans for (``SmaSpine3D-v0``, ``SmaSpineChain-v0``; its
            configuration, table and batch class); the privileged modes read its state, and
            :meth:`bind` follows each episode's env.
        mode: ``"oracle"`` (privileged), ``"oracle_causal"`` (privileged state, current load,
            observed targets) or ``"estimated"``.
        settings: :class:`~.mpc.MPPIConfig` (default :meth:`default_settings` of the env).
        temperature_limit: guard of :class:`~.base.BaseController` [K] (a wire observed at or
            above it gets 0 V), or None.
    """

    plan_fields = SPATIAL_PLAN_FIELDS

    def __init__(self, env, mode: str = "estimated", *, settings: MPPIConfig | None = None, **kwargs):
        env = getattr(env, "unwrapped", env)
        cfg = getattr(env, "config", None)
        if not isinstance(cfg, SpatialConfig):
            raise ValueError(
                f"env must be a spatial env (SmaSpine3D-v0, SmaSpineChain-v0), got {type(env).__name__}"
            )
        for key in ("v_max", "dt"):
            if key in kwargs:
                raise ValueError(f"{key} comes from the env; do not pass it to SpatialMPPIController")
        settings = self.default_settings(cfg) if settings is None else settings
        super().__init__(
            settings,
            mode,
            cfg.n_wires,
            cfg.control_period,
            cfg.physics_dt,
            extremes=drive_patterns(cfg.layout),
            v_max=cfg.v_max,
            **kwargs,
        )
        s = self.settings
        self.env_config = cfg
        self.readings = SpatialReadings(env)
        table = env.table
        self._idx = {
            key: env.obs_index(key)
            for key in (table.task.key, "temperature", "resistance", "previous_action")
        }
        self._task_obs = env.obs_index(table.task.key)
        target = [e.key for e in table.entries if e.source == "target"][0]
        preview = [e.key for e in table.entries if e.source == "preview"][0]
        self._target_obs, self._preview_obs = env.obs_index(target), env.obs_index(preview)
        read = (*self._idx.values(), self._target_obs, self._preview_obs)
        self._obs_size = 1 + max(i.stop - 1 for i in read)  # entries an observation must have
        self._target_low = table.low[self._target_obs].astype(np.float64)
        self._target_high = table.high[self._target_obs].astype(np.float64)
        self._err_scale = REFERENCE_ERROR_SCALE / cfg.error_scale
        self._rate_limit = MAX_PREVIEW_RATE / self._err_scale  # in the task's unit per s
        self._scale = np.asarray(cfg.layout.voltage_scale, dtype=np.float64)
        self._kernel = rollout_many_spatial if s.parallel else rollout_many_spatial_serial
        self._ks = s.plan_solver(cfg.solver).to_kernel()
        self._t_lim = cfg.temperature_limit - s.temp_margin
        lay = cfg.layout
        self._nominal = lay.to_kernel()
        self._shape = (lay.n_wires, lay.n_modules, lay.n_seg)
        self.estimator = (
            SpatialPhaseEstimator(cfg, {k: self._idx[k] for k in SpatialPhaseEstimator.KEYS})
            if mode == "estimated"
            else None
        )
        n, h = s.n_samples, self.horizon_steps
        self._work = np.empty((n, lay.state_size()))
        self._rec = np.empty((n, h, self.readings.record_size))
        self._status = np.empty(n, dtype=np.int64)
        self.bind(env)
        self.reset()

    @classmethod
    def from_env(cls, env, **kwargs) -> SpatialMPPIController:
        """Build for a spatial env (the registry's constructor)."""
        return cls(env, **kwargs)

    @staticmethod
    def default_settings(cfg: SpatialConfig) -> MPPIConfig:
        """The default :class:`MPPIConfig` of a spatial env: the planar horizon (3 s: a cold
        antagonist needs about that at full drive before it pulls, a shorter horizon cannot see a
        reversal pay off) with fewer rollouts than the planar 32, so that the plan time stays
        near the 0.1-s control period on the spatial core (benchmarks/bench_mpc.py); a chain's
        rollouts cost about twice a module's."""
        if cfg.n_modules == 1:
            return MPPIConfig(n_samples=16, horizon=3.0)
        return MPPIConfig(n_samples=12, horizon=3.0)

    # ------------------------------------------------------------------ observation
    def _check_obs(self, observation):
        obs, single = observation_batch(observation, self._obs_size)
        if not np.all(np.isfinite(obs)):
            raise ValueError("observation must be finite, got NaN or inf")
        return obs, single

    def _temperatures(self, obs):
        return obs[:, self._idx["temperature"]]

    def _action(self, obs, volts):
        """Guard, clip to [0, v_max] seed-equivalent volts, action 2 V / v_max − 1 per wire."""
        if self.temperature_limit is not None:
            volts = np.where(self._temperatures(obs) >= self.temperature_limit, 0.0, volts)
        return volts_to_action(np.clip(volts, 0.0, self.v_max), self.v_max)

    # ------------------------------------------------------------------ the planning problem
    def _problem(self, obs):
        """(state0, kp, kw, km, loads, resolve, targets (H, d), offset (d,), ohm, wvol)."""
        h = self.horizon_steps
        if self.mode in PRIVILEGED_MODES:
            snap, (state0, kp, kw, km) = self._oracle_snapshot("states", "kps", "kws", "kms")
            a = snap.arrays
            loads, resolve = self._snapshot_loads(snap, self._shape[2])
            targets = self._snapshot_targets(snap) if self.mode == "oracle" else self._observed_targets(obs)
            offset = np.zeros(targets.shape[1])
            return state0, kp, kw, km, loads, resolve, targets, offset, a["ohm"], a["wvol"]
        est = self.estimator
        state0 = est.update(obs)
        loads = np.zeros((h, self._shape[2], 3))
        resolve = np.zeros(h, dtype=np.bool_)
        r = self.readings
        now = self._readings_of(state0, est.kp, est.kw, est.km, r.ohm, r.wvol)
        offset = obs[self._task_obs] - now[r.task]
        targets = self._observed_targets(obs)
        return state0, est.kp, est.kw, est.km, loads, resolve, targets, offset, r.ohm, r.wvol

    def _observed_targets(self, obs) -> np.ndarray:
        """(H, d) targets from the observed target and its preview (:meth:`MPPIBase._preview_targets`),
        clipped to the env's target bounds."""
        targets = self._preview_targets(
            obs[self._target_obs], obs[self._preview_obs], self.env_config.preview_steps, self._rate_limit
        )
        return np.clip(targets, self._target_low, self._target_high)

    def _readings_of(self, state, kp, kw, km, ohm, wvol) -> np.ndarray:
        """Probe row of one spatial state (the env's readings of it)."""
        row = np.empty((1, self.readings.record_size))
        record(state, kp, kw, km, make_work(*self._shape), row[0])
        return self.readings(row, ohm, wvol)[0]

    def _score(self, volts, problem) -> np.ndarray:
        state0, kp, kw, km, loads, resolve, targets, offset, ohm, wvol = problem
        n, h = volts.shape[0], volts.shape[1]
        self._kernel(
            state0,
            kp,
            self._ks,
            kw,
            km,
            np.ascontiguousarray(volts * self._scale),
            np.ascontiguousarray(loads),
            np.ascontiguousarray(resolve),
            self.plan_dt,
            self.plan_sub,
            self._work,
            self._rec,
            self._status,
        )
        r = self.readings
        probe = r(self._rec.reshape(n * h, -1), ohm, wvol).reshape(n, h, -1)
        err = (probe[:, :, r.task] + offset - targets[None, :, :]) * self._err_scale
        q0 = state0[SL.wire_offset(SL.F_QJ, self._shape[0]) :][: self._shape[0]] * wvol
        energy = np.sum(probe[:, -1, r.joule] - q0[None, :], axis=1)
        return self._cost(np.sum(err * err, axis=2), energy, probe[:, :, r.temp], self._status)
