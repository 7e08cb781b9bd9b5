"""What a controller can reach in the spatial envs, computed from the model (the docstrings' reach tables).

A row is a steady state of :func:`spine_gym.simulate_spatial` without load: the wire(s) of one
direction heated from cold at a constant voltage for :data:`HOLD_S` seconds; the voltage that
holds a bend Θ is found by bisection. ``python -m spine_gym.envs.reach`` recomputes the tables
(about a minute); the numbers below are its output at the defaults and the env docstrings quote
them (``tests/envs/test_env_spatial.py`` checks rows against the model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from ..layout import SpineLayout
from ..simulate_spatial import simulate_spatial

__all__ = ["HOLD_S", "ReachRow", "hold", "voltage_for", "reach_3d", "reach_chain", "REACH_3D", "REACH_CHAIN"]

HOLD_S = 60.0  # [s] hold time of a steady state
DIRECTIONS = {"axis": (0,), "diagonal": (0, 1)}  # heated wires of each module (ψ = 0°, 90°)


@dataclass(frozen=True)
class ReachRow:
    """One steady state: bend Θ [deg] toward ``direction``, seed-equivalent voltage [V] on the
    heated wires, their temperature [K], total electrical power [W], tip position (x, y, z) [mm]."""

    theta: float
    direction: str
    voltage: float
    temperature: float
    power: float
    tip_mm: tuple[float, float, float]


def _volts(layout: SpineLayout, direction: str, v: float) -> np.ndarray:
    """Voltages: ``v`` (seed-equivalent, × the wire's voltage scale) on the direction's wires of
    every module."""
    out = np.zeros(layout.n_wires)
    j = 0
    for m in layout.modules:
        for w in DIRECTIONS[direction]:
            out[j + w] = v
        j += len(m.wires)
    return out * layout.voltage_scale


def hold(layout: SpineLayout, direction: str, v: float) -> tuple[float, ReachRow]:
    """Steady state at seed-equivalent voltage ``v``: (smallest module bend Θ [deg], the row)."""
    res = simulate_spatial(HOLD_S, _volts(layout, direction, v), layout=layout)
    bends = np.hypot(res.module_bending_deg[-1, :, 0], res.module_bending_deg[-1, :, 1])
    heated = _volts(layout, direction, 1.0) > 0
    theta = float(bends.min())
    row = ReachRow(
        theta=theta,
        direction=direction,
        voltage=float(v),
        temperature=float(res.temperature[-1, heated].max()),
        power=float(res.power[-1].sum()),
        tip_mm=tuple(float(x) for x in 1000.0 * res.tip_position[-1]),
    )
    return theta, row


def voltage_for(
    layout: SpineLayout, direction: str, theta: float, v_hi: float = 5.0, tol: float = 0.005
) -> ReachRow:
    """The row whose voltage holds every module at a bend of at least ``theta`` [deg] (bisection)."""
    lo, hi = 0.0, v_hi
    best = hold(layout, direction, hi)[1]
    if best.theta < theta:
        raise ValueError(f"theta = {theta:g} deg is beyond the reach at {v_hi:g} V ({best.theta:.1f} deg)")
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        t, row = hold(layout, direction, mid)
        if t >= theta:
            hi, best = mid, row
        else:
            lo = mid
    return best


def _rows(layout: SpineLayout, thetas, label: str) -> list[ReachRow]:
    cases = [(t, d) for t in thetas for d in DIRECTIONS]
    return [voltage_for(layout, d, t) for t, d in tqdm(cases, desc=label, unit="row")]


def reach_3d(thetas=(20.0, 30.0, 40.0, 45.0)) -> list[ReachRow]:
    """Rows of ``SmaSpine3D-v0`` (the seed's four-wire module)."""
    return _rows(SpineLayout.seed(), thetas, "SmaSpine3D-v0")


def reach_chain(n_modules: int = 2, thetas=(10.0, 15.0, 20.0, 25.0)) -> list[ReachRow]:
    """Rows of ``SmaSpineChain-v0``: every module bent by Θ the same way."""
    return _rows(SpineLayout.chain(n_modules), thetas, "SmaSpineChain-v0")


def markdown(rows, theta_label: str = "Θ [deg]") -> str:
    """The rows as a Markdown table."""
    lines = [
        f"| {theta_label} | direction | voltage [V] | wire T [K] | power [W] | tip (x, y, z) [mm] |",
        "|---|---|--:|--:|--:|---|",
    ]
    for r in rows:
        x, y, z = r.tip_mm
        lines.append(
            f"| {r.theta:.1f} | {r.direction} | {r.voltage:.2f} | {r.temperature:.0f} | {r.power:.2f} | "
            f"({x:.0f}, {y:.0f}, {z:.0f}) |"
        )
    return "\n".join(lines)


# the output of ``python -m spine_gym.envs.reach`` at the defaults (quoted by the env docstrings)
REACH_3D: tuple[ReachRow, ...] = (
    ReachRow(20.110, "axis", 2.1533, 367.32, 2.242, (86.9, 0.0, 444.2)),
    ReachRow(20.799, "diagonal", 2.1045, 365.07, 4.343, (63.5, 63.5, 443.5)),
    ReachRow(30.135, "axis", 2.5000, 390.14, 2.913, (128.2, 0.0, 431.0)),
    ReachRow(30.102, "diagonal", 2.1924, 369.82, 4.627, (90.6, 90.6, 431.1)),
    ReachRow(40.031, "axis", 2.8320, 414.14, 3.625, (166.8, 0.0, 413.3)),
    ReachRow(40.078, "diagonal", 2.4365, 385.77, 5.568, (118.1, 118.1, 413.2)),
    ReachRow(45.092, "axis", 2.9980, 426.98, 4.006, (185.5, 0.0, 402.5)),
    ReachRow(45.152, "diagonal", 2.5586, 394.17, 6.066, (131.4, 131.4, 402.4)),
)
REACH_CHAIN: tuple[ReachRow, ...] = (
    ReachRow(10.013, "axis", 2.1680, 368.33, 2.269, (83.3, 0.0, 444.8)),
    ReachRow(10.228, "diagonal", 2.1143, 365.77, 4.369, (67.9, 67.9, 441.7)),
    ReachRow(15.052, "axis", 2.5244, 391.98, 2.964, (123.3, 0.0, 432.3)),
    ReachRow(15.066, "diagonal", 2.2119, 371.15, 4.700, (87.3, 87.3, 432.2)),
    ReachRow(20.042, "axis", 2.8662, 416.96, 3.703, (160.9, 0.0, 415.2)),
    ReachRow(20.042, "diagonal", 2.4609, 387.57, 5.667, (113.8, 113.8, 415.2)),
    ReachRow(25.037, "axis", 3.1982, 443.52, 4.487, (195.9, 0.0, 394.0)),
    ReachRow(25.044, "diagonal", 2.7051, 404.84, 6.688, (138.6, 138.6, 393.9)),
)


if __name__ == "__main__":
    for name, rows in (("REACH_3D", reach_3d()), ("REACH_CHAIN", reach_chain())):
        print(f"{name} = (")
        for r in rows:
            print(f"    {r!r},")
        print(")")
        print(markdown(rows))
