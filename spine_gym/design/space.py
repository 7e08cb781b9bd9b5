"""Design variables, metrics and the evaluation of one design (MODEL.md §9 "capacity", §10.4).

A *design* is a set of overrides on the baseline: any :class:`~spine_gym.params.ModelParams` field
(``spine_gym.params.field_names()``: wire offset ``a``, wires per side ``n_w``, pre-strain ``eps0``,
tube modulus ``E_t``, …), the drive ``voltage`` of the capacity protocol
(:class:`~spine_gym.capacity.CapacityProtocol`) and the layout parameter ``n_modules``
(:data:`LAYOUT_PARAMS`). Without ``n_modules`` a design is the planar spine (``ModelParams``);
with it, it is the chained spatial spine :meth:`SpineLayout.chain(n_modules, params)
<spine_gym.layout.SpineLayout.chain>` (``n_modules=1``: the seed's one four-wire module), whose
factory reads ``a``, ``n_w``, ``n_seg``, ``ls``, ``L0`` and ``m_top`` of the params, so the same
axes sweep the wire offset and the wire count of every module (SPATIAL.md §1, §6). Each design is
scored by :func:`spine_gym.capacity.capacity_metrics` (``layout=`` for the spatial ones); this
module neither re-implements the protocol nor the physics, it only parses user specifications,
validates them up front (so that a typo fails before any worker starts) and turns one evaluation
into a flat record.

Specification grammar (shared by the CLI and the Python API):

* sweep axis ``name=lo:hi:n`` — ``n`` evenly spaced values from ``lo`` to ``hi`` (inclusive);
  ``name=lo:hi:n:log`` — geometric spacing; ``name=v1,v2,...`` — an explicit list; ``name=v`` —
  one value.
* search range ``name=lo:hi`` — continuous (integer for integer fields) range; ``name=lo:hi:log`` —
  log-uniform; ``name=v1,v2,...`` — a categorical choice.
* assignment ``name=value`` — a fixed override of the base design.
* constraint ``metric>=x`` or ``metric<=y``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..capacity import CapacityMetrics, CapacityProtocol, capacity_metrics
from ..layout import MAX_MODULES, SpineLayout
from ..params import ModelParams, SolverOptions, field_names
from ..physics import columns as L
from ..simulate import SimulationError

__all__ = [
    "METRICS",
    "METRIC_ALIASES",
    "LAYOUT_PARAMS",
    "PROTOCOL_PARAMS",
    "Constraint",
    "SearchDim",
    "design_parameter_names",
    "design_params",
    "evaluate_design",
    "is_integer_param",
    "make_design",
    "parameter_range",
    "parse_assignment",
    "parse_constraint",
    "parse_search_spec",
    "parse_sweep_spec",
    "resolve_metric",
]

#: Metrics of one design, in CSV column order (fields of CapacityMetrics), with units.
METRICS: dict[str, str] = {
    "stable_angle_deg": "stable angle θ_s [deg]",
    "responding_time_s": "responding time (i) [s]",
    "responding_time_swing_s": "responding time (ii) [s]",
    "load_deflection_deg": "deflection under tip force [deg]",
    "actuating_ability": "actuating ability [1/deg]",
    "peak_temperature_K": "peak wire temperature [K]",
}
assert list(METRICS) == [f.name for f in dataclasses.fields(CapacityMetrics)]

#: Short names accepted wherever a metric is named.
METRIC_ALIASES: dict[str, str] = {
    "stable_angle": "stable_angle_deg",
    "angle": "stable_angle_deg",
    "responding_time": "responding_time_s",
    "response_time": "responding_time_s",
    "responding_time_swing": "responding_time_swing_s",
    "load_deflection": "load_deflection_deg",
    "deflection": "load_deflection_deg",
    "ability": "actuating_ability",
    "peak_temperature": "peak_temperature_K",
}

#: Metrics that are ``inf`` when the protocol never reaches the level (CapacityMetrics docstring):
#: the responding times, and the ability when the tip force moves the spine by exactly 0 deg.
INF_METRICS = ("responding_time_s", "responding_time_swing_s", "actuating_ability")

#: Design variables that live in the capacity protocol rather than in ModelParams.
PROTOCOL_PARAMS: dict[str, tuple[float, float]] = {"voltage": (0.0, 100.0)}  # [V], CapacityProtocol

#: Design variables of the layout (integers): a design that sets one runs on a SpineLayout.
LAYOUT_PARAMS: dict[str, tuple[int, int]] = {"n_modules": (1, MAX_MODULES)}  # SpineLayout.chain

_MODEL_FIELDS = frozenset(field_names())
_INT_FIELDS = frozenset(
    f.name for f in dataclasses.fields(ModelParams) if f.type in ("int", int)
) | frozenset(LAYOUT_PARAMS)


def design_parameter_names() -> list[str]:
    """Every name a design study may vary: the ModelParams fields, ``voltage``, then ``n_modules``."""
    return field_names() + list(PROTOCOL_PARAMS) + list(LAYOUT_PARAMS)


def is_integer_param(name: str) -> bool:
    """True for integer design variables (``n_w``, ``n_seg``, ``n_modules``)."""
    return name in _INT_FIELDS


def _check_name(name: str) -> str:
    name = name.strip()
    if name not in _MODEL_FIELDS and name not in PROTOCOL_PARAMS and name not in LAYOUT_PARAMS:
        raise ValueError(
            f"unknown design parameter {name!r}; valid names: {', '.join(design_parameter_names())}"
        )
    return name


def parameter_range(name: str) -> tuple[float, float]:
    """The allowed [lo, hi] of one design variable (cross-field rules are checked separately)."""
    name = _check_name(name)
    if name in PROTOCOL_PARAMS:
        return PROTOCOL_PARAMS[name]
    if name in LAYOUT_PARAMS:
        return LAYOUT_PARAMS[name]
    return ModelParams._RANGES[name]


def resolve_metric(name: str) -> str:
    """Canonical metric name for ``name`` or an alias; ValueError listing the valid ones."""
    key = name.strip()
    key = METRIC_ALIASES.get(key, key)
    if key not in METRICS:
        raise ValueError(
            f"unknown metric {name!r}; valid metrics: {', '.join(METRICS)} "
            f"(aliases: {', '.join(METRIC_ALIASES)})"
        )
    return key


def _split(spec: str, what: str) -> tuple[str, str]:
    if "=" not in spec:
        raise ValueError(f"{what} {spec!r} must look like NAME=VALUES")
    name, _, rhs = spec.partition("=")
    name = _check_name(name)
    rhs = rhs.strip()
    if not rhs:
        raise ValueError(f"{what} for {name!r} has no value")
    return name, rhs


def _number(name: str, text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ValueError(f"{name}: {text!r} is not a number") from None
    if not math.isfinite(v):
        raise ValueError(f"{name}: values must be finite, got {text!r}")
    return v


def _as_param_values(name: str, values) -> list[float | int]:
    """Cast to int for integer fields (refusing fractions), float otherwise."""
    out: list[float | int] = []
    for v in values:
        v = float(v)
        if is_integer_param(name):
            r = round(v)
            if abs(v - r) > 1e-9 * max(1.0, abs(v)):
                lo, hi = parameter_range(name)
                raise ValueError(f"{name} takes integers in [{lo}, {hi}], got {v!r}")
            out.append(int(r))
        else:
            out.append(v)
    return out


def _check_values_in_range(name: str, values) -> None:
    lo, hi = parameter_range(name)
    for v in values:
        if not lo <= v <= hi:
            raise ValueError(f"{name} must be in [{lo:g}, {hi:g}], got {v!r}")


def _range_fields(name: str, rhs: str, what: str, n_fields: int, forms: str) -> tuple[list[str], bool]:
    """The ``:``-separated fields of the range ``rhs`` without its optional ``:log``, and whether it had
    one; ValueError naming the allowed ``forms`` unless there are ``n_fields``."""
    parts = rhs.split(":")
    log = parts[-1].strip().lower() == "log"
    if log:
        parts = parts[:-1]
    if len(parts) != n_fields:
        raise ValueError(f"{what} for {name!r} must be {forms}, got {rhs!r}")
    return parts, log


def _check_value_list(name: str, values, what: str, kind: str) -> None:
    """ValueError unless ``values`` (the ``kind`` of a ``what``) are some, distinct and in range."""
    if not values:
        raise ValueError(f"{what} for {name!r} has no values")
    if len(set(values)) != len(values):
        raise ValueError(f"{name}: {kind} must be distinct, got {values}")
    _check_values_in_range(name, values)


def parse_sweep_spec(spec: str) -> tuple[str, list[float | int]]:
    """Parse one sweep axis ``name=lo:hi:n[:log]``, ``name=v1,v2,...`` or ``name=v``.

    Returns:
        (name, values) with values cast to int for integer fields.

    Raises:
        ValueError: unknown name, malformed spec, or a value outside the field's range (message
        names the parameter and the allowed range).
    """
    name, rhs = _split(spec, "sweep spec")
    if ":" in rhs:
        parts, log = _range_fields(name, rhs, "sweep spec", 3, "lo:hi:n or lo:hi:n:log")
        lo, hi = _number(name, parts[0]), _number(name, parts[1])
        try:
            n = int(parts[2])
        except ValueError:
            raise ValueError(f"{name}: number of points must be an integer, got {parts[2]!r}") from None
        if n < 1:
            raise ValueError(f"{name}: number of points must be >= 1, got {n}")
        if n == 1 and lo != hi:
            raise ValueError(f"{name}: one point needs lo == hi, got {lo:g}:{hi:g}:1")
        if log:
            if lo <= 0 or hi <= 0:
                raise ValueError(f"{name}: a log sweep needs lo, hi > 0, got {lo:g}:{hi:g}")
            raw = np.geomspace(lo, hi, n)
        else:
            raw = np.linspace(lo, hi, n)
        values = _as_param_values(name, raw)
    else:
        values = _as_param_values(name, [_number(name, t) for t in rhs.split(",") if t.strip()])
    _check_value_list(name, values, "sweep spec", "sweep values")
    return name, values


@dataclass(frozen=True)
class SearchDim:
    """One dimension of an optimiser search space.

    Attributes:
        name: design parameter.
        low, high: bounds of a range (None for a categorical dimension).
        log: log-uniform range.
        choices: categorical values (None for a range).
    """

    name: str
    low: float | None = None
    high: float | None = None
    log: bool = False
    choices: tuple | None = None

    @property
    def is_int(self) -> bool:
        return is_integer_param(self.name)

    def suggest(self, trial) -> float | int:
        """Draw this dimension from an Optuna trial."""
        if self.choices is not None:
            return trial.suggest_categorical(self.name, list(self.choices))
        if self.is_int:
            return trial.suggest_int(self.name, int(self.low), int(self.high), log=self.log)
        return trial.suggest_float(self.name, float(self.low), float(self.high), log=self.log)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self) | {"choices": None if self.choices is None else list(self.choices)}


def parse_search_spec(spec: str) -> SearchDim:
    """Parse one search dimension ``name=lo:hi[:log]`` or ``name=v1,v2,...`` (categorical)."""
    name, rhs = _split(spec, "search spec")
    if ":" in rhs:
        parts, log = _range_fields(name, rhs, "search spec", 2, "lo:hi or lo:hi:log")
        lo, hi = _as_param_values(name, [_number(name, parts[0]), _number(name, parts[1])])
        if not lo < hi:
            raise ValueError(f"{name}: search range needs lo < hi, got {lo!r}:{hi!r}")
        if log and lo <= 0:
            raise ValueError(f"{name}: a log range needs lo > 0, got {lo!r}")
        _check_values_in_range(name, (lo, hi))
        return SearchDim(name, low=lo, high=hi, log=log)
    values = _as_param_values(name, [_number(name, t) for t in rhs.split(",") if t.strip()])
    _check_value_list(name, values, "search spec", "categorical choices")
    return SearchDim(name, choices=tuple(values))


def parse_assignment(spec: str) -> tuple[str, float | int]:
    """Parse a fixed override ``name=value`` of the base design."""
    name, rhs = _split(spec, "assignment")
    (value,) = _as_param_values(name, [_number(name, rhs)])
    _check_values_in_range(name, (value,))
    return name, value


#: Finite stand-in for an infinite violation (Optuna's constraint values must be finite-ish floats
#: and stay JSON-safe in every storage backend).
INF_VIOLATION = 1e9


@dataclass(frozen=True)
class Constraint:
    """``metric >= bound`` (sense ``">="``) or ``metric <= bound`` (sense ``"<="``)."""

    metric: str
    sense: str
    bound: float

    def __post_init__(self):
        object.__setattr__(self, "metric", resolve_metric(self.metric))
        if self.sense not in (">=", "<="):
            raise ValueError(f"constraint sense must be '>=' or '<=', got {self.sense!r}")
        if not math.isfinite(self.bound):
            raise ValueError(f"constraint bound on {self.metric} must be finite, got {self.bound!r}")

    def violation(self, value: float) -> float:
        """Amount by which ``value`` violates the constraint (<= 0 means satisfied).

        ``inf`` metrics are handled explicitly: a responding time that is never reached (inf)
        violates ``<= y`` by :data:`INF_VIOLATION`, and an infinite ability satisfies ``>= x``.
        NaN (a failed simulation) counts as violated by INF_VIOLATION.
        """
        if math.isnan(value):
            return INF_VIOLATION
        v = value - self.bound if self.sense == "<=" else self.bound - value
        return float(min(max(v, -INF_VIOLATION), INF_VIOLATION))

    def __str__(self) -> str:
        return f"{self.metric}{self.sense}{self.bound:g}"


def parse_constraint(spec: str) -> Constraint:
    """Parse ``metric>=x`` or ``metric<=y`` (metric names or aliases)."""
    for sense in (">=", "<="):
        if sense in spec:
            left, _, right = spec.partition(sense)
            metric = resolve_metric(left)
            return Constraint(metric, sense, _number(metric, right.strip()))
    raise ValueError(f"constraint {spec!r} must look like METRIC>=X or METRIC<=Y")


def design_params(model: ModelParams | SpineLayout) -> ModelParams:
    """The ModelParams of a design (a layout's ``params``)."""
    return model.params if isinstance(model, SpineLayout) else model


def _as_chain(layout: SpineLayout) -> int:
    """``n_modules`` of a layout made by :meth:`SpineLayout.chain` (ValueError for any other)."""
    n = layout.n_modules
    if layout != SpineLayout.chain(n, layout.params):
        raise ValueError(
            "base layout must be SpineLayout.chain(n_modules, params) (design overrides rebuild it "
            f"from its params), got a layout with {n} module(s) of another geometry"
        )
    return n


def make_design(
    overrides: dict[str, float | int],
    base: ModelParams | SpineLayout | None = None,
    protocol: CapacityProtocol | None = None,
) -> tuple[ModelParams | SpineLayout, CapacityProtocol]:
    """Apply design overrides to a base design and protocol (all validated).

    Args:
        overrides: ``{name: value}`` of any :func:`design_parameter_names`.
        base: a ModelParams (planar spine) or a layout made by :meth:`SpineLayout.chain`
            (default: the MODEL.md §7 baseline, planar).
        protocol: base capacity protocol.

    Returns:
        ``(model, protocol)``: ``model`` is a ModelParams for a planar design and
        ``SpineLayout.chain(n_modules, params)`` when ``n_modules`` is overridden or the base is a
        chain (the params overrides then apply to every module: ``a``, ``n_w``, ...).

    Raises:
        ValueError: unknown name or an invalid value (incl. a chain past self-weight buckling);
        the message names the parameter.
    """
    base = base or ModelParams()
    protocol = protocol or CapacityProtocol()
    n_modules = _as_chain(base) if isinstance(base, SpineLayout) else None
    model_kw: dict[str, Any] = {}
    proto_kw: dict[str, Any] = {}
    for k, v in overrides.items():
        k = _check_name(k)
        v = _as_param_values(k, [v])[0]
        if k in LAYOUT_PARAMS:
            _check_values_in_range(k, (v,))
            n_modules = v
        else:
            (proto_kw if k in PROTOCOL_PARAMS else model_kw)[k] = v
    try:
        params = design_params(base)
        params = params.replace(**model_kw) if model_kw else params
        proto = dataclasses.replace(protocol, **proto_kw) if proto_kw else protocol
        model = params if n_modules is None else SpineLayout.chain(n_modules, params)
    except ValueError as e:
        shown = ", ".join(f"{k}={v!r}" for k, v in overrides.items())
        raise ValueError(f"invalid design ({shown}): {e}") from e
    return model, proto


def evaluate_design(
    model: ModelParams | SpineLayout, protocol: CapacityProtocol, solver: SolverOptions | None = None
) -> dict[str, Any]:
    """Capacity metrics of one design (planar ``ModelParams`` or a ``SpineLayout``) as a flat record.

    Returns:
        dict with every :data:`METRICS` key (floats; ``inf`` where a level is never reached, NaN
        only when the simulation failed) and ``status``: ``"ok"``, ``"buckled: <reason>"`` when a
        load of the protocol (gravity, the tip force) is past the design's buckling load
        (``layout.ERR_BUCKLING``, see :func:`spine_gym.buckling.critical_load`), or
        ``"failed: <reason>"`` for any other failure of the simulation.
    """
    try:
        if isinstance(model, SpineLayout):
            m = capacity_metrics(protocol=protocol, solver=solver, layout=model)
        else:
            m = capacity_metrics(model, protocol, solver)
    except SimulationError as e:
        cause = "buckled" if e.status == L.ERR_BUCKLING else "failed"
        return {k: math.nan for k in METRICS} | {"status": f"{cause}: {e}"}
    return {k: float(v) for k, v in m.as_dict().items()} | {"status": "ok"}
