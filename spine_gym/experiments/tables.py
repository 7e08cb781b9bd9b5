"""The comparison tables of the reproduction: each experiment's model values next to MODEL.md §10.

A :class:`Row` is one compared quantity with its tolerance, a :class:`Section` the table of one
experiment (:func:`compare_hysteresis`, :func:`compare_alternate`, :func:`compare_capacity`), and
:func:`format_section` its markdown.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

from ..capacity import CapacityMetrics
from ..simulate import SimulationResult
from .references import (
    ALTERNATE_REFERENCE,
    ALTERNATE_SWING_TIMES,
    ANGLE_TOL_DEG,
    CAPACITY_FIELDS,
    CAPACITY_REFERENCE,
    HYSTERESIS_REFERENCE,
    QUICK_CASES,
    SEED_MAX_ERROR_DEG,
    SWING_TOL_DEG,
    T_SWITCH,
    alternate_events,
    hysteresis_events,
)

__all__ = [
    "Row",
    "Section",
    "capacity_cases",
    "compare_alternate",
    "compare_capacity",
    "compare_experiments",
    "compare_hysteresis",
    "format_section",
]


# --------------------------------------------------------------------------------------- rows
@dataclass(frozen=True)
class Row:
    """One compared quantity: the model's value next to the MODEL.md §10 reference.

    Attributes:
        quantity: what is compared (e.g. ``"Θ(20 s)"``).
        unit: its unit.
        model: the value this package computes.
        reference: the MODEL.md §10 reference solution value.
        tolerance: the gate used to flag a deviation (MODEL.md's where it gives one, else ours).
        decimals: decimals to print.
    """

    quantity: str
    unit: str
    model: float
    reference: float
    tolerance: float
    decimals: int = 2

    @property
    def deviation(self) -> float:
        """model − reference (``nan`` if either is not finite)."""
        if not (math.isfinite(self.model) and math.isfinite(self.reference)):
            return math.nan
        return self.model - self.reference

    @property
    def within(self) -> bool:
        """|deviation| <= tolerance (False if the model value is not finite)."""
        d = self.deviation
        return math.isfinite(d) and abs(d) <= self.tolerance + 1e-12

    def as_dict(self) -> dict:
        d = asdict(self)
        d.pop("decimals")
        d.update(deviation=self.deviation, within=self.within)
        return d


@dataclass
class Section:
    """A comparison table of one experiment."""

    key: str
    title: str
    rows: list[Row]
    notes: list[str] = field(default_factory=list)

    @property
    def n_outside(self) -> int:
        """Rows whose deviation exceeds their tolerance."""
        return sum(not r.within for r in self.rows)

    def max_abs_deviation(self, unit: str = "deg", prefix: str = "Θ(") -> float:
        """Largest |deviation| over the rows of a unit whose quantity starts with ``prefix``."""
        d = [abs(r.deviation) for r in self.rows if r.unit == unit and r.quantity.startswith(prefix)]
        return max(d) if d else math.nan


# ------------------------------------------------------------------------------- comparisons
def compare_hysteresis(result: SimulationResult) -> Section:
    """The §10.2 comparison: trajectory, event times, state at 20 s and maxima."""
    rows = [
        Row(f"Θ({t:g} s)", "deg", float(result.angle_deg[result.at(t)]), ref, ANGLE_TOL_DEG)
        for t, ref in HYSTERESIS_REFERENCE.items()
    ]
    ev = hysteresis_events(result)
    rows += [
        Row("onset (Θ > 0.5°)", "s", ev["onset_s"], 5.5, 0.3),
        Row("90 % of Θ(20 s) reached", "s", ev["rise90_s"], 17.1, 0.3),
        Row("after switch-off: Θ < 10 % of peak", "s", ev["relax10_after_off_s"], 26.0, 0.5),
        Row("after switch-off: Θ < 1°", "s", ev["below1deg_after_off_s"], 26.8, 0.5),
    ]
    k = result.at(T_SWITCH)
    rows += [
        Row("T_R(20 s)", "K", float(result.temperature_right[k]), 401.9, 1.0, 1),
        Row("σ_R(20 s)", "MPa", float(result.stress_right[k]) / 1e6, 428.0, 3.0, 1),
        Row("σ_L(20 s)", "MPa", float(result.stress_left[k]) / 1e6, 360.0, 3.0, 1),
        Row("x_A,R(20 s)", "-", float(result.x_austenite_right[k]), 0.652, 0.01, 3),
        Row("ε_R(20 s)", "-", float(result.strain_right[k]), 0.0284, 3e-4, 4),
        Row("ε_L(20 s)", "-", float(result.strain_left[k]), 0.0674, 3e-4, 4),
        Row("max T_R", "K", float(result.temperature_right.max()), 401.9, 1.0, 1),
        Row("max σ_R", "MPa", float(result.stress_right.max()) / 1e6, 429.0, 3.0, 1),
        Row("max σ_L", "MPa", float(result.stress_left.max()) / 1e6, 361.0, 3.0, 1),
    ]
    sec = Section("hysteresis", "§10.2 Hysteresis run (right wire 3.2 V for 0–20 s, then 0 V; 50 s)", rows)
    sec.notes.append(
        f"max |ΔΘ| over the {len(HYSTERESIS_REFERENCE)} reference times: "
        f"{sec.max_abs_deviation():.3f} deg (the seed's model vs its experiment: max error "
        f"{SEED_MAX_ERROR_DEG['hysteresis']} deg)"
    )
    return sec


def compare_alternate(result: SimulationResult) -> Section:
    """The §10.3 comparison: trajectory (swing times at 1.0°, others 0.5°) and event times."""
    rows = []
    for t, ref in ALTERNATE_REFERENCE.items():
        tol = SWING_TOL_DEG if t in ALTERNATE_SWING_TIMES else ANGLE_TOL_DEG
        rows.append(Row(f"Θ({t:g} s)", "deg", float(result.angle_deg[result.at(t)]), ref, tol))
    ev = alternate_events(result)
    rows += [
        Row("zero crossing", "s", ev["zero_crossing_s"], 31.5, 0.3),
        Row("swing +20° → −20°", "s", ev["swing_s"], 3.65, 0.5),
    ]
    sec = Section("alternate", "§10.3 Alternate drive (right 3.2 V for 0–20 s, left 3.2 V for 20–40 s)", rows)
    sec.notes.append(
        f"max |ΔΘ| over the {len(ALTERNATE_REFERENCE)} reference times: {sec.max_abs_deviation():.3f} deg "
        f"(the seed's model vs its experiment: max error {SEED_MAX_ERROR_DEG['alternate']} deg); "
        "MODEL.md §10.3: the swing times 29.5–31.5 s are roundoff-sensitive and gated at 1.0 deg"
    )
    return sec


def capacity_cases(quick: bool = False) -> list[str]:
    """Names of the §10.4 cases to run (all seven, or a four-case subset with ``quick``)."""
    return list(QUICK_CASES) if quick else list(CAPACITY_REFERENCE)


def compare_capacity(metrics: dict[str, CapacityMetrics]) -> Section:
    """The §10.4 comparison: every metric of every case run (keys of :data:`CAPACITY_REFERENCE`)."""
    rows = []
    for case, m in metrics.items():
        if case not in CAPACITY_REFERENCE:
            raise ValueError(f"unknown capacity case {case!r}; valid: {list(CAPACITY_REFERENCE)}")
        ref = CAPACITY_REFERENCE[case][1]
        for key, attr, label, unit, tol, relative in CAPACITY_FIELDS:
            r = ref[key]
            dec = 3 if unit == "1/deg" else 2
            rows.append(
                Row(f"{case}: {label}", unit, float(getattr(m, attr)), r, tol * r if relative else tol, dec)
            )
    sec = Section(
        "capacity",
        "§10.4 Capacity protocol and design studies (3.2 V; 60 s left, 60 s right, 30 s 1 N)",
        rows,
    )
    sec.notes.append(
        "protocol: left wire 0–60 s (θ_s = |Θ(60 s)|), right wire 60–150 s, tip force (0, −1 N) from "
        "120 s; ability = 1/|Θ(150 s) − Θ(120 s)|; tolerances: 0.5 deg, 0.3 s, 0.1 deg, 3 % (ours)"
    )
    return sec



def compare_experiments(
    hysteresis: SimulationResult, alternate: SimulationResult, capacity: dict[str, CapacityMetrics]
) -> list[Section]:
    """The sections of the whole reproduction: §10.2, §10.3 and §10.4, in that order."""
    return [compare_hysteresis(hysteresis), compare_alternate(alternate), compare_capacity(capacity)]


# ------------------------------------------------------------------------------- formatting
def _fmt(v: float, dec: int, signed: bool = False) -> str:
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return f"{v:+.{dec}f}" if signed else f"{v:.{dec}f}"


def format_section(section: Section) -> str:
    """A markdown table of one section (model, reference, deviation, tolerance, within?)."""
    head = ["quantity", "unit", "model", "reference (MODEL.md §10)", "deviation", "tolerance", "within"]
    body = [
        [
            r.quantity,
            r.unit,
            _fmt(r.model, r.decimals),
            _fmt(r.reference, r.decimals),
            _fmt(r.deviation, r.decimals, signed=True),
            f"{r.tolerance:g}",
            "yes" if r.within else "NO",
        ]
        for r in section.rows
    ]
    widths = [max(len(h), *(len(b[i]) for b in body)) for i, h in enumerate(head)]

    def line(cells):
        return "| " + " | ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)) + " |"

    out = [f"### {section.title}", "", line(head), "|" + "|".join("-" * (w + 2) for w in widths) + "|"]
    out += [line(b) for b in body]
    out.append("")
    out += [f"* {n}" for n in section.notes]
    out.append(f"* rows outside tolerance: {section.n_outside} of {len(section.rows)}")
    return "\n".join(out)
