"""The functional core shared by :class:`SmaSpineEnv` and :class:`SmaSpineVectorEnv`.

:class:`EnvConfig` holds the validated constructor arguments; :class:`SpineBatch` holds B spines
and implements reset (per environment, with that environment's random generator) and step (all
environments at once: one jitted call of :func:`spine_gym.physics.env_kernels.step_many`, then
observations, rewards and infos as array operations). The single env is a batch of one, so the
single and the vector env run the same code and give the same numbers (the vector-equivalence
test checks this bit for bit). The physics (MODEL.md) lives only in ``spine_gym.physics``; this
module converts units and does bookkeeping.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..params import ModelParams, SolverOptions, field_names
from ..physics import batch, env_kernels
from ..physics import layout as L
from ..physics.solver import init_state
from ..uncertainty import ParameterUncertainty
from . import _bookkeeping as bk
from .task import ANGLE_LIMIT, TARGET_KINDS, LoadSchedule, TargetProfile

__all__ = [
    "EnvConfig",
    "SpineBatch",
    "OBS_NAMES",
    "OBS_UNITS",
    "default_randomization",
    "validate_actions",
    "RESET_OPTION_KEYS",
    "SpineSnapshot",
    "EPISODE_ATTRS",
    "status_text",
    "status_texts",
]

# observation layout (indices 0..3 are fixed by the env contract)
(
    OBS_ANGLE,
    OBS_TARGET,
    OBS_TEMP_R,
    OBS_TEMP_L,
    OBS_RATE,
    OBS_PREVIEW,
    OBS_PREV_R,
    OBS_PREV_L,
    OBS_RES_R,
    OBS_RES_L,
    OBS_DIM,
) = range(11)
OBS_NAMES = (
    "angle",
    "target",
    "temperature_right",
    "temperature_left",
    "angle_rate",
    "target_preview",
    "previous_action_right",
    "previous_action_left",
    "resistance_right",
    "resistance_left",
)
OBS_UNITS = ("deg", "deg", "K", "K", "deg/s", "deg", "-", "-", "Ohm", "Ohm")

ANGLE_OBS_LIMIT = 180.0  # [deg] bound of the angle entry
RATE_OBS_LIMIT = 1000.0  # [deg/s] bound of the angle-rate entry
TEMP_OBS_HIGH = 2000.0  # [K] = the kernel's temperature sanity bound (layout.K_TMAX)
TARGET_REACH = 60.0  # [deg] |angle| the spine reaches at >= ~4 V (±63 deg at full transformation)
V_MAX_LIMIT = 8.0  # [V] above ~8 V a wire held on for long exceeds the model's 2000 K bound
N_CHANNELS = bk.N_CHANNELS  # measured channels: angle, T_R, T_L, R_R, R_L
RESET_OPTION_KEYS = ("target", "loads", "params")
# the env attributes held in SpineBatch.episodes[i], in that order
EPISODE_ATTRS = ("target_profile", "load_schedule", "model_params")

# default domain randomisation: field -> ("scale" | "shift", low, high) about the nominal value
_DEFAULT_DR = {
    "alpha": ("scale", 0.75, 1.25),  # convection coefficient
    "E_t": ("scale", 0.8, 1.2),  # tube modulus
    "T_E": ("shift", -10.0, 10.0),  # ambient temperature [K]
    "lam_A": ("scale", 0.95, 1.05),  # resistivity, austenite
    "lam_M": ("scale", 0.95, 1.05),  # resistivity, martensite
}


def default_randomization(params: ModelParams | None = None) -> dict[str, tuple[float, float]]:
    """The ranges ``domain_randomization=True`` uses, as absolute (low, high) per ModelParams field.

    Convection α × [0.75, 1.25], tube modulus E_t × [0.8, 1.2], ambient T_E ± 10 K and both
    resistivities × [0.95, 1.05] about ``params`` (default: the MODEL.md §7 baseline).
    """
    params = params or ModelParams()
    out = {}
    for name, (how, lo, hi) in _DEFAULT_DR.items():
        v = getattr(params, name)
        out[name] = (v * lo, v * hi) if how == "scale" else (v + lo, v + hi)
    return out


# ---------------------------------------------------------------- validation helpers
def _real(
    name: str, value, lo: float = -math.inf, hi: float = math.inf, *, lo_open=False, hi_open=False
) -> float:
    """``float(value)`` or ValueError naming ``name``, the allowed range and the value received."""
    if isinstance(value, bool):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    bad = not math.isfinite(v) or (v <= lo if lo_open else v < lo) or (v >= hi if hi_open else v > hi)
    if bad:
        lb, rb = "(" if lo_open else "[", ")" if hi_open else "]"
        raise ValueError(f"{name} must be in {lb}{lo:g}, {hi:g}{rb}, got {value!r}")
    return v


def _int(name: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
    if not lo <= int(value) <= hi:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
    return int(value)


def _pair(name: str, value, lo: float, hi: float, *, allow_none=False, integer=False):
    if value is None:
        if allow_none:
            return None
        raise ValueError(f"{name} must be a (low, high) pair, got None")
    try:
        a, b = value
    except (TypeError, ValueError):
        extra = " or None (off)" if allow_none else ""
        raise ValueError(f"{name} must be a (low, high) pair{extra}, got {value!r}") from None
    conv = (lambda n, v: _int(n, v, int(lo), int(hi))) if integer else (lambda n, v: _real(n, v, lo, hi))
    a, b = conv(f"{name}[0]", a), conv(f"{name}[1]", b)
    if a > b:
        raise ValueError(f"{name} must have low <= high, got {value!r}")
    return (a, b)


def _multiple(name: str, value: float, unit: float, unit_name: str) -> int:
    n = int(round(value / unit))
    if n < 1 or abs(n * unit - value) > 1e-9 * max(value, 1.0):
        raise ValueError(f"{name} must be a whole multiple of {unit_name} = {unit:g} s, got {value!r}")
    return n


def validate_actions(actions, shape: tuple[int, ...]) -> np.ndarray:
    """Actions as float64 of exactly ``shape``; ValueError on a wrong shape, a non-number or NaN/inf."""
    try:
        a = np.asarray(actions, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"action must be a numeric array of shape {shape}, got {actions!r}") from None
    if a.shape != shape:
        raise ValueError(f"action must have shape {shape}, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"action must be finite (no NaN or inf), got {a.tolist()}")
    return a


# ---------------------------------------------------------------- configuration
@dataclass(frozen=True)
class EnvConfig:
    """Validated arguments of ``SmaSpine-v0`` (see :class:`spine_gym.envs.SmaSpineEnv` for meanings)."""

    v_max: float = 5.0
    control_period: float = 0.1
    physics_dt: float = 0.01
    episode_duration: float = 60.0
    target_range: tuple[float, float] = (-45.0, 45.0)
    target_kinds: tuple[str, ...] = TARGET_KINDS
    sine_period_range: tuple[float, float] = (20.0, 60.0)
    target_preview: float = 1.0
    tip_force_range: tuple[float, float] | None = (0.0, 0.5)
    tip_force_count: tuple[int, int] = (0, 2)
    tip_force_duration: tuple[float, float] = (1.0, 10.0)
    payload_range: tuple[float, float] | None = (0.0, 0.05)
    domain_randomization: Any = False
    sensor_noise: Any = None
    sensor_delay: int = 0
    temperature_limit: float = 423.0
    error_scale: float = 10.0
    energy_weight: float = 0.5
    cost_weight: float = 0.0
    params: ModelParams | None = None
    solver: SolverOptions | None = None

    def __post_init__(self):
        s = object.__setattr__
        dr = self.domain_randomization
        if isinstance(dr, str | os.PathLike):  # a fitted preset: its uncertainty, and its values by default
            try:
                dr = ParameterUncertainty.from_file(dr)
            except (ValueError, OSError) as e:
                raise ValueError(
                    f"domain_randomization must be False, True, a dict or the path of a fit preset "
                    f"(.json/.yaml written by spine_gym.calibrate); {dr!r}: {e}"
                ) from None
            s(self, "domain_randomization", dr)
        fitted = dr.params if isinstance(dr, ParameterUncertainty) else None
        params = self.params if self.params is not None else (fitted or ModelParams())
        if not isinstance(params, ModelParams):
            raise ValueError(f"params must be a spine_gym.ModelParams, got {type(self.params).__name__}")
        solver = self.solver if self.solver is not None else SolverOptions()
        if not isinstance(solver, SolverOptions):
            raise ValueError(f"solver must be a spine_gym.SolverOptions, got {type(self.solver).__name__}")
        s(self, "params", params)
        s(self, "solver", solver)
        s(self, "v_max", _real("v_max", self.v_max, 0.0, V_MAX_LIMIT, lo_open=True))
        s(self, "physics_dt", _real("physics_dt", self.physics_dt, 0.0, 1.0, lo_open=True))
        s(self, "control_period", _real("control_period", self.control_period, self.physics_dt, 10.0))
        _multiple("control_period", self.control_period, self.physics_dt, "physics_dt")
        s(
            self,
            "episode_duration",
            _real("episode_duration", self.episode_duration, self.control_period, 86400.0),
        )
        _multiple("episode_duration", self.episode_duration, self.control_period, "control_period")
        s(self, "target_range", _pair("target_range", self.target_range, -TARGET_REACH, TARGET_REACH))
        kinds = (self.target_kinds,) if isinstance(self.target_kinds, str) else tuple(self.target_kinds)
        if not kinds or any(k not in TARGET_KINDS for k in kinds):
            raise ValueError(
                f"target_kinds must be a non-empty subset of {TARGET_KINDS}, got {self.target_kinds!r}"
            )
        s(self, "target_kinds", kinds)
        s(
            self,
            "sine_period_range",
            _pair("sine_period_range", self.sine_period_range, 2.0 * self.control_period, 1e6),
        )
        s(self, "target_preview", _real("target_preview", self.target_preview, 0.0, 600.0))
        s(self, "tip_force_range", _pair("tip_force_range", self.tip_force_range, 0.0, 20.0, allow_none=True))
        s(self, "tip_force_count", _pair("tip_force_count", self.tip_force_count, 0, 100, integer=True))
        s(self, "tip_force_duration", _pair("tip_force_duration", self.tip_force_duration, 1e-6, 86400.0))
        if self.tip_force_duration[0] <= 0.0:
            raise ValueError(f"tip_force_duration must be > 0 s, got {self.tip_force_duration!r}")
        s(self, "payload_range", _pair("payload_range", self.payload_range, 0.0, 1.0, allow_none=True))
        s(self, "domain_randomization", self._check_dr(self.domain_randomization, params))
        s(self, "sensor_noise", self._check_noise(self.sensor_noise))
        s(self, "sensor_delay", _int("sensor_delay", self.sensor_delay, 0, 1000))
        s(
            self,
            "temperature_limit",
            _real("temperature_limit", self.temperature_limit, params.T_E, TEMP_OBS_HIGH, lo_open=True),
        )
        s(self, "error_scale", _real("error_scale", self.error_scale, 0.0, 1e6, lo_open=True))
        s(self, "energy_weight", _real("energy_weight", self.energy_weight, 0.0, 1e6))
        s(self, "cost_weight", _real("cost_weight", self.cost_weight, 0.0, 1e6))

    @staticmethod
    def _check_dr(value, params: ModelParams) -> tuple[tuple[str, float, float], ...]:
        if value is False or value is None:
            return ()
        if isinstance(value, ParameterUncertainty):
            return value
        if value is True:
            value = default_randomization(params)
        if not isinstance(value, Mapping):
            raise ValueError(
                "domain_randomization must be False, True (default ranges), a dict "
                f"{{ModelParams field: (low, high)}} or the path of a fit preset, got {value!r}"
            )
        allowed = [f for f in field_names() if f not in ("n_w", "n_seg")]
        out = []
        for name in sorted(value):
            if name not in allowed:
                raise ValueError(
                    f"domain_randomization: unknown or non-randomisable field {name!r}; valid: {allowed}"
                )
            lo, hi = _pair(f"domain_randomization[{name!r}]", value[name], -math.inf, math.inf)
            for v in (lo, hi):
                try:
                    params.replace(**{name: v})
                except ValueError as e:
                    raise ValueError(
                        f"domain_randomization[{name!r}] = {value[name]!r} leaves the model's range: {e}"
                    ) from None
            out.append((name, lo, hi))
        return tuple(out)

    @staticmethod
    def _check_noise(value) -> tuple[float, float, float]:
        if value is None or value is False:
            return (0.0, 0.0, 0.0)
        keys = ("angle", "temperature", "resistance")
        if not isinstance(value, Mapping) or set(value) - set(keys):
            raise ValueError(
                f"sensor_noise must be None or a dict with keys among {keys} (standard deviations in "
                f"deg, K, Ohm), got {value!r}"
            )
        return tuple(_real(f"sensor_noise[{k!r}]", value.get(k, 0.0), 0.0, 1e3) for k in keys)

    # ------------------------------------------------------------------ derived
    @property
    def n_sub(self) -> int:
        """Physics steps per control period."""
        return int(round(self.control_period / self.physics_dt))

    @property
    def n_steps(self) -> int:
        """Control steps per episode."""
        return int(round(self.episode_duration / self.control_period))

    @property
    def preview_steps(self) -> int:
        """Control periods between the current target and the preview target."""
        return int(round(self.target_preview / self.control_period))

    @property
    def energy_reference(self) -> float:
        """Largest electrical energy of one control period [J]: both sides at v_max, nominal
        martensite/austenite resistivity, whichever is lower (the normaliser of the energy term)."""
        p = self.params
        r_min = min(p.lam_A, p.lam_M) * p.L0 / p.wire_area  # [Ω] one wire
        return 2.0 * p.n_w * self.v_max**2 / r_min * self.control_period

    def resistance_bound(self) -> float:
        """Upper bound of the resistance entries [Ω]: 2x the largest one-wire resistance over the
        nominal and randomised parameters (values above it are clipped)."""
        cands = [self.params]
        if isinstance(self.domain_randomization, ParameterUncertainty):
            cands += self.domain_randomization.extremes(self.params)
        else:
            for name, lo, hi in self.domain_randomization:
                cands += [self.params.replace(**{name: lo}), self.params.replace(**{name: hi})]
        r = max(max(p.lam_A, p.lam_M) * p.L0 / p.wire_area for p in cands)
        return float(2.0 * r + 10.0 * self.sensor_noise[2])

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of the observation entries, float32."""
        low = np.zeros(OBS_DIM, dtype=np.float32)
        high = np.zeros(OBS_DIM, dtype=np.float32)
        low[[OBS_ANGLE]], high[[OBS_ANGLE]] = -ANGLE_OBS_LIMIT, ANGLE_OBS_LIMIT
        low[[OBS_TARGET, OBS_PREVIEW]], high[[OBS_TARGET, OBS_PREVIEW]] = -ANGLE_LIMIT, ANGLE_LIMIT
        low[[OBS_TEMP_R, OBS_TEMP_L]], high[[OBS_TEMP_R, OBS_TEMP_L]] = 0.0, TEMP_OBS_HIGH
        low[OBS_RATE], high[OBS_RATE] = -RATE_OBS_LIMIT, RATE_OBS_LIMIT
        low[[OBS_PREV_R, OBS_PREV_L]], high[[OBS_PREV_R, OBS_PREV_L]] = -1.0, 1.0
        low[[OBS_RES_R, OBS_RES_L]], high[[OBS_RES_R, OBS_RES_L]] = 0.0, self.resistance_bound()
        return low, high


def parse_reset_options(options) -> dict[str, Any]:
    """Validate ``reset(options=...)``: keys among :data:`RESET_OPTION_KEYS`, objects of the right type."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ValueError(f"options must be a dict with keys among {RESET_OPTION_KEYS}, got {options!r}")
    unknown = set(options) - set(RESET_OPTION_KEYS)
    if unknown:
        raise ValueError(f"unknown reset option(s) {sorted(unknown)}; valid keys: {RESET_OPTION_KEYS}")
    out = {}
    target = options.get("target")
    if target is not None:
        if isinstance(target, int | float | np.number) and not isinstance(target, bool):
            target = TargetProfile.constant(float(target))
        if not isinstance(target, TargetProfile):
            raise ValueError(f"options['target'] must be a TargetProfile or a number [deg], got {target!r}")
        out["target"] = target
    loads = options.get("loads")
    if loads is not None:
        if not isinstance(loads, LoadSchedule):
            raise ValueError(f"options['loads'] must be a LoadSchedule, got {loads!r}")
        out["loads"] = loads
    params = options.get("params")
    if params is not None:
        if not isinstance(params, ModelParams):
            raise ValueError(f"options['params'] must be a ModelParams, got {params!r}")
        out["params"] = params
    return out


# ---------------------------------------------------------------- snapshots
# per-environment rows of SpineBatch that make up one environment's full state (one place)
SNAPSHOT_ARRAYS = (
    "states",  # model state vector (physics.layout)
    "kps",  # the episode's (possibly randomised) constants
    "loads",  # vertex forces of the last step
    "meas",  # batch.record row of the last step
    "status",
    "targets",
    "forces",
    "resolve_plan",
    "k",
    "prev_action",
    "hist",
    "prev_measured_angle",
    "joule",
    "side_volume",
    "ohm_per_resistivity",
    "volts",
)


@dataclass(frozen=True, eq=False)
class SpineSnapshot:
    """The full state of one environment: model state, episode data, bookkeeping and RNG.

    Made by ``snapshot()`` of :class:`SpineBatch`, :class:`~spine_gym.envs.SmaSpineEnv` or
    :class:`~spine_gym.envs.SmaSpineVectorEnv`; ``restore(snapshot)`` puts it back, after which the
    env continues bit for bit as it would have from the moment of the snapshot (tested). The arrays
    are private copies (read-only); a snapshot can be restored any number of times and into any
    env of the same configuration.

    Attributes:
        arrays: name -> copy of the environment's row of each :data:`SNAPSHOT_ARRAYS` entry.
        episode: the episode's (TargetProfile, LoadSchedule, ModelParams).
        rng_state: ``bit_generator.state`` of the env's generator (sensor noise and later resets),
            or None if the batch alone was snapshotted.
        extra: env-level flags (e.g. whether the episode has ended).
    """

    arrays: Mapping[str, np.ndarray]
    episode: tuple[TargetProfile, LoadSchedule, ModelParams]
    rng_state: dict | None = None
    extra: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def state(self) -> np.ndarray:
        """The model state vector (``spine_gym.physics.layout``)."""
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


# ---------------------------------------------------------------- the batch of spines
class SpineBatch:
    """B spines with their episode data; the one implementation behind both environments.

    Args:
        cfg: validated configuration.
        num_envs: B.
        parallel: step with the ``prange`` kernel (else its serial twin).
    """

    def __init__(self, cfg: EnvConfig, num_envs: int, parallel: bool):
        self.cfg = cfg
        self.num_envs = b = int(num_envs)
        self.parallel = bool(parallel)
        p = cfg.params
        n = p.n_seg
        self.nominal_kp = p.to_kernel()
        self.ks = cfg.solver.to_kernel()
        self.states = np.zeros((b, L.state_size(n)))
        self.backup = np.zeros_like(self.states)
        self.kps = np.tile(self.nominal_kp, (b, 1))
        self.loads = np.zeros((b, n, 2))
        self.meas = np.zeros((b, batch.OUT_SIZE))
        self.status = np.zeros(b, dtype=np.int64)
        n_grid = cfg.n_steps + 1 + cfg.preview_steps
        self.time_grid = np.arange(n_grid) * cfg.control_period  # [s] t_k = k Δt
        self.targets = np.zeros((b, n_grid))  # [deg] θ*(t_k)
        self.forces = np.zeros((b, cfg.n_steps, 2))  # [N] tip force + payload weight over step k
        self.resolve_plan = np.zeros((b, cfg.n_steps), dtype=np.bool_)
        self.k = np.zeros(b, dtype=np.int64)  # control steps taken in the episode
        self.prev_action = np.full((b, 2), -1.0)
        self.hist = np.zeros((b, cfg.sensor_delay + 1, N_CHANNELS))  # true channels, oldest first
        self.prev_measured_angle = np.zeros(b)
        self.joule = np.zeros((b, 2))  # [J] cumulative Joule heat of each side
        self.side_volume = np.zeros(b)  # [m^3] wire volume of one side
        self.ohm_per_resistivity = np.zeros(b)  # [1/m] L0 / A_w
        self.episodes: list[tuple[TargetProfile, LoadSchedule, ModelParams] | None] = [None] * b
        self.obs_low, self.obs_high = cfg.observation_bounds()
        self.noise_sigma = np.array(
            [
                cfg.sensor_noise[0],
                cfg.sensor_noise[1],
                cfg.sensor_noise[1],
                cfg.sensor_noise[2],
                cfg.sensor_noise[2],
            ]
        )
        self.noisy = bool(self.noise_sigma.any())
        self.energy_ref = cfg.energy_reference
        self.settings = np.zeros(bk.N_SETTINGS)
        self.settings[bk.S_PERIOD] = cfg.control_period
        self.settings[bk.S_ERROR_SCALE] = cfg.error_scale
        self.settings[bk.S_ENERGY_COEF] = cfg.energy_weight / self.energy_ref
        self.settings[bk.S_COST_WEIGHT] = cfg.cost_weight
        self.settings[bk.S_T_LIMIT] = cfg.temperature_limit
        self.max_steps = cfg.n_steps  # truncation (the vector env may lower it to max_episode_steps)
        self.volts = np.zeros((b, 2))  # [V] applied over the last step
        self._all = np.ones(b, dtype=np.bool_)
        self._row_ids = np.arange(b)

    # ------------------------------------------------------------------ reset
    def reset_env(self, i: int, rng: np.random.Generator, options=None) -> np.ndarray:
        """Start a new episode in environment ``i`` and return its first observation (float32).

        The draws come from ``rng`` in this order: target profile, load schedule, randomised
        parameters (each only if not pinned by ``options``), then the sensor noise.
        """
        cfg = self.cfg
        opts = parse_reset_options(options)
        target = opts.get("target")
        if target is None:
            target = TargetProfile.sample(
                rng, cfg.episode_duration, cfg.target_range, cfg.target_kinds, cfg.sine_period_range
            )
        loads = opts.get("loads")
        if loads is None:
            loads = LoadSchedule.sample(
                rng,
                cfg.episode_duration,
                cfg.tip_force_range,
                cfg.tip_force_count,
                cfg.tip_force_duration,
                cfg.payload_range,
            )
        params = opts.get("params")
        if params is None:
            if isinstance(cfg.domain_randomization, ParameterUncertainty):
                params = cfg.domain_randomization.draw(rng, cfg.params)
                kp = params.to_kernel()
            elif cfg.domain_randomization:
                draws = {name: float(rng.uniform(lo, hi)) for name, lo, hi in cfg.domain_randomization}
                try:
                    params = cfg.params.replace(**draws)
                except ValueError as e:
                    raise ValueError(
                        f"domain_randomization drew an invalid parameter set {draws}: {e}"
                    ) from None
                kp = params.to_kernel()
            else:
                params, kp = cfg.params, self.nominal_kp
        else:
            if params.n_seg != cfg.params.n_seg:
                raise ValueError(
                    f"options['params'].n_seg must equal the env's n_seg = {cfg.params.n_seg}, "
                    f"got {params.n_seg}"
                )
            kp = params.to_kernel()
        self.episodes[i] = (target, loads, params)
        self.kps[i] = kp
        self.targets[i] = target(self.time_grid)
        weight = loads.payload_force(params.g)
        self.forces[i] = loads.tip_force(self.time_grid[: cfg.n_steps]) + weight
        plan = self.resolve_plan[i]
        plan[0] = np.any(self.forces[i, 0] != weight)  # the initial state is solved under the payload only
        plan[1:] = np.any(self.forces[i, 1:] != self.forces[i, :-1], axis=1)
        vforce = np.zeros((params.n_seg, 2))
        vforce[0] = weight
        st = init_state(self.states[i], kp, self.ks, vforce)
        if st != L.OK:
            raise ValueError(
                f"the initial state cannot be solved under a payload of {loads.payload:g} kg "
                f"({L.STATUS_TEXT.get(st, st)}); use a lighter payload"
            )
        self.status[i] = L.OK
        self.k[i] = 0
        self.prev_action[i] = -1.0  # 0 V on both wires before the episode
        self.side_volume[i] = params.wire_volume * params.n_w
        self.ohm_per_resistivity[i] = params.L0 / params.wire_area
        rows = np.array([i], dtype=np.int64)
        env_kernels.record_many(self.states, self.kps, rows, self.meas)
        m = self.meas[i]
        self.joule[i] = (m[L.X_QJR] * self.side_volume[i], m[L.X_QJL] * self.side_volume[i])
        true = np.empty(N_CHANNELS)
        bk.channels(m, self.ohm_per_resistivity[i], true)
        self.hist[i] = true  # the sensors read the initial state before t = 0
        measured = true + (rng.normal(size=N_CHANNELS) * self.noise_sigma if self.noisy else 0.0)
        self.prev_measured_angle[i] = measured[0]
        obs = np.empty(OBS_DIM)
        preview = self.targets[i, min(cfg.preview_steps, self.targets.shape[1] - 1)]
        bk.assemble(obs, measured, 0.0, self.targets[i, 0], preview, -1.0, -1.0, self.obs_low, self.obs_high)
        return obs.astype(np.float32)

    def reset_info(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """Info arrays (the keys of :meth:`step`) of freshly reset environments ``rows``; no step
        was taken, so voltage, power, energy and both reward terms are 0."""
        n = rows.shape[0]
        m = self.meas[rows]
        angle = np.degrees(m[:, batch.OUT_ANGLE])
        target = self.targets[rows, 0]
        temps = m[:, [L.X_TR, L.X_TL]]
        return {
            "voltage": np.zeros((n, 2)),
            "angle_deg": angle,
            "target_deg": target,
            "tracking_error_deg": target - angle,
            "energy_J": np.zeros(n),
            "power_W": np.zeros((n, 2)),
            "cost": self._cost(temps),
            "temperature": temps,
            "resistance": m[:, [batch.OUT_RES_R, batch.OUT_RES_L]] * self.ohm_per_resistivity[rows, None],
            "time": np.zeros(n),
            "tip_force": self._weights(rows),
            "status": np.zeros(n, dtype=np.int64),
            "reward_tracking": np.zeros(n),
            "reward_energy": np.zeros(n),
        }

    def _weights(self, rows):
        out = np.zeros((rows.shape[0], 2))
        for j, i in enumerate(rows):
            _, loads, params = self.episodes[i]
            out[j] = loads.payload_force(params.g)
        return out

    # ------------------------------------------------------------------ step
    def step(
        self, actions: np.ndarray, rngs: Sequence[np.random.Generator], active: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Advance the active environments by one control period.

        Args:
            actions: (B, 2) finite float64 (validated by the caller), clipped here to [-1, 1].
            rngs: per-environment generators (only used for sensor noise).
            active: (B,) bool, environments to step (default all).

        Returns:
            ``(obs, reward, terminated, truncated, info)`` for the active rows only, in row order;
            ``info`` is a dict of arrays with one row per active environment.
        """
        cfg = self.cfg
        if active is None:
            active = self._all
            rows = self._row_ids
        else:
            rows = np.flatnonzero(active)
        n = rows.shape[0]
        a = np.clip(actions, -1.0, 1.0)
        np.multiply(a + 1.0, 0.5 * cfg.v_max, out=self.volts)
        k0 = self.k[rows]
        kk = np.minimum(k0, cfg.n_steps - 1)
        self.loads[rows, 0, :] = self.forces[rows, kk]
        resolve = np.zeros(self.num_envs, dtype=np.bool_)
        resolve[rows] = self.resolve_plan[rows, kk] & (k0 < cfg.n_steps)
        kernel = env_kernels.step_many if self.parallel else env_kernels.step_many_serial
        kernel(
            self.states,
            self.backup,
            self.kps,
            self.ks,
            self.volts[:, 0],
            self.volts[:, 1],
            self.loads,
            resolve,
            active,
            cfg.physics_dt,
            cfg.n_sub,
            self.status,
            self.meas,
        )
        noise = np.zeros((n, N_CHANNELS))
        if self.noisy:  # drawn per environment from its own generator, after the physics
            for j, i in enumerate(rows):
                noise[j] = rngs[i].normal(size=N_CHANNELS) * self.noise_sigma
        obs = np.empty((n, OBS_DIM), dtype=np.float32)
        info = np.empty((n, bk.N_INFO))
        terminated = np.empty(n, dtype=np.bool_)
        truncated = np.empty(n, dtype=np.bool_)
        bk.finish_rows(
            rows,
            self.meas,
            self.k,
            self.joule,
            self.side_volume,
            self.ohm_per_resistivity,
            self.hist,
            noise,
            self.prev_measured_angle,
            self.prev_action,
            a,
            self.volts,
            self.loads,
            self.status,
            self.targets,
            cfg.preview_steps,
            self.max_steps,
            self.obs_low,
            self.obs_high,
            self.settings,
            obs,
            info,
            terminated,
            truncated,
        )
        out = {
            "voltage": info[:, bk.I_VOLT_R : bk.I_VOLT_L + 1],
            "angle_deg": info[:, bk.I_ANGLE],
            "target_deg": info[:, bk.I_TARGET],
            "tracking_error_deg": info[:, bk.I_ERROR],
            "energy_J": info[:, bk.I_ENERGY],
            "power_W": info[:, bk.I_POWER_R : bk.I_POWER_L + 1],
            "cost": info[:, bk.I_COST],
            "temperature": info[:, bk.I_TEMP_R : bk.I_TEMP_L + 1],
            "resistance": info[:, bk.I_RES_R : bk.I_RES_L + 1],
            "time": info[:, bk.I_TIME],
            "tip_force": info[:, bk.I_FORCE_X : bk.I_FORCE_Y + 1],
            "status": self.status[rows],
            "reward_tracking": info[:, bk.I_R_TRACK],
            "reward_energy": info[:, bk.I_R_ENERGY],
        }
        return obs, info[:, bk.I_REWARD], terminated, truncated, out

    # ------------------------------------------------------------------ snapshot / restore
    def snapshot(self, i: int) -> SpineSnapshot:
        """Copy of environment ``i``'s full state (without its generator; the envs add that)."""
        if self.episodes[i] is None:
            raise RuntimeError("call reset() before snapshot()")
        arrays = {}
        for name in SNAPSHOT_ARRAYS:
            row = np.array(getattr(self, name)[i], copy=True)
            row.setflags(write=False)
            arrays[name] = row
        return SpineSnapshot(arrays=arrays, episode=self.episodes[i])

    def restore(self, i: int, snap: SpineSnapshot) -> None:
        """Put a :meth:`snapshot` back into environment ``i``; ValueError if it does not fit."""
        if not isinstance(snap, SpineSnapshot):
            raise ValueError(f"snapshot must be a SpineSnapshot, got {type(snap).__name__}")
        missing = set(SNAPSHOT_ARRAYS) - set(snap.arrays)
        if missing:
            raise ValueError(f"snapshot lacks {sorted(missing)}")
        for name in SNAPSHOT_ARRAYS:
            dest = getattr(self, name)
            src = np.asarray(snap.arrays[name])
            if src.shape != dest.shape[1:]:
                raise ValueError(
                    f"snapshot does not fit this env: {name} has shape {src.shape}, the env's "
                    f"{dest.shape[1:]} (different n_seg, episode length, preview or sensor delay)"
                )
        for name in SNAPSHOT_ARRAYS:
            getattr(self, name)[i] = snap.arrays[name]
        self.episodes[i] = snap.episode

    # ------------------------------------------------------------------ helpers
    def _cost(self, temps: np.ndarray) -> np.ndarray:
        """Σ over both wires of max(0, T − temperature_limit) [K] (as ``_bookkeeping.finish_rows``)."""
        over = np.maximum(temps - self.cfg.temperature_limit, 0.0)
        return over[:, 0] + over[:, 1]

    def state_summary(self, i: int) -> dict[str, Any]:
        """What the renderer needs for environment ``i``."""
        n = self.cfg.params.n_seg
        target, loads, params = self.episodes[i]
        k = int(self.k[i])
        return {
            "dth": self.states[i, L.X_HEAD : L.X_HEAD + n].copy(),
            "kp": self.kps[i].copy(),
            "temperature": (float(self.states[i, L.X_TR]), float(self.states[i, L.X_TL])),
            "ambient": float(params.T_E),
            "target_deg": float(self.targets[i, min(k, self.targets.shape[1] - 1)]),
            "angle_deg": float(np.degrees(self.states[i, L.X_HEAD : L.X_HEAD + n].sum())),
            "tip_force": self.forces[i, min(k, self.cfg.n_steps - 1)].copy(),
            "time": k * self.cfg.control_period,
            "voltage": (self.prev_action[i] + 1.0) * 0.5 * self.cfg.v_max,
        }


def status_text(code: int) -> str:
    """``info["status_text"]`` of a step with status ``code`` (from ``layout.STATUS_TEXT``)."""
    return L.STATUS_TEXT.get(int(code), str(int(code)))


def status_texts(status: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``info["status_text"]`` of failed steps: (positions j with ``status[j] != OK``, their
    :func:`status_text` as an object array)."""
    failed = np.flatnonzero(status != L.OK)
    return failed, np.array([status_text(c) for c in status[failed]], dtype=object)


def config_fields() -> list[str]:
    """Names of the env's keyword arguments held in :class:`EnvConfig`."""
    return [f.name for f in dataclasses.fields(EnvConfig)]
