"""Classical controllers for ``SmaSpine-v0``: step voltage, bang-bang and PID (no torch needed).

Three ways of driving the two antagonistic SMA wires that the learned policies of ``spine_gym/agents/`` are
compared against:

* :class:`StepVoltageController` — the paper's open-loop drive (MODEL.md §9): a constant voltage
  on the wire that bends toward the target. The voltage for a target angle is read from the
  model's steady-state map (:func:`~.steady_state.steady_state_map`, simulated once and cached),
  so it would be exact on the nominal model without loads or hysteresis; it never looks at the
  measured angle.
* :class:`BangBangController` — a three-level relay with a hysteresis band on the tracking error
  (heat the right wire, heat none, heat the left wire).
* :class:`PIDController` — PID on the angle error with derivative on the measurement, a
  first-order derivative filter, back-calculation anti-windup and an optional steady-state
  feedforward; its signed output ``u`` [V] is split between the wires as
  ``right = max(u, 0) + bias``, ``left = max(-u, 0) + bias``.

All three are :class:`PlanarController` s: Stable-Baselines3's ``predict`` of
:class:`~.base.BaseController` over the fixed observation entries of ``SmaSpine-v0``'s contract,
read from its table (:func:`spine_gym.envs.planar.planar_obs_index`: 0 angle [deg], 1 target
[deg], 2/3 right/left wire temperature [K]); they return actions in the env's
``Box(-1, 1, (2,))`` convention: ``volts = (a + 1) / 2 * v_max`` with index 0 = right wire. The
spatial envs' controllers are in :mod:`.spatial`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..envs.planar import planar_obs_index
from ..params import ModelParams
from .base import BaseController, PIDGains, checked_relay, observation_batch, relay_config
from .steady_state import SteadyStateMap, steady_state_map

__all__ = [
    "PlanarController",
    "StepVoltageController",
    "BangBangController",
    "PIDController",
]

# SmaSpine-v0's observation indices, from its table (the first four entries are the env contract)
OBS_ANGLE = planar_obs_index("angle_deg")
OBS_TARGET = planar_obs_index("target_deg")
OBS_TEMP_R = planar_obs_index("temperature")
OBS_TEMP_L = OBS_TEMP_R + 1
N_FIXED_OBS = 1 + max(OBS_ANGLE, OBS_TARGET, OBS_TEMP_L)


def checked_preview_index(preview_index) -> int:
    """``preview_index`` (the observation entry of the target preview) as an int, or ValueError: an
    integer past the fixed entries (angle, target, temperatures)."""
    if (
        isinstance(preview_index, bool)
        or not isinstance(preview_index, int | np.integer)
        or preview_index < N_FIXED_OBS
    ):
        raise ValueError(f"preview_index must be an integer >= {N_FIXED_OBS}, got {preview_index!r}")
    return int(preview_index)


class PlanarController(BaseController):
    """A controller of the planar pair: reads ``SmaSpine-v0``'s contract entries (angle, target,
    right and left wire temperature; indices from the env's table) and drives two wires."""

    def _check_obs(self, observation) -> tuple[np.ndarray, bool]:
        obs, single = observation_batch(observation, N_FIXED_OBS, " (angle, target, T_right, T_left first)")
        if not np.all(np.isfinite(obs[:, :N_FIXED_OBS])):
            raise ValueError("observation must be finite, got NaN or inf in entries 0..3")
        return obs, single

    def _temperatures(self, obs: np.ndarray) -> np.ndarray:
        """(n, 2) observed wire temperatures [K] (the guard's input)."""
        return obs[:, [OBS_TEMP_R, OBS_TEMP_L]]

    def _previewed_target(self, obs: np.ndarray, preview: float) -> np.ndarray:
        """(n,) the target blended with its preview, ``(1 - preview)·target + preview·ahead``
        (``ahead``: observation entry ``self.preview_index``; the target alone if ``preview`` is 0)."""
        target = obs[:, OBS_TARGET]
        if preview <= 0.0:
            return target
        if obs.shape[1] <= self.preview_index:
            raise ValueError(
                f"preview > 0 needs observation entry {self.preview_index} (target preview), "
                f"got observations of size {obs.shape[1]}"
            )
        ahead = obs[:, self.preview_index]
        if not np.all(np.isfinite(ahead)):
            raise ValueError(f"observation must be finite, got NaN or inf in entry {self.preview_index}")
        return (1.0 - preview) * target + preview * ahead


# --------------------------------------------------------------------------- step voltage
class StepVoltageController(PlanarController):
    """Open-loop step voltage (the paper's drive): the steady-state voltage for the target.

    For a target Θ* the wire on the side of Θ* (right for Θ* > 0) gets
    ``steady_state_map().voltage_for(|Θ*|)`` and the other wire 0 V. The measured angle is never
    used; a time-varying target (ramp, sine) is followed quasi-statically through the same map.

    Args:
        ss_map: steady-state map; default :func:`steady_state_map` of ``params`` up to ``v_max``.
        params: model parameters for the default map (default: baseline).
        **kwargs: ``v_max``, ``dt``, ``temperature_limit`` of :class:`BaseController`.
    """

    name = "step"

    def __init__(self, ss_map: SteadyStateMap | None = None, *, params: ModelParams | None = None, **kwargs):
        super().__init__(**kwargs)
        if ss_map is not None and not isinstance(ss_map, SteadyStateMap):
            raise ValueError(f"ss_map must be a SteadyStateMap, got {type(ss_map).__name__}")
        self.ss_map = ss_map or steady_state_map(params, v_max=self.v_max)

    def _volts(self, obs, mem):
        target = obs[:, OBS_TARGET]
        v = self.ss_map.voltage_for(target)
        return np.stack([np.where(target > 0, v, 0.0), np.where(target < 0, v, 0.0)], axis=1)


class BangBangController(PlanarController):
    """Three-level relay with a hysteresis band on the tracking error e = target − angle [deg].

    Modes: +1 heat the right wire at ``v_on``, −1 heat the left wire, 0 both at ``v_hold``.
    The relay switches to +1 when e > ``band``, to −1 when e < −``band``, and back to 0 once the
    error has crossed to ``-release`` on the other side (``release`` < 0 keeps heating until the
    error has shrunk to ``|release|``; this is the hysteresis that stops chattering).

    Args:
        v_on: voltage on the active wire [V], in (0, v_max].
        band: error that switches a wire on [deg], in [0, 90].
        release: error beyond zero at which an active wire switches off [deg], in [-band, 90].
        v_hold: voltage on both wires in mode 0 [V], in [0, v_max] (0: both off).
        **kwargs: ``v_max``, ``dt``, ``temperature_limit`` of :class:`BaseController`.
    """

    name = "bang_bang"
    state_size = 1  # relay mode

    def __init__(
        self, v_on: float = 3.5, band: float = 1.0, release: float = 0.0, v_hold: float = 0.0, **kwargs
    ):
        super().__init__(**kwargs)
        relay = checked_relay(v_on, band, release, v_hold, self.v_max)
        self.v_on, self.band, self.release, self.v_hold = relay

    def _volts(self, obs, mem):
        e = obs[:, OBS_TARGET] - obs[:, OBS_ANGLE]
        mode = mem[:, 0]
        mode = np.where(e > self.band, 1.0, np.where(e < -self.band, -1.0, mode))
        # release: the active wire switches off once the error has gone past -release / +release
        mode = np.where((mode > 0) & (e < -self.release), 0.0, mode)
        mode = np.where((mode < 0) & (e > self.release), 0.0, mode)
        mem[:, 0] = mode
        vr = np.where(mode > 0, self.v_on, self.v_hold * (mode == 0))
        vl = np.where(mode < 0, self.v_on, self.v_hold * (mode == 0))
        return np.stack([vr, vl], axis=1)

    def config(self) -> dict:
        return {**relay_config(self), **super().config()}


# --------------------------------------------------------------------------- PID
class PIDController(PlanarController):
    """PID on the angle error, signed output split between the antagonistic wires.

    ``u = ff(r) + kp e + I + D`` [V] with ``e = r − Θ`` [deg], ``D`` the filtered derivative of
    −Θ (no derivative kick on target steps) and ``ff`` the steady-state voltage of the reference
    (signed by side) times ``feedforward``. The reference is the current target Θ* blended with
    the env's look-ahead target (observation ``preview_index``, ``SmaSpine-v0``'s entry 5 =
    Θ*(t + 1 s)): ``r = (1 − preview) Θ* + preview Θ*_preview`` (classical preview feedforward,
    which the learned policies get too). The wires get ``right = max(u, 0) + bias`` and
    ``left = max(−u, 0) + bias``, clipped to [0, v_max]. Anti-windup by back-calculation:
    ``dI/dt = ki e + kaw (u_sat − u)`` where ``u_sat`` is the part of ``u`` the wires can apply.

    Args:
        kp, ki, kd, tau_d, bias, kaw, feedforward, preview: see :class:`PIDGains`; ``kp, ki, kd,
            kaw`` ≥ 0, ``tau_d`` in [0, 100] s, ``bias`` in [0, v_max] V, ``feedforward`` and
            ``preview`` in [0, 1].
        preview_index: observation entry of the look-ahead target (used if ``preview`` > 0), >= 4.
        ss_map: steady-state map for the feedforward (default: :func:`steady_state_map`).
        **kwargs: ``v_max``, ``dt``, ``temperature_limit`` of :class:`BaseController`.
    """

    name = "pid"
    state_size = 3  # integrator [V], filtered derivative [V], previous angle [deg] (NaN: none yet)

    def __init__(
        self,
        kp: float = PIDGains.kp,
        ki: float = PIDGains.ki,
        kd: float = PIDGains.kd,
        tau_d: float = PIDGains.tau_d,
        bias: float = PIDGains.bias,
        kaw: float = PIDGains.kaw,
        feedforward: float = PIDGains.feedforward,
        preview: float = PIDGains.preview,
        *,
        preview_index: int = planar_obs_index("target_preview"),
        ss_map: SteadyStateMap | None = None,
        params: ModelParams | None = None,
        **kwargs,
    ):
        super().__init__(**kwargs)
        self.gains = PIDGains.checked(kp, ki, kd, tau_d, bias, kaw, feedforward, preview, v_max=self.v_max)
        self.preview_index = checked_preview_index(preview_index)
        if ss_map is not None and not isinstance(ss_map, SteadyStateMap):
            raise ValueError(f"ss_map must be a SteadyStateMap, got {type(ss_map).__name__}")
        self.ss_map = ss_map
        if self.gains.feedforward > 0.0 and self.ss_map is None:
            self.ss_map = steady_state_map(params, v_max=self.v_max)

    @classmethod
    def from_gains(cls, gains: PIDGains | dict, **kwargs) -> PIDController:
        """Build from a :class:`PIDGains` or a dict of its fields (e.g. a tuned YAML entry)."""
        g = dataclasses.asdict(gains) if isinstance(gains, PIDGains) else dict(gains)
        unknown = set(g) - {f.name for f in dataclasses.fields(PIDGains)}
        if unknown:
            valid = [f.name for f in dataclasses.fields(PIDGains)]
            raise ValueError(f"unknown PID gain(s) {sorted(unknown)}; valid: {valid}")
        return cls(**g, **kwargs)

    def _initial_state(self, n):
        mem = np.zeros((n, self.state_size))
        mem[:, 2] = np.nan
        return mem

    def _volts(self, obs, mem):
        g = self.gains
        angle, target = obs[:, OBS_ANGLE], self._previewed_target(obs, g.preview)
        e = target - angle
        prev = mem[:, 2]
        first = np.isnan(prev)
        rate = np.where(first, 0.0, (angle - np.where(first, angle, prev)) / self.dt)  # [deg/s]
        # first-order filter on -kd * dΘ/dt, discretised exactly for a held input
        alpha = 1.0 if g.tau_d <= 0.0 else 1.0 - math.exp(-self.dt / g.tau_d)
        d = mem[:, 1] + alpha * (-g.kd * rate - mem[:, 1])
        d = np.where(first, 0.0, d)
        ff = 0.0
        if g.feedforward > 0.0:
            ff = g.feedforward * np.sign(target) * self.ss_map.voltage_for(target)
        u = ff + g.kp * e + mem[:, 0] + d
        u_hi = self.v_max - g.bias
        u_sat = np.clip(u, -u_hi, u_hi)
        mem[:, 0] += self.dt * (g.ki * e + g.kaw * (u_sat - u))
        mem[:, 1] = d
        mem[:, 2] = angle
        vr = np.maximum(u_sat, 0.0) + g.bias
        vl = np.maximum(-u_sat, 0.0) + g.bias
        return np.stack([vr, vl], axis=1)

    def config(self) -> dict:
        return {**dataclasses.asdict(self.gains), "preview_index": self.preview_index, **super().config()}
