"""Which parameters a fit varies, their bounds, and the default sets "thermal", "mechanical", "all".

A fit parameter is a ModelParams field (``alpha``, ``E_t``, …) or the composite ``T_shift`` [K],
which moves both stress-line anchors ``T_low`` and ``T_high`` by the same amount and so shifts
σ_A(T) and σ_M(T) of MODEL.md §3.1 along the temperature axis without changing their slope: it is
*the* transformation-temperature parameter (the §7 alternative calibration is the baseline with
``T_shift = −20 K``, written there as +140 MPa on both stresses).

A spatial fit (start: a :class:`~spine_gym.SpineLayout`) may also vary one wire's material values
(:class:`~spine_gym.WireGroup`): ``wire<j>.lam_scale`` (resistivity scale), ``wire<j>.T_shift``
[K] (that wire's transformation temperatures, as ``T_shift`` for one wire) and ``wire<j>.eps0``
(its pre-strain), j in the layout's voltage order. The set ``"wires"`` is all three for every
wire plus the shared tube modulus ``E_t`` and convection ``alpha``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..layout import WIRE_VALUE_RANGES, WIRE_VALUES, SpineLayout, wire_key
from ..params import ModelParams

__all__ = ["FitParameter", "PARAMETER_SETS", "UNITS", "WIRE_UNITS", "resolve_parameters", "wire_key"]

# composite parameters: name -> (direction {field: coefficient}, unit, meaning)
COMPOSITES = {
    "T_shift": ({"T_low": 1.0, "T_high": 1.0}, "K", "shift of the transformation temperatures"),
}
# units of the fields a fit may vary (the report prints them); additive ones get bounds ± a shift
UNITS = {
    "alpha": "W/(m^2 K)",
    "lam_A": "Ohm m",
    "lam_M": "Ohm m",
    "E_t": "Pa",
    "E_A": "Pa",
    "E_M": "Pa",
    "eps_T": "-",
    "dsigma": "Pa",
    "sigma_A_low": "Pa",
    "sigma_A_high": "Pa",
    "T_low": "K",
    "T_high": "K",
    "T_E": "K",
    "c": "J/(kg K)",
    "rho": "kg/m^3",
    "tau": "s",
    "V_L": "m^3",
    "L0": "m",
    "eps0": "-",
    "m_seg": "kg",
    "m_top": "kg",
    "T_shift": "K",
}
ADDITIVE = {"T_low": 40.0, "T_high": 40.0, "T_E": 20.0, "T_shift": 40.0}  # default bounds ± this [K]
MULTIPLICATIVE = (0.5, 2.0)  # default bounds of the other parameters: start value × these

PARAMETER_SETS = {
    "thermal": ("alpha", "lam_A", "lam_M", "T_shift"),
    "mechanical": ("E_t", "E_M", "eps_T", "dsigma"),
    "all": ("alpha", "lam_A", "lam_M", "T_shift", "E_t", "E_M", "eps_T", "dsigma", "T_E"),
    "wires": ("wire<j>.lam_scale", "wire<j>.T_shift", "wire<j>.eps0", "E_t", "alpha"),  # every j
}
# per-wire parameters of a spatial layout: wire<j>.<value> (j in voltage order)
WIRE_UNITS = {"lam_scale": "-", "T_shift": "K", "eps0": "-"}
WIRE_ADDITIVE = {"T_shift": 40.0}  # default bounds ± this [K]; the others × MULTIPLICATIVE


def _plain_params(start) -> ModelParams:
    return start.params if isinstance(start, SpineLayout) else start


@dataclass(frozen=True)
class FitParameter:
    """One fitted quantity with its bounds (in its own unit)."""

    name: str
    lower: float
    upper: float

    def __post_init__(self):
        if self.name not in UNITS and wire_key(self.name) is None:
            raise ValueError(
                f"parameter must be one of {sorted(UNITS)} or wire<j>.<{'|'.join(WIRE_VALUES)}>, "
                f"got {self.name!r}"
            )
        for key in ("lower", "upper"):
            v = getattr(self, key)
            if not (isinstance(v, int | float | np.floating) and math.isfinite(v)):
                raise ValueError(f"{self.name}: {key} bound must be a finite number, got {v!r}")
        if not self.lower < self.upper:
            raise ValueError(
                f"{self.name}: lower bound must be < upper bound, got ({self.lower!r}, {self.upper!r})"
            )

    @property
    def unit(self) -> str:
        key = wire_key(self.name)
        return WIRE_UNITS[key[1]] if key else UNITS[self.name]

    @property
    def direction(self) -> dict[str, float]:
        """{ModelParams field: coefficient}: how one unit of this parameter moves the fields."""
        return dict(COMPOSITES[self.name][0]) if self.name in COMPOSITES else {self.name: 1.0}

    def value(self, params: ModelParams | SpineLayout) -> float:
        """The parameter's value in ``params`` (composites are offsets, 0 at any preset; a per-wire
        value needs a SpineLayout)."""
        key = wire_key(self.name)
        if key is not None:
            if not isinstance(params, SpineLayout):
                raise ValueError(
                    f"{self.name}: a per-wire parameter needs a SpineLayout start, got ModelParams"
                )
            if key[0] >= params.n_wires:
                raise ValueError(f"{self.name}: wire index must be < {params.n_wires} (the layout's wires)")
            return float(params.wire_values[key[0]][key[1]])
        return 0.0 if self.name in COMPOSITES else float(getattr(_plain_params(params), self.name))

    @classmethod
    def around(cls, name: str, start: ModelParams | SpineLayout) -> FitParameter:
        """Default bounds about ``start``: ± a shift for temperatures, × [0.5, 2] otherwise, kept
        inside the field's valid range (``ModelParams._RANGES``, the layout's per-wire ranges)."""
        key = wire_key(name)
        if key is not None:
            v = cls(name, 0.0, 1.0).value(start)
            add = WIRE_ADDITIVE.get(key[1])
            lo, hi = (v - add, v + add) if add else (v * MULTIPLICATIVE[0], v * MULTIPLICATIVE[1])
            r_lo, r_hi = WIRE_VALUE_RANGES[key[1]]
            return cls(name, max(lo, r_lo), min(hi, r_hi))
        if name not in UNITS:
            raise ValueError(f"parameter must be one of {sorted(UNITS)}, got {name!r}")
        v = 0.0 if name in COMPOSITES else float(getattr(_plain_params(start), name))
        if name in ADDITIVE:
            lo, hi = v - ADDITIVE[name], v + ADDITIVE[name]
        else:
            lo, hi = sorted((v * MULTIPLICATIVE[0], v * MULTIPLICATIVE[1]))
        if name in ModelParams._RANGES:
            r_lo, r_hi = ModelParams._RANGES[name]
            lo, hi = max(lo, r_lo), min(hi, r_hi)
        return cls(name, lo, hi)


def _expand_set(name: str, start) -> list[str]:
    if name != "wires":
        return list(PARAMETER_SETS[name])
    if not isinstance(start, SpineLayout):
        raise ValueError("parameters 'wires' (per-wire values) needs a SpineLayout start, got ModelParams")
    return [f"wire{j}.{v}" for j in range(start.n_wires) for v in WIRE_VALUES] + ["E_t", "alpha"]


def resolve_parameters(spec, start: ModelParams | SpineLayout) -> tuple[FitParameter, ...]:
    """Turn a user's choice into FitParameters.

    ``spec``: a set name (``"thermal"``, ``"mechanical"``, ``"all"``, ``"wires"`` for a layout), a
    comma-separated string or sequence of names (default bounds), a mapping {name: (lower, upper)
    or None}, or FitParameters.
    """
    if isinstance(spec, str):
        spec = (
            _expand_set(spec, start)
            if spec in PARAMETER_SETS
            else [s.strip() for s in spec.split(",") if s.strip()]
        )
    if isinstance(spec, Mapping):
        items = [
            FitParameter.around(k, start) if b is None else FitParameter(k, float(b[0]), float(b[1]))
            for k, b in spec.items()
        ]
    elif isinstance(spec, Sequence):
        items = [p if isinstance(p, FitParameter) else FitParameter.around(p, start) for p in spec]
    else:
        raise ValueError(
            f"parameters must be one of {sorted(PARAMETER_SETS)}, a list of names or a mapping "
            f"{{name: (lower, upper)}}, got {spec!r}"
        )
    names = [p.name for p in items]
    if not names:
        raise ValueError("parameters must name at least one parameter")
    if len(set(names)) != len(names):
        raise ValueError(f"parameters must not repeat a name, got {names}")
    fields = [f for p in items for f in p.direction]
    if len(set(fields)) != len(fields):
        raise ValueError(f"parameters {names} move the same ModelParams field twice ({sorted(fields)})")
    for p in items:
        v = p.value(start)
        if not p.lower <= v <= p.upper:
            raise ValueError(
                f"{p.name}: start value {v:g} must lie within the bounds [{p.lower:g}, {p.upper:g}]"
            )
    return tuple(items)
