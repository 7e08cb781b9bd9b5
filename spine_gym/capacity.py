"""Capacity metrics of a spine design (seed paper §"design optimisation", MODEL.md §9, §10.4).

The protocol (durations are MODEL.md's choice; the seed gives none):

1. 0 … t_stable: step voltage on the **left** wire. Stable angle θ_s = |Θ(t_stable)|.
2. t_stable … end: the input switches to the **right** wire. Responding time = time after the
   switch to bend to +0.9 θ_s (reading (i)); reading (ii) = time to cover 90 % of the swing from
   Θ(t_stable) to Θ(t_load_on).
3. t_load_on … end: a vertical force (0, −F) on the top disk. Actuating ability =
   1 / |Θ(end) − Θ(t_load_on)| [1/deg].

Spatial and chained layouts (:class:`SpineLayout`) run the same protocol in the plane of the
0°/180° wires: "left" is every module's 180° wire, "right" every module's 0° wire, each at the
protocol voltage times the layout's :attr:`~SpineLayout.voltage_scale` (the same Joule heating as the
seed's wire), the load is the global (0, 0, −F) and Θ is the x component of the tip bending vector.

Everything here is a library function; the experiment and design scripts only call it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .layout import SpineLayout
from .params import ModelParams, SolverOptions
from .simulate import SimulationResult, simulate
from .simulate_spatial import SpatialResult

__all__ = ["CapacityProtocol", "CapacityMetrics", "capacity_metrics", "metrics_from_result", "run_protocol"]


@dataclass(frozen=True)
class CapacityProtocol:
    """Timing and loads of the capacity protocol (MODEL.md §10.4 defaults)."""

    voltage: float = 3.2  # [V] step voltage on the driven wire
    t_stable: float = 60.0  # [s] duration of the left-wire phase
    t_respond: float = 60.0  # [s] right-wire phase before the load
    t_load: float = 30.0  # [s] duration of the loaded phase
    tip_force: float = 1.0  # [N] magnitude of the vertical (downward) tip force
    dt: float = 0.01  # [s] output step

    def __post_init__(self):
        for name, lo, hi in (
            ("voltage", 0.0, 100.0),
            ("t_stable", 0.1, 1e4),
            ("t_respond", 0.1, 1e4),
            ("t_load", 0.1, 1e4),
            ("tip_force", 0.0, 1e3),
            ("dt", 1e-4, 1.0),
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"{name} must be in [{lo:g}, {hi:g}], got {v!r}")

    @property
    def t_load_on(self) -> float:
        """Time [s] at which the tip force is applied."""
        return self.t_stable + self.t_respond

    @property
    def duration(self) -> float:
        """Total duration [s]."""
        return self.t_stable + self.t_respond + self.t_load


@dataclass(frozen=True)
class CapacityMetrics:
    """Result of the capacity protocol. Times are ``inf`` when the level is never reached."""

    stable_angle_deg: float  # θ_s = |Θ(t_stable)| [deg]
    responding_time_s: float  # reading (i): after the switch, to reach +0.9 θ_s before the load [s]
    responding_time_swing_s: float  # reading (ii): 90 % of the swing Θ(t_stable) → Θ(t_load_on) [s]
    load_deflection_deg: float  # |Θ(end) − Θ(t_load_on)| under the tip force [deg]
    actuating_ability: float  # 1 / load_deflection [1/deg]
    peak_temperature_K: float  # hottest wire temperature over the protocol [K]

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def _first_crossing(t: np.ndarray, y: np.ndarray, level: float, t_from: float, t_to: float) -> float:
    """First time in [t_from, t_to] at which y ≥ level, linearly interpolated; inf if never."""
    idx = np.nonzero((t >= t_from - 1e-12) & (t <= t_to + 1e-12) & (y >= level))[0]
    if idx.size == 0:
        return math.inf
    k = int(idx[0])
    if k == 0 or t[k - 1] < t_from - 1e-12 or y[k] == y[k - 1]:
        return float(t[k])
    return float(t[k - 1] + (level - y[k - 1]) * (t[k] - t[k - 1]) / (y[k] - y[k - 1]))


def _angle_and_peak(result: SimulationResult | SpatialResult) -> tuple[np.ndarray, float]:
    """Θ(t) [deg] in the protocol's plane and the hottest wire temperature [K] of a trajectory."""
    if isinstance(result, SpatialResult):
        return result.tip_bending_deg[:, 0], float(result.temperature.max())
    return result.angle_deg, float(max(result.temperature_right.max(), result.temperature_left.max()))


def metrics_from_result(
    result: SimulationResult | SpatialResult, protocol: CapacityProtocol
) -> CapacityMetrics:
    """Capacity metrics of a trajectory produced by :func:`run_protocol`."""
    t = result.time
    a, peak = _angle_and_peak(result)
    a_stable = float(a[result.at(protocol.t_stable)])
    a_load_on = float(a[result.at(protocol.t_load_on)])
    a_end = float(a[-1])
    theta_s = abs(a_stable)
    # the response is read before the load goes on (the loaded phase is a different test)
    t_on = protocol.t_load_on
    t_resp = _first_crossing(t, a, 0.9 * theta_s, protocol.t_stable, t_on) - protocol.t_stable
    swing = a_load_on - a_stable
    if swing > 0.0:
        t_swing = _first_crossing(t, a, a_stable + 0.9 * swing, protocol.t_stable, t_on) - protocol.t_stable
    else:
        t_swing = math.inf
    defl = abs(a_end - a_load_on)
    return CapacityMetrics(
        stable_angle_deg=theta_s,
        responding_time_s=t_resp,
        responding_time_swing_s=t_swing,
        load_deflection_deg=defl,
        actuating_ability=1.0 / defl if defl > 0.0 else math.inf,
        peak_temperature_K=peak,
    )


def _layout_voltages(layout: SpineLayout, v_right: np.ndarray, v_left: np.ndarray) -> np.ndarray:
    """(n, W) voltages: ``v_right`` on every module's 0° wire, ``v_left`` on its 180° wire, scaled."""
    volts = np.zeros((v_right.shape[0], layout.n_wires))
    j = 0
    for k, m in enumerate(layout.modules):
        psi = [w.psi_deg for w in m.wires]
        if 0.0 not in psi or 180.0 not in psi:
            raise ValueError(
                f"layout.modules[{k}] needs wires at psi_deg 0 and 180 for the capacity protocol, got {psi}"
            )
        volts[:, j + psi.index(0.0)] = v_right
        volts[:, j + psi.index(180.0)] = v_left
        j += len(psi)
    return volts * layout.voltage_scale


def run_protocol(
    params: ModelParams | None = None,
    protocol: CapacityProtocol | None = None,
    solver: SolverOptions | None = None,
    layout: SpineLayout | None = None,
) -> SimulationResult | SpatialResult:
    """Simulate the capacity protocol; returns the full trajectory (a SpatialResult for a layout)."""
    p = protocol or CapacityProtocol()
    n = int(round(p.duration / p.dt))
    t = np.arange(n) * p.dt
    eps = 1e-9
    v_left = np.where(t < p.t_stable - eps, p.voltage, 0.0)
    v_right = np.where(t >= p.t_stable - eps, p.voltage, 0.0)
    if layout is not None:
        if params is not None:
            raise ValueError(f"pass params inside the layout, not beside it; got params={params!r}")
        tip = np.zeros((n, 3))
        tip[t >= p.t_load_on - eps, 2] = -p.tip_force
        volts = _layout_voltages(layout, v_right, v_left)
        return simulate(n * p.dt, volts, dt=p.dt, tip_force=tip, solver=solver, layout=layout)
    tip = np.zeros((n, 2))
    tip[t >= p.t_load_on - eps, 1] = -p.tip_force
    return simulate(n * p.dt, v_right, v_left, dt=p.dt, tip_force=tip, params=params, solver=solver)


def capacity_metrics(
    params: ModelParams | None = None,
    protocol: CapacityProtocol | None = None,
    solver: SolverOptions | None = None,
    layout: SpineLayout | None = None,
) -> CapacityMetrics:
    """Run the capacity protocol for one design (``params``, or a spatial/chained ``layout``)."""
    p = protocol or CapacityProtocol()
    return metrics_from_result(run_protocol(params, p, solver, layout), p)
