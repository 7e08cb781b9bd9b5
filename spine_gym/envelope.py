"""The actuator envelope from the physics: what a wire voltage does to one wire of the model.

Per drive voltage (one wire of the planar pair held at it from cold, its antagonist at 0 V — the
seed's step drive, MODEL.md §10.2):

* :func:`electrics` — the wire's current, Joule power and adiabatic heating rate in martensite and
  austenite (R = λ L₀ / A_w, MODEL.md §3.7, §8), the thermal time constant ρ c / (α S_V) and the
  steady temperature of either phase without latent heat;
* :func:`step_drive` — the model's wire temperature and austenite fraction (:func:`spine_gym.simulate`):
  its steady temperature, the time to 50 % austenite (the transformation) and to a cut-off;
* :func:`cutoff_drive` — the same drive on the env's plant with the wire driver's thermal cut-off
  (``thermal_cutoff``, the ``-v2`` ids): the temperature at each control period and the largest
  overshoot above the cut-off, which the cut-off, acting once per control period, cannot prevent.

``scripts/envelope_numbers.py`` prints these for 3.2/4/5/6/8 V and plots the temperatures;
``docs/envelope.md`` draws the decision from them.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

from .params import ModelParams
from .simulate import simulate

__all__ = ["Electrics", "StepDrive", "electrics", "step_drive", "cutoff_drive", "first_time_at"]


@dataclass(frozen=True)
class Electrics:
    """One wire at ``volts`` [V]: resistance [Ohm], current [A], Joule power [W] and adiabatic
    heating rate [K/s] in martensite (``_m``) and austenite (``_a``); thermal time constant [s]; steady
    temperature without latent heat [K] in either phase."""

    volts: float
    r_m: float
    r_a: float
    i_m: float
    i_a: float
    p_m: float
    p_a: float
    heating_m: float
    heating_a: float
    tau_th: float
    t_steady_m: float
    t_steady_a: float


def electrics(volts: float, params: ModelParams | None = None) -> Electrics:
    """:class:`Electrics` of one wire of ``params`` (default: MODEL.md §7) at ``volts``."""
    p = params or ModelParams()
    r_m, r_a = p.lam_M * p.L0 / p.wire_area, p.lam_A * p.L0 / p.wire_area
    heat_capacity = p.rho * p.c * p.wire_volume  # [J/K]
    conductance = p.alpha * (4.0 / p.d) * p.wire_volume  # α S_V V_w [W/K]
    p_m, p_a = volts**2 / r_m, volts**2 / r_a
    return Electrics(
        volts=float(volts),
        r_m=r_m,
        r_a=r_a,
        i_m=volts / r_m,
        i_a=volts / r_a,
        p_m=p_m,
        p_a=p_a,
        heating_m=p_m / heat_capacity,
        heating_a=p_a / heat_capacity,
        tau_th=heat_capacity / conductance,
        t_steady_m=p.T_E + p_m / conductance,
        t_steady_a=p.T_E + p_a / conductance,
    )


def first_time_at(time: np.ndarray, values: np.ndarray, level: float) -> float:
    """The first time [s] at which ``values`` reach ``level`` (linear between samples); NaN if never."""
    above = np.flatnonzero(values >= level)
    if above.size == 0:
        return float("nan")
    k = int(above[0])
    if k == 0:
        return float(time[0])
    t0, t1, v0, v1 = time[k - 1], time[k], values[k - 1], values[k]
    return float(t0 + (level - v0) / (v1 - v0) * (t1 - t0))


@dataclass(frozen=True)
class StepDrive:
    """The model's driven wire at ``volts`` from cold, no cut-off: time [s], temperature [K] and
    austenite fraction [-] every ``dt``; the steady temperature (the last sample) [K]."""

    volts: float
    time: np.ndarray
    temperature: np.ndarray
    austenite: np.ndarray

    @property
    def t_steady(self) -> float:
        return float(self.temperature[-1])

    def time_to_transformation(self) -> float:
        """Time [s] to 50 % austenite."""
        return first_time_at(self.time, self.austenite, 0.5)

    def time_to(self, temperature: float) -> float:
        """Time [s] to ``temperature`` [K]."""
        return first_time_at(self.time, self.temperature, temperature)


def step_drive(volts: float, duration: float = 180.0, dt: float = 0.01) -> StepDrive:
    """The right wire of the planar model at ``volts`` for ``duration`` [s], the left at 0 V
    (:func:`spine_gym.simulate`, MODEL.md §7 parameters, no load)."""
    r = simulate(duration, volts, 0.0, dt=dt)
    return StepDrive(float(volts), r.time, r.temperature_right, r.x_austenite_right)


def cutoff_drive(volts: float, cutoff: float | None, duration: float = 60.0) -> tuple[np.ndarray, np.ndarray]:
    """(time [s], temperature [K] of the driven wire at the end of each control period) of
    ``SmaSpineEasy-v2`` at ``v_max`` = ``volts`` with ``thermal_cutoff`` = ``cutoff`` (``None``: the
    same plant without it): action +1 on the right wire, −1 on the left, target held at 0°."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.make(
            "SmaSpineEasy-v2", v_max=volts, thermal_cutoff=cutoff, episode_duration=duration
        ).unwrapped
    _, info = env.reset(seed=0, options={"target": 0.0})
    times, temps = [0.0], [float(info["temperature"][0])]
    action = np.array([1.0, -1.0], dtype=np.float32)
    for _ in range(round(duration / env.config.control_period)):
        _, _, terminated, _, info = env.step(action)
        if terminated:
            raise RuntimeError(f"the plant failed at {volts} V: {info.get('status_text')}")
        times.append(float(info["time"]))
        temps.append(float(info["temperature"][0]))
    env.close()
    return np.array(times), np.array(temps)
