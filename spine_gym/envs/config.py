"""The configuration every env of spine_gym shares, and its validation.

:class:`BaseEnvConfig` holds and validates the arguments all envs share (voltages, periods, loads,
domain randomisation, sensors, reward weights) and checks that every reset it can draw solves its
initial state; the per-geometry configurations add their task and their declarative
observation/info table (:class:`.planar.PlanarConfig`, :mod:`.spatial`). The validators here
(:func:`validate_actions` and the argument checks) raise one-line ``ValueError`` s naming the
argument, its allowed range and the value received. The physics (MODEL.md, SPATIAL.md) lives
only in ``spine_gym.physics``.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from itertools import product
from typing import Any

import numpy as np

from ..layout import wire_key
from ..params import DYNAMICS_ONLY_FIELDS, ModelParams, SolverOptions, field_names
from ..physics import columns as L
from ..uncertainty import ParameterUncertainty, apply_offsets
from .drive import check_v_max
from .ids import TEMPERATURE_LIMIT_K
from .loads import LoadSchedule
from .table import Entry

__all__ = [
    "BaseEnvConfig",
    "config_fields",
    "default_randomization",
    "validate_actions",
    "RESET_OPTION_KEYS",
    "EPISODE_ATTRS",
]

ANGLE_OBS_LIMIT = 180.0  # [deg] bound of the angle entry
RATE_OBS_LIMIT = 1000.0  # [deg/s] bound of the angle-rate entry
TEMP_OBS_HIGH = 2000.0  # [K] = the kernel's temperature sanity bound (layout.K_TMAX)
TARGET_REACH = 60.0  # [deg] |angle| the spine reaches at >= ~4 V (±63 deg at full transformation)
MAX_CORNER_FIELDS = 10  # randomised fields of the initial state whose 2^k box corners are checked
RESET_OPTION_KEYS = ("target", "loads", "params")
# the env attributes held in TableBatch.episodes[i], in that order
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


def _floor6(x: float) -> float:
    """``x`` > 0 rounded down to 6 significant digits (a limit a user may copy)."""
    scale = 10.0 ** (5 - math.floor(math.log10(x)))
    return math.floor(x * scale) / scale


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
class BaseEnvConfig:
    """Validated arguments every env of spine_gym shares (the task's own are in the subclasses)."""

    NOISE_KEYS = ("angle", "temperature", "resistance")  # sensor_noise keys (units in the env docs)

    v_max: float = 5.0
    control_period: float = 0.1
    physics_dt: float | None = None  # None: the control period (one model output step per env step)
    episode_duration: float = 60.0
    target_preview: float = 1.0
    tip_force_range: tuple[float, float] | None = (0.0, 0.5)
    tip_force_count: tuple[int, int] = (0, 2)
    tip_force_duration: tuple[float, float] = (1.0, 10.0)
    payload_range: tuple[float, float] | None = (0.0, 0.05)
    domain_randomization: Any = False
    sensor_noise: Any = None
    sensor_delay: int = 0
    temperature_limit: float = TEMPERATURE_LIMIT_K
    thermal_cutoff: float | None = None
    error_scale: float = 10.0
    energy_weight: float = 0.5
    cost_weight: float = 0.0
    observe_errors: bool = False
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
        s(self, "v_max", check_v_max(self.v_max))
        s(self, "control_period", _real("control_period", self.control_period, 0.0, 10.0, lo_open=True))
        dt = self.control_period if self.physics_dt is None else self.physics_dt
        s(self, "physics_dt", _real("physics_dt", dt, 0.0, self.control_period, lo_open=True))
        _multiple("control_period", self.control_period, self.physics_dt, "physics_dt")
        s(
            self,
            "episode_duration",
            _real("episode_duration", self.episode_duration, self.control_period, 86400.0),
        )
        _multiple("episode_duration", self.episode_duration, self.control_period, "control_period")
        self._check_task()
        s(self, "target_preview", _real("target_preview", self.target_preview, 0.0, 600.0))
        s(self, "tip_force_range", _pair("tip_force_range", self.tip_force_range, 0.0, 20.0, allow_none=True))
        s(self, "tip_force_count", _pair("tip_force_count", self.tip_force_count, 0, 100, integer=True))
        s(self, "tip_force_duration", _pair("tip_force_duration", self.tip_force_duration, 1e-6, 86400.0))
        if self.tip_force_duration[0] <= 0.0:
            raise ValueError(f"tip_force_duration must be > 0 s, got {self.tip_force_duration!r}")
        s(self, "payload_range", _pair("payload_range", self.payload_range, 0.0, 1.0, allow_none=True))
        s(self, "domain_randomization", self._check_dr(self.domain_randomization, params))
        s(self, "sensor_noise", self._check_noise(self.sensor_noise, self.NOISE_KEYS))
        s(self, "sensor_delay", _int("sensor_delay", self.sensor_delay, 0, 1000))
        s(
            self,
            "temperature_limit",
            _real("temperature_limit", self.temperature_limit, params.T_E, TEMP_OBS_HIGH, lo_open=True),
        )
        if self.thermal_cutoff is not None:
            s(
                self,
                "thermal_cutoff",
                _real("thermal_cutoff", self.thermal_cutoff, params.T_E, self.temperature_limit, lo_open=True),
            )
        s(self, "error_scale", _real("error_scale", self.error_scale, 0.0, 1e6, lo_open=True))
        s(self, "energy_weight", _real("energy_weight", self.energy_weight, 0.0, 1e6))
        s(self, "cost_weight", _real("cost_weight", self.cost_weight, 0.0, 1e6))
        if not isinstance(self.observe_errors, bool | np.bool_):
            raise ValueError(f"observe_errors must be True or False, got {self.observe_errors!r}")
        s(self, "observe_errors", bool(self.observe_errors))
        self._check_initial_states()

    def _check_task(self) -> None:
        """Validate the task's own fields (subclasses)."""

    def _check_kinds(self, kinds: tuple[str, ...], period_name: str) -> None:
        """Validate ``target_kinds`` (one of ``kinds`` or a non-empty subset of them, held as a tuple)
        and the (low, high) period range ``period_name`` of periodic targets (>= 2 control periods)."""
        s = object.__setattr__
        given = (self.target_kinds,) if isinstance(self.target_kinds, str) else tuple(self.target_kinds)
        if not given or any(k not in kinds for k in given):
            raise ValueError(f"target_kinds must be a non-empty subset of {kinds}, got {self.target_kinds!r}")
        s(self, "target_kinds", given)
        periods = _pair(period_name, getattr(self, period_name), 2.0 * self.control_period, 1e6)
        s(self, period_name, periods)

    # ------------------------------------------------------------------ resets that can be held
    def initial_status(self, params: ModelParams, payload: float) -> int:
        """Status (``layout.OK`` or an error code) of the initial state (MODEL.md §3.10) of an
        episode with parameters ``params`` under ``payload`` [kg]: the solve a reset makes, with
        the same inputs (``LoadSchedule.payload_force`` on the top vertex). ValueError if
        ``params`` give no valid spine."""
        raise NotImplementedError

    def initial_loads(self, params: ModelParams, payload: float) -> np.ndarray:
        """The vertex forces (n_seg, force_dim) of a reset under ``payload`` [kg]: its weight on
        the top vertex."""
        vforce = np.zeros((self.n_seg, self.force_dim))
        vforce[0] = LoadSchedule(payload=payload, dim=self.force_dim).payload_force(params.g)
        return vforce

    def _check_initial_states(self) -> None:
        """Every reset this configuration can draw solves its initial state: the heaviest payload
        of ``payload_range`` at every corner of the randomised box of the fields that enter the
        initial state (the reset's own solve, :meth:`initial_status`). A reset that cannot is a
        ValueError raised inside ``step`` of an autoresetting vector env."""
        payload = 0.0 if self.payload_range is None else self.payload_range[1]
        failed = []  # (corner, params, status) that cannot hold the payload
        for corner, params in self._initial_corners():
            try:
                status = self.initial_status(params, payload)
            except ValueError as e:
                raise ValueError(
                    f"domain_randomization gives an invalid spine at its corner {corner}: {e}"
                ) from None
            if status != L.OK:
                failed.append((corner, params, status))
        for corner, params, status in failed:
            if payload == 0.0 or self.initial_status(params, 0.0) != L.OK:
                what, where = (
                    ("domain_randomization", f" at its corner {corner}") if corner else ("params", "")
                )
                raise ValueError(
                    f"{what} must give an initial state that can be solved without payload; it cannot"
                    f"{where} ({L.STATUS_TEXT.get(status, status)})"
                )
        if failed:
            limit, corner, status = min(
                ((self._payload_limit(p, payload), c, st) for c, p, st in failed), key=lambda t: t[0]
            )
            where = f" at domain_randomization's corner {corner}" if corner else ""
            raise ValueError(
                f"payload_range must have high <= {_floor6(limit)} kg (the heaviest payload whose initial "
                f"state can be solved{where}: {L.STATUS_TEXT.get(status, status)}), "
                f"got {self.payload_range!r}"
            )

    def _payload_limit(self, params: ModelParams, payload: float) -> float:
        """The heaviest payload in [0, ``payload``] whose initial state solves (bisection to 1e-9
        relative; 0 solves, ``payload`` does not)."""
        lo, hi = 0.0, payload
        while hi - lo > 1e-9 * hi:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.initial_status(params, mid) == L.OK else (lo, mid)
        return lo

    def _initial_corners(self) -> Iterator[tuple[dict[str, float], ModelParams]]:
        """(the randomised fields' values, params) at the nominal parameters and at every corner of
        the box of randomised fields that enter the initial state (not ``DYNAMICS_ONLY_FIELDS``).
        A preset's corners that leave the model's range are skipped (its draws redraw those); a
        dict's raise ValueError (its resets would)."""
        yield {}, self.params
        dr = self.domain_randomization
        if isinstance(dr, ParameterUncertainty):
            # a spatial fit's per-wire directions are checked at their nominal values (the layout's)
            js = [
                j
                for j, d in enumerate(dr.directions)
                if set(d) - DYNAMICS_ONLY_FIELDS and all(wire_key(f) is None for f in d)
            ]
            self._check_corner_count(len(js))
            for bounds in product(*((dr.lower[j], dr.upper[j]) for j in js)):
                off = np.zeros(len(dr.names))
                off[js] = np.asarray(bounds) - dr.values[js]
                try:
                    params = apply_offsets(self.params, dr.directions, off)
                except ValueError:
                    continue
                yield dict(zip((dr.names[j] for j in js), bounds, strict=True)), params
            return
        ranges = [(name, lo, hi) for name, lo, hi in dr if name not in DYNAMICS_ONLY_FIELDS]
        self._check_corner_count(len(ranges))
        for values in product(*((lo, hi) for _, lo, hi in ranges)):
            corner = dict(zip((name for name, _, _ in ranges), values, strict=True))
            try:
                params = self.params.replace(**corner)
            except ValueError as e:
                raise ValueError(
                    f"domain_randomization can draw an invalid parameter set {corner}: {e}"
                ) from None
            yield corner, params

    @staticmethod
    def _check_corner_count(k: int) -> None:
        if k > MAX_CORNER_FIELDS:
            raise ValueError(
                f"domain_randomization must randomise at most {MAX_CORNER_FIELDS} fields that enter the "
                f"initial state (fields other than {sorted(DYNAMICS_ONLY_FIELDS)}; each reset's worst "
                f"case is checked at the 2^k corners of their box), got {k}"
            )

    @property
    def noise_sigma(self) -> dict[str, float]:
        """``sensor_noise`` as {key: standard deviation} over :attr:`NOISE_KEYS` (0 = off)."""
        return dict(zip(self.NOISE_KEYS, self.sensor_noise, strict=True))

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
    def _check_noise(value, keys: tuple[str, ...]) -> tuple[float, ...]:
        if value is None or value is False:
            return (0.0,) * len(keys)
        if not isinstance(value, Mapping) or set(value) - set(keys):
            raise ValueError(
                f"sensor_noise must be None or a dict with keys among {keys} (standard deviations, "
                f"units in the env's documentation), got {value!r}"
            )
        return tuple(_real(f"sensor_noise[{k!r}]", value.get(k, 0.0), 0.0, 1e3) for k in keys)

    def extreme_params(self) -> list[ModelParams]:
        """The nominal parameters and the extremes of the randomised ones (each field at its low
        and its high end, or a fit's extremes): what the bounds of the resistance entries cover."""
        cands = [self.params]
        if isinstance(self.domain_randomization, ParameterUncertainty):
            cands += self.domain_randomization.extremes(self.params)
        else:
            for name, lo, hi in self.domain_randomization:
                cands += [self.params.replace(**{name: lo}), self.params.replace(**{name: hi})]
        return cands

    def wire_entries(self, names: tuple[str, ...], resistance_doc: str) -> tuple[Entry, Entry, Entry]:
        """The (temperature, previous action, resistance) entries, one component per wire (group)
        ``names``; the resistance entry's documentation is ``resistance_doc``."""
        return (
            Entry(
                "temperature",
                "temperature",
                "K",
                "wire temperature",
                tuple(f"temperature_{n}" for n in names),
                (0.0, TEMP_OBS_HIGH),
                noise="temperature",
            ),
            Entry(
                "previous_action",
                "action",
                "-",
                "previous action (after clipping)",
                tuple(f"previous_action_{n}" for n in names),
                (-1.0, 1.0),
                info=False,
            ),
            Entry(
                "resistance",
                "resistance",
                "Ohm",
                resistance_doc,
                tuple(f"resistance_{n}" for n in names),
                (0.0, self.resistance_bound()),
                noise="resistance",
            ),
        )

    @staticmethod
    def reward_entries() -> tuple[Entry, Entry, Entry]:
        """The reward (returned by ``step``, not in the info) and its two terms (in the info)."""
        return (
            Entry("reward", "reward", "-", "reward of the step", ("reward",), info=False),
            Entry("reward_tracking", "reward_tracking", "-", "−‖e‖ / error_scale", ("reward_tracking",)),
            Entry("reward_energy", "reward_energy", "-", "−energy_weight · E / E_ref", ("reward_energy",)),
        )

    def error_entries(self, unit: str, names: tuple[str, ...], bound: float) -> tuple[Entry, ...]:
        """The observed tracking errors (``observe_errors``): target − measured tracked entry and
        target preview − measured tracked entry, components ``names``, bounds ±``bound``; () if off.
        They come last in the observation, so the indices of the other entries do not move."""
        if not self.observe_errors:
            return ()
        lim = (-bound, bound)
        return (
            Entry(
                "measured_error",
                "measured_error",
                unit,
                "target − measured tracked quantity",
                tuple(f"error_{n}" for n in names),
                lim,
                info=False,
            ),
            Entry(
                "measured_preview_error",
                "measured_preview_error",
                unit,
                "target preview − measured tracked quantity",
                tuple(f"preview_error_{n}" for n in names),
                lim,
                info=False,
            ),
        )

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


def config_fields(cls: type) -> list[str]:
    """Names of the env's keyword arguments held in its configuration class ``cls``."""
    return [f.name for f in dataclasses.fields(cls)]
