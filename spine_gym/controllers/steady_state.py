"""The voltage → steady bending angle map of one heated wire (planar model), which the open-loop
step drives and the PID feedforwards of both geometries read (a spatial module's axis is the
planar pair on that axis, SPATIAL.md §7.1)."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..envs.drive import check_v_max
from ..params import ModelParams
from ..simulate import simulate
from .base import check_range

__all__ = ["SteadyStateMap", "steady_state_map"]


@dataclass(frozen=True)
class SteadyStateMap:
    """Bending angle reached by a constant voltage on one wire (the other off), from straight.

    Attributes:
        voltage: (n,) wire voltages [V], increasing from 0.
        angle_deg: (n,) angle [deg] after ``settle_time`` seconds at that voltage (monotone
            non-decreasing; the model is mirror-symmetric, so the left wire gives ``-angle_deg``).
        settle_time: simulated time per voltage [s].
    """

    voltage: np.ndarray
    angle_deg: np.ndarray
    settle_time: float

    @property
    def max_angle_deg(self) -> float:
        """Largest angle the map reaches [deg]."""
        return float(self.angle_deg[-1])

    def voltage_for(self, angle_deg: float | np.ndarray) -> np.ndarray:
        """Voltage [V] on the bending wire whose steady state is ``|angle_deg|`` (clipped to the map).

        Angles below the smallest reachable one give the lowest voltage that moves the spine at
        all (0 V for 0°); angles beyond the saturation give the voltage that first reaches it.
        """
        a = np.abs(np.asarray(angle_deg, dtype=np.float64))
        ang, volt = self.angle_deg, self.voltage
        # strictly increasing part for interpolation: first voltage reaching each new angle
        keep = np.concatenate([[True], np.diff(ang) > 1e-6])
        ang_u, volt_u = ang[keep], volt[keep]
        out = np.interp(a, ang_u, volt_u)
        return np.where(a <= 0.0, 0.0, out)


@functools.lru_cache(maxsize=16)
def _steady_state_map_cached(params: ModelParams, v_max: float, n_points: int, settle_time: float):
    volts = np.linspace(0.0, v_max, n_points)
    angles = np.zeros(n_points)
    for i, v in enumerate(volts[1:], start=1):
        res = simulate(settle_time, float(v), 0.0, dt=0.05, params=params)
        angles[i] = res.angle_deg[-1]
    angles = np.maximum.accumulate(np.maximum(angles, 0.0))  # monotone by construction (roundoff)
    volts.setflags(write=False)
    angles.setflags(write=False)
    return SteadyStateMap(voltage=volts, angle_deg=angles, settle_time=settle_time)


def steady_state_map(
    params: ModelParams | None = None,
    *,
    v_max: float = 5.0,
    n_points: int = 51,
    settle_time: float = 120.0,
) -> SteadyStateMap:
    """Simulate the voltage → steady bending angle map once and cache it (per argument set).

    Each point runs :func:`spine_gym.simulate` for ``settle_time`` seconds with a constant
    voltage on the right wire from the straight §3.10 state, without external loads (gravity of
    the spine's own masses is part of the model). ~0.5 s for the default 51 points.

    Args:
        params: model parameters (default: MODEL.md §7 baseline).
        v_max: largest voltage of the map [V], in (0, 8] (:func:`spine_gym.envs.drive.check_v_max`).
        n_points: number of voltages, in [3, 1000].
        settle_time: simulated time per voltage [s], in [1, 1000].

    Returns:
        A :class:`SteadyStateMap` (its arrays are read-only; the same object is returned for the
        same arguments).
    """
    params = params or ModelParams()
    if not isinstance(params, ModelParams):
        raise ValueError(f"params must be a ModelParams, got {type(params).__name__}")
    v_max = check_v_max(v_max)
    if not isinstance(n_points, int | np.integer) or not 3 <= n_points <= 1000:
        raise ValueError(f"n_points must be an integer in [3, 1000], got {n_points!r}")
    settle_time = check_range("settle_time", settle_time, 1.0, 1000.0)
    return _steady_state_map_cached(params, v_max, int(n_points), settle_time)
