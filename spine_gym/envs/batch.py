"""B spines of one env driven by its declarative table: the batch behind the single and the vector env.

:class:`TableBatch` holds the per-environment arrays (model state, episode data, the writer's
memory), resets one environment with its own generator and steps all active ones at once
(:meth:`TableBatch.advance`): one jitted call of the plant's step kernel
(:mod:`.step_kernels`: the inputs of :func:`.readout.begin_step` — actions, voltages,
loads —, the physics of every spine, its probe — the physics readings in the common probe layout
of :mod:`.readout` — and :func:`.readout.finish_rows` — sensors, observation, reward,
info, from the env's :class:`~.table.Table`), all into preallocated per-environment buffers
(``obs``, ``last_row``, ``status``, ``terminated``, ``truncated``) that the envs copy out.
Subclasses are the plants (:class:`spine_gym.envs.spatial.SpatialBatch`, …): they allocate the
physics arrays, draw the episode's target, solve, record and probe their spines at a reset and name
their step kernel and its plant tuple. The single env is a batch of one, so single and vector env
run the same code and give the same numbers (tested bit for bit).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..params import ModelParams
from ..physics import columns as L
from ..uncertainty import ParameterUncertainty
from . import readout as ro
from ._infos import status_text
from .config import RESET_OPTION_KEYS, BaseEnvConfig, validate_actions
from .loads import LoadSchedule
from .table import Table

__all__ = ["TableBatch", "SpineSnapshot"]

# per-environment arrays of every batch (the plant adds its own through PLANT_ARRAYS)
COMMON_ARRAYS = (
    "states",  # model state vector
    "kps",  # the episode's (possibly randomised) constants
    "loads",  # vertex forces of the last step
    "meas",  # the plant's record row of the last step
    "probe",  # the probe row of the last step
    "status",
    "targets",
    "forces",
    "resolve_plan",
    "volts",
    "ohm",  # [1/m] L0/A_w of each wire group
    "wvol",  # [m^3] wire volume of each wire group
    "last_row",  # the table row of the last step or reset (true values)
    *ro.Memory._fields,
)
_FLOATS = (np.dtype(np.float32), np.dtype(np.float64))  # action dtypes taken without validate_actions
# entries of a plant tuple that come from the configuration (the others are batch attributes)
_CFG_PLANT = ("physics_dt", "n_sub")


@dataclass(frozen=True, eq=False)
class SpineSnapshot:
    """The full state of one environment: model state, episode data, bookkeeping and RNG.

    Made by ``snapshot()`` of :class:`TableBatch`, :class:`~spine_gym.envs.SmaSpineEnv` or
    :class:`~spine_gym.envs.SmaSpineVectorEnv`; ``restore(snapshot)`` puts it back, after which the
    env continues bit for bit as it would have from the moment of the snapshot (tested). The arrays
    are private copies (read-only); a snapshot can be restored any number of times and into any
    env of the same configuration.

    Attributes:
        arrays: name -> copy of the environment's row of each array of ``TableBatch.snapshot_arrays``.
        episode: the episode's (TargetProfile, LoadSchedule, ModelParams).
        rng_state: ``bit_generator.state`` of the env's generator (sensor noise and later resets),
            or None if the batch alone was snapshotted.
        extra: env-level flags (e.g. whether the episode has ended).
    """

    arrays: Mapping[str, np.ndarray]
    episode: tuple[Any, LoadSchedule, ModelParams]  # (target, loads, params)
    rng_state: dict | None = None
    extra: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def state(self) -> np.ndarray:
        """The model state vector (``spine_gym.physics.planar.columns``, or
        ``spine_gym.physics.spatial.columns`` for a spatial spine)."""
        return self.arrays["states"]

    @property
    def kp(self) -> np.ndarray:
        """The episode's kernel constants (``ModelParams.to_kernel``)."""
        return self.arrays["kps"]

    @property
    def step_index(self) -> int:
        """Control steps taken in the episode."""
        return int(self.arrays["k"])

    def with_rng(self, rng_state: dict | None, **extra) -> SpineSnapshot:
        """A copy carrying the env's generator state and flags."""
        return dataclasses.replace(self, rng_state=rng_state, extra={**self.extra, **extra})


class TableBatch:
    """B spines with their episode data (see the module docstring).

    Args:
        cfg: validated configuration (a :class:`~.config.BaseEnvConfig` subclass with ``table()``,
            ``n_wires``, ``n_seg``, ``force_dim``, ``volt_coef``, ``energy_reference``).
        num_envs: B.
        parallel: step with the ``prange`` kernel (else its serial twin).
        action_shape: the shape of the actions the env takes, (B, W) by default (a single env's
            is (W,)); :meth:`check_actions` names it in its errors.
    """

    PLANT_ARRAYS: tuple[str, ...] = ()
    PLANT: tuple[str, ...] = ()  # the plant tuple of its step kernel (step_kernels.*_PLANT)
    RECORD_SIZE: int = 0

    def __init__(
        self, cfg: BaseEnvConfig, num_envs: int, parallel: bool, action_shape: tuple[int, ...] | None = None
    ):
        self.cfg = cfg
        self.num_envs = b = int(num_envs)
        self.action_shape = (b, cfg.n_wires) if action_shape is None else tuple(action_shape)
        self.parallel = bool(parallel)
        self.table: Table = cfg.table()
        self.obs_names = self.table.obs_names
        self.obs_low, self.obs_high = self.table.low, self.table.high
        nw, n, f, d = cfg.n_wires, cfg.n_seg, cfg.force_dim, self.table.task_dim
        self.ks = cfg.solver.to_kernel()
        self._alloc_plant(b)
        self.backup = np.zeros_like(self.states)
        self.loads = np.zeros((b, n, f))
        self.meas = np.zeros((b, self.record_size()))
        self.probe_cols = ro.probe_cols(nw, cfg.n_modules)
        self.probe = np.zeros((b, self.probe_cols[-1]))
        self.status = np.zeros(b, dtype=np.int64)
        n_grid = cfg.n_steps + 1 + cfg.preview_steps
        self.time_grid = np.arange(n_grid) * cfg.control_period  # [s] t_k = k Δt
        self.targets = np.zeros((b, n_grid, d))
        self.forces = np.zeros((b, cfg.n_steps, f))  # [N] tip force + payload weight over step k
        self.resolve_plan = np.zeros((b, cfg.n_steps), dtype=np.bool_)
        self.volts = np.zeros((b, nw))  # [V] applied over the last step
        self.ohm = np.zeros((b, nw))
        self.wvol = np.zeros((b, nw))
        self.last_row = np.zeros((b, self.table.width))
        self.mem = ro.Memory(
            k=np.zeros(b, dtype=np.int64),
            joule=np.zeros((b, nw)),
            hist=np.zeros((b, cfg.sensor_delay + 1, self.table.n_channels)),
            prev_task=np.zeros((b, d)),
            prev_action=np.full((b, nw), -1.0),
        )
        self.spec = self._spec_of(cfg)
        self.episodes: list[tuple[Any, LoadSchedule, ModelParams] | None] = [None] * b
        self.reward_col = self.table.cols["reward"].start
        self.row_ids = np.arange(b)
        # the step's buffers, written in place at the rows stepped (no per-step allocation)
        self.obs = np.zeros((b, self.table.obs_dim), dtype=np.float32)  # last observation
        self.terminated = np.zeros(b, dtype=np.bool_)
        self.truncated = np.zeros(b, dtype=np.bool_)
        self.clipped = np.zeros((b, nw))  # clipped actions of the step
        self.resolve = np.zeros(b, dtype=np.bool_)
        self.noise = np.zeros((b, self.table.n_channels))  # stays 0 without sensor noise
        self._coef = np.broadcast_to(np.asarray(cfg.volt_coef, dtype=np.float64), (nw,)).copy()
        self._fresh_actions = np.full((b, nw), -1.0)
        self._out = tuple(
            ro.Out(obs=self.obs, row=self.last_row, terminated=self.terminated, truncated=self.truncated)
        )
        self._spec = tuple(self.spec)
        self._mem = tuple(self.mem)
        inputs = (self.probe, self.status)
        tail = (self.volts, self.loads, self.targets, self.noise)
        self._step_in = (*inputs, self.clipped, *tail)  # ro.Step of a step
        self._reset_in = (*inputs, self._fresh_actions, *tail)  # ro.Step of a reset
        self._drive = (self._coef, self.forces, self.resolve_plan, self.resolve)
        self._plant = tuple(getattr(cfg, k) if k in _CFG_PLANT else getattr(self, k) for k in self.PLANT)

    def _spec_of(self, cfg: BaseEnvConfig) -> ro.Spec:
        """The readout's maps and settings (:data:`.readout.Spec`) from the table and ``cfg``; sets
        :attr:`noise_sigma` and :attr:`noisy`."""
        maps = self.table.spec_arrays({pb: int(self.probe_cols[pb]) for pb in range(ro.N_PB)})
        self.noise_sigma = maps["sigma"]
        self.noisy = bool(self.noise_sigma.any())
        settings = np.zeros(ro.N_SETTINGS)
        settings[ro.S_PERIOD] = cfg.control_period
        settings[ro.S_ERROR_SCALE] = cfg.error_scale
        settings[ro.S_ENERGY_COEF] = cfg.energy_weight / cfg.energy_reference
        settings[ro.S_COST_WEIGHT] = cfg.cost_weight
        settings[ro.S_T_LIMIT] = cfg.temperature_limit
        settings[ro.S_CUTOFF] = math.inf if cfg.thermal_cutoff is None else cfg.thermal_cutoff
        counts = np.zeros(ro.N_COUNTS, dtype=np.int64)
        counts[ro.C_PREVIEW] = cfg.preview_steps
        counts[ro.C_MAX_STEPS] = cfg.n_steps
        return ro.Spec(
            qcol=maps["qcol"],
            probe_cols=self.probe_cols,
            chan_src=maps["chan_src"],
            chan_dst=maps["chan_dst"],
            obs_cols=maps["obs_cols"],
            task=maps["task"],
            low=self.table.low.astype(np.float64),
            high=self.table.high.astype(np.float64),
            settings=settings,
            counts=counts,
        )

    # ------------------------------------------------------------------ plant hooks
    def _alloc_plant(self, b: int) -> None:
        """Allocate ``states``, ``kps`` and the plant's arrays (PLANT_ARRAYS)."""
        raise NotImplementedError

    def record_size(self) -> int:
        raise NotImplementedError

    def _parse_target(self, target) -> Any:
        """A pinned target of ``reset(options={"target": ...})`` as the plant's target object."""
        raise NotImplementedError

    def _sample_target(self, rng: np.random.Generator) -> Any:
        raise NotImplementedError

    def _target_grid(self, i: int, target) -> np.ndarray:
        """(n_grid, d) target of the tracked entry at the control instants."""
        raise NotImplementedError

    def _set_episode(self, i: int, params: ModelParams, kp: np.ndarray | None) -> None:
        """Per-episode constants of spine ``i`` (kps[i], ohm[i], wvol[i] and plant tables)."""
        raise NotImplementedError

    def _init_state(self, i: int, vforce: np.ndarray) -> int:
        raise NotImplementedError

    def _step_kernel(self):
        """The plant's step kernel of :mod:`.step_kernels` (looked up per call: the benchmarks
        wrap the module attribute), parallel or serial as ``self.parallel``."""
        raise NotImplementedError

    def _record(self, rows: np.ndarray) -> None:
        raise NotImplementedError

    def _probe(self, rows: np.ndarray) -> None:
        raise NotImplementedError

    # ------------------------------------------------------------------ facts
    @property
    def max_steps(self) -> int:
        """Truncation step count (the vector env may lower it to ``max_episode_steps``)."""
        return int(self.spec.counts[ro.C_MAX_STEPS])

    @max_steps.setter
    def max_steps(self, value: int) -> None:
        self.spec.counts[ro.C_MAX_STEPS] = int(value)

    @property
    def snapshot_arrays(self) -> tuple[str, ...]:
        return (*COMMON_ARRAYS, *self.PLANT_ARRAYS)

    def _array(self, name: str) -> np.ndarray:
        return getattr(self.mem, name) if name in ro.Memory._fields else getattr(self, name)

    # ------------------------------------------------------------------ reset
    def _draw_params(self, rng: np.random.Generator, opts: dict) -> tuple[ModelParams, np.ndarray | None]:
        cfg = self.cfg
        params = opts.get("params")
        if params is not None:
            return params, None
        dr = cfg.domain_randomization
        if isinstance(dr, ParameterUncertainty):
            return dr.draw(rng, cfg.params), None
        if dr:
            draws = {name: float(rng.uniform(lo, hi)) for name, lo, hi in dr}
            try:
                return cfg.params.replace(**draws), None
            except ValueError as e:
                raise ValueError(f"domain_randomization drew an invalid parameter set {draws}: {e}") from None
        return cfg.params, self.nominal_kp

    def reset_env(self, i: int, rng: np.random.Generator, options=None) -> np.ndarray:
        """Start a new episode in environment ``i`` and return its first observation (float32).

        The draws come from ``rng`` in this order: target, load schedule, randomised parameters
        (each only if not pinned by ``options``), then the sensor noise.
        """
        cfg = self.cfg
        opts = self.parse_options(options)
        target = opts.get("target")
        if target is None:
            target = self._sample_target(rng)
        loads = opts.get("loads")
        if loads is None:
            loads = LoadSchedule.sample(
                rng,
                cfg.episode_duration,
                cfg.tip_force_range,
                cfg.tip_force_count,
                cfg.tip_force_duration,
                cfg.payload_range,
                dim=cfg.force_dim,
            )
        params, kp = self._draw_params(rng, opts)
        self._set_episode(i, params, kp)
        self.episodes[i] = (target, loads, params)
        self.targets[i] = self._target_grid(i, target)
        weight = loads.payload_force(params.g)
        self.forces[i] = loads.tip_force(self.time_grid[: cfg.n_steps]) + weight
        plan = self.resolve_plan[i]
        plan[0] = np.any(self.forces[i, 0] != weight)  # the initial state is solved under the payload only
        plan[1:] = np.any(self.forces[i, 1:] != self.forces[i, :-1], axis=1)
        self.loads[i] = 0.0
        self.loads[i, 0] = weight
        st = self._init_state(i, self.loads[i])
        if st != L.OK:
            raise ValueError(
                f"the initial state cannot be solved under a payload of {loads.payload:g} kg "
                f"({L.STATUS_TEXT.get(st, st)}); use a lighter payload"
            )
        self.status[i] = L.OK
        rows = self.row_ids[i : i + 1]
        self._record(rows)
        self._probe(rows)
        if self.noisy:
            self.noise[i] = rng.normal(size=self.table.n_channels) * self.noise_sigma
        ro.finish(rows, self._reset_in, self._mem, self._spec, self._out, True)
        return self.obs[i].copy()

    def parse_options(self, options) -> dict[str, Any]:
        """Validate ``reset(options=...)``: keys among ``target``, ``loads``, ``params``."""
        return _parse_options(options, RESET_OPTION_KEYS, self._parse_target, self.cfg)

    def row_infos(self, block: np.ndarray, status: np.ndarray) -> list[dict[str, Any]]:
        """Per-environment info dicts (a single env's ``info``) of the step rows ``block`` (n, width),
        a fresh copy the dicts keep views of, and their ``status`` (n,): the table's keys, then
        ``status`` and, on a failed step, ``status_text``."""
        out = self.table.row_dicts(block)
        for d, code in zip(out, status.tolist(), strict=True):
            d["status"] = code
            if code != L.OK:
                d["status_text"] = status_text(code)
        return out

    def reset_info(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """Info arrays of freshly reset environments ``rows`` (zero voltage, energy, reward terms)."""
        info = self.table.info_dict(self.last_row[rows])
        info["status"] = np.zeros(rows.shape[0], dtype=np.int64)
        return info

    # ------------------------------------------------------------------ step
    def check_actions(self, actions) -> np.ndarray:
        """``actions`` (of :attr:`action_shape`) as a (B, W) C-contiguous, writable float64 array, a
        view if it is one already; ValueError (:func:`.config.validate_actions`) on a wrong shape or a
        non-number (not finite actions are left to :meth:`advance`). One array type for every caller
        (a policy's float32, a controller's float64, a read-only or strided view): numba compiles
        the step kernel once per argument type, and the step converts each action to float64 anyway
        (exactly, from float32)."""
        if not (
            isinstance(actions, np.ndarray) and actions.dtype in _FLOATS and actions.shape == self.action_shape
        ):
            actions = validate_actions(actions, self.action_shape)
        actions = actions.reshape(self.num_envs, -1)
        if actions.dtype != np.float64 or not (actions.flags.c_contiguous and actions.flags.writeable):
            actions = np.array(actions, dtype=np.float64, order="C")
        return actions

    def advance(
        self, actions, rngs: Sequence[np.random.Generator], rows: np.ndarray | None = None
    ) -> np.ndarray:
        """Advance the environments ``rows`` (default all) by one control period, in place.

        Writes the buffers :attr:`obs`, :attr:`last_row` (the step rows: reward, info), :attr:`status`,
        :attr:`terminated` and :attr:`truncated` at ``rows`` and leaves the other rows as they are:
        one jitted call (inputs, physics, probe, readout: :mod:`.step_kernels`) and no NumPy
        temporaries (with sensor noise, the noise is drawn first, per environment).

        Args:
            actions: (B, W) float64 from :meth:`check_actions`; clipped to [-1, 1]
                (ValueError if not finite).
            rngs: per-environment generators (only used for sensor noise).
            rows: (n,) int64 environments to step, ascending (default all).

        Returns:
            ``rows``.
        """
        if rows is None:
            rows = self.row_ids
        if self.noisy:  # drawn per environment from its own generator, only for a valid step
            if not np.isfinite(actions).all():
                self._refuse(actions)
            c = self.table.n_channels
            for i in rows:
                self.noise[i] = rngs[i].normal(size=c) * self.noise_sigma
        kernel = self._step_kernel()
        if not kernel(
            rows, actions, self._drive, self._plant, self._step_in, self._mem, self._spec, self._out
        ):
            self._refuse(actions)
        return rows

    def _refuse(self, actions: np.ndarray) -> None:
        """Raise the documented ValueError of actions that are not finite, in the env's shape."""
        validate_actions(actions.reshape(self.action_shape), self.action_shape)

    def step(
        self, actions: np.ndarray, rngs: Sequence[np.random.Generator], active: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """:meth:`advance` returning fresh arrays of the active rows.

        Args:
            actions: (B, W) finite float64 (validated by the caller), clipped here to [-1, 1].
            rngs: per-environment generators (only used for sensor noise).
            active: (B,) bool, environments to step (default all).

        Returns:
            ``(obs, reward, terminated, truncated, info)`` for the active rows only, in row order;
            ``info`` is a dict of arrays with one row per active environment.
        """
        rows = self.advance(actions, rngs, None if active is None else np.flatnonzero(active))
        block = self.last_row[rows]
        info = self.table.info_dict(block)
        info["status"] = self.status[rows]
        return self.obs[rows], block[:, self.reward_col], self.terminated[rows], self.truncated[rows], info

    # ------------------------------------------------------------------ snapshot / restore
    def snapshot(self, i: int) -> SpineSnapshot:
        """Copy of environment ``i``'s full state (without its generator; the envs add that)."""
        if self.episodes[i] is None:
            raise RuntimeError("call reset() before snapshot()")
        arrays = {}
        for name in self.snapshot_arrays:
            row = np.array(self._array(name)[i], copy=True)
            row.setflags(write=False)
            arrays[name] = row
        return SpineSnapshot(arrays=arrays, episode=self.episodes[i])

    def restore(self, i: int, snap: SpineSnapshot) -> None:
        """Put a :meth:`snapshot` back into environment ``i``; ValueError if it does not fit."""
        if not isinstance(snap, SpineSnapshot):
            raise ValueError(f"snapshot must be a SpineSnapshot, got {type(snap).__name__}")
        names = self.snapshot_arrays
        missing = set(names) - set(snap.arrays)
        if missing:
            raise ValueError(f"snapshot lacks {sorted(missing)} (is it from another env?)")
        for name in names:
            dest = self._array(name)
            src = np.asarray(snap.arrays[name])
            if src.shape != dest.shape[1:]:
                raise ValueError(
                    f"snapshot does not fit this env: {name} has shape {src.shape}, the env's "
                    f"{dest.shape[1:]} (different layout, episode length, preview or sensor delay)"
                )
        for name in names:
            self._array(name)[i] = snap.arrays[name]
        self.episodes[i] = snap.episode


def _parse_options(options, keys, parse_target, cfg) -> dict[str, Any]:
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ValueError(f"options must be a dict with keys among {keys}, got {options!r}")
    unknown = set(options) - set(keys)
    if unknown:
        raise ValueError(f"unknown reset option(s) {sorted(unknown)}; valid keys: {keys}")
    out = {}
    if options.get("target") is not None:
        out["target"] = parse_target(options["target"])
    loads = options.get("loads")
    if loads is not None:
        if not isinstance(loads, LoadSchedule) or loads.dim != cfg.force_dim:
            raise ValueError(
                f"options['loads'] must be a LoadSchedule with dim = {cfg.force_dim}, got {loads!r}"
            )
        out["loads"] = loads
    params = options.get("params")
    if params is not None:
        if not isinstance(params, ModelParams):
            raise ValueError(f"options['params'] must be a ModelParams, got {params!r}")
        out["params"] = params
    return out
