"""Sliding-mode tracking control of the antagonistic SMA wires (planar, and per bending axis).

The law follows the adaptive nonsingular terminal sliding-mode controllers of the SMA-actuator
literature (e.g. X. Li et al., "Adaptive Nonsingular Fast Terminal Sliding Mode Control for Shape
Memory Alloy Actuated System", *Actuators* 13(9):367, 2024, doi:10.3390/act13090367): a terminal
sliding surface, a boundary layer against chattering and a switching gain adapted on line. With
the tracking error ``e = r − Θ`` [deg] (r: the target, optionally blended with the previewed one as
in :class:`.baselines.PIDController`) and, per control period ``dt``:

* **Surface** ``s = ė + λ sig(e)^γ`` [deg/s] with ``sig(e)^γ = |e|^γ sign(e)`` and γ in (0, 1]
  (γ = 1: the linear surface ``ė + λ e``; γ < 1: the terminal surface, on which the error reaches
  zero in finite time, and whose gain ``λ γ |e|^(γ−1)`` grows as the error shrinks). ``ė`` is
  ``−dΘ/dt`` from a first-order-filtered difference of the measured angle (time constant
  ``tau_d``): the derivative acts on the measurement only, so a target step gives no kick (the
  reference's own rate is left to the feedforward and the preview). The law never differentiates
  ``s``, so the ``|e|^(γ−1)`` singularity of the classical terminal surface never enters the
  voltage (the nonsingular property).
* **Voltage** ``u = ff(r) + Î + k_s s + K̂ sat(s / φ)`` [V]: the equivalent control is the
  steady-state voltage of the reference (``ff``: :func:`.baselines.steady_state_map`, signed,
  times ``feedforward``, exactly as the PID's) plus ``Î``, an on-line estimate of what the map
  misses (loads, hysteresis, a different plant), ``dÎ/dt = k_i s + k_aw (u_sat − u)`` (integrating
  the surface, with the PID's back-calculation anti-windup); the reaching law is the exponential
  one, ``k_s s`` plus the switching term, where ``sat`` (clip to [−1, 1]) replaces ``sign`` inside
  the boundary layer ``|s| ≤ φ`` (continuous in s, ±1 outside it).
* **Adaptive switching gain** ``K̂`` [V]: ``dK̂/dt = ρ |s|`` outside the layer (it grows while
  the state is away from the surface), ``dK̂/dt = −σ (K̂ − K_min)`` inside (it leaks back, so it
  does not stay high once tracking is good), always clipped to ``[K_min, K_max]``.
* **Wires**: ``u_sat = clip(u, ±(v_max − bias))``; ``right = max(u_sat, 0) + bias``,
  ``left = max(−u_sat, 0) + bias`` (the PID's split), then the controller base class's thermal
  guard and clip to [0, v_max].

:class:`SlidingModeController` drives ``SmaSpine-v0``'s pair; :class:`SpatialSlidingModeController`
applies the same law on each bending axis of each module of a spatial spine through
:class:`.spatial.SpatialController` (references, inverse kinematics, wire split and guard as for
the spatial PID). Both share one implementation of the law, :func:`sliding_mode_step`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..envs.planar import planar_obs_index
from ..params import ModelParams
from .base import check_range
from .planar import OBS_ANGLE, PlanarController, checked_preview_index
from .steady_state import SteadyStateMap, steady_state_map
from .spatial import SpatialController, SpatialSignals

__all__ = [
    "SMCGains",
    "SlidingModeController",
    "SpatialSlidingModeController",
    "sliding_surface",
    "boundary_layer",
    "adapt_gain",
    "sliding_mode_step",
]

N_MEMORY = 4  # per axis: estimate Î [V], filtered rate dΘ/dt [deg/s], previous angle [deg], gain K̂ [V]


@dataclass(frozen=True)
class SMCGains:
    """Settings of the sliding-mode law (error in deg, output in V); see the module docstring.

    Attributes:
        lam: surface slope λ [deg^(1−γ)/s].
        gamma: surface exponent γ in (0, 1] (1: linear surface).
        tau_d: filter time constant of the measured angle's rate [s] (0: raw difference).
        k_s: proportional reaching gain [V s/deg].
        k_i: gain of the equivalent-control estimate ``dÎ/dt = k_i s`` [V/deg].
        phi: boundary-layer half width φ [deg/s].
        k_min, k_max: bounds of the adaptive switching gain [V] (``k_min`` is also its start).
        rho: adaptation rate outside the layer [V/deg].
        sigma: leak rate inside the layer [1/s].
        bias: voltage added to both wires [V].
        kaw: back-calculation anti-windup gain of ``Î`` [1/s].
        feedforward: weight in [0, 1] of the steady-state feedforward voltage.
        preview: weight in [0, 1] of the previewed target in the reference.
    """

    lam: float = 6.0
    gamma: float = 0.7
    tau_d: float = 0.3
    k_s: float = 0.3
    k_i: float = 0.3
    phi: float = 2.0
    k_min: float = 0.2
    k_max: float = 2.0
    rho: float = 0.05
    sigma: float = 0.2
    bias: float = 0.3
    kaw: float = 1.0
    feedforward: float = 0.5
    preview: float = 0.3

    @classmethod
    def checked(cls, *, v_max: float, **values) -> SMCGains:
        """The settings (defaults for those not given), each checked against its range
        (ValueError naming the first one out of range, or an unknown name)."""
        names = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise ValueError(f"unknown sliding-mode setting(s) {unknown}; valid: {names}")
        g = {n: values.get(n, getattr(cls, n)) for n in names}
        out = dict(
            lam=check_range("lam", g["lam"], 0.0, 1e3),
            gamma=check_range("gamma", g["gamma"], 0.0, 1.0, lo_open=True),
            tau_d=check_range("tau_d", g["tau_d"], 0.0, 100.0),
            k_s=check_range("k_s", g["k_s"], 0.0, 1e3),
            k_i=check_range("k_i", g["k_i"], 0.0, 1e3),
            phi=check_range("phi", g["phi"], 0.0, 1e3, lo_open=True),
            k_min=check_range("k_min", g["k_min"], 0.0, v_max),
        )
        out["k_max"] = check_range("k_max", g["k_max"], out["k_min"], v_max)
        out.update(
            rho=check_range("rho", g["rho"], 0.0, 1e3),
            sigma=check_range("sigma", g["sigma"], 0.0, 1e3),
            bias=check_range("bias", g["bias"], 0.0, v_max),
            kaw=check_range("kaw", g["kaw"], 0.0, 1e3),
            feedforward=check_range("feedforward", g["feedforward"], 0.0, 1.0),
            preview=check_range("preview", g["preview"], 0.0, 1.0),
        )
        return cls(**out)


# --------------------------------------------------------------------------- the law
def sliding_surface(e: np.ndarray, e_dot: np.ndarray, lam: float, gamma: float) -> np.ndarray:
    """``s = ė + λ |e|^γ sign(e)`` [deg/s] for errors ``e`` [deg] and their rates ``ė`` [deg/s]."""
    e = np.asarray(e, dtype=np.float64)
    return np.asarray(e_dot, dtype=np.float64) + lam * np.sign(e) * np.abs(e) ** gamma


def boundary_layer(s: np.ndarray, phi: float) -> np.ndarray:
    """``sat(s / φ)``: ``s / φ`` inside the layer ``|s| ≤ φ``, ``sign(s)`` outside."""
    return np.clip(np.asarray(s, dtype=np.float64) / phi, -1.0, 1.0)


def adapt_gain(k: np.ndarray, s: np.ndarray, g: SMCGains, dt: float) -> np.ndarray:
    """One period of the switching-gain adaptation: ``+ρ |s| dt`` outside the layer, an exact
    exponential leak toward ``k_min`` at rate σ inside it, clipped to ``[k_min, k_max]``."""
    s = np.abs(np.asarray(s, dtype=np.float64))
    leak = g.k_min + (k - g.k_min) * math.exp(-g.sigma * dt)
    return np.clip(np.where(s > g.phi, k + g.rho * s * dt, leak), g.k_min, g.k_max)


def sliding_mode_step(
    g: SMCGains, e: np.ndarray, angle: np.ndarray, ff, mem: np.ndarray, dt: float, u_hi: float
) -> np.ndarray:
    """One control period of the law on ``m`` independent axes; returns ``u_sat`` (n, m) [V].

    Args:
        g: the settings.
        e: (n, m) tracking errors r − Θ [deg].
        angle: (n, m) measured angles Θ [deg].
        ff: the feedforward voltage [V] (0 or broadcastable to (n, m)), already weighted.
        mem: (n, 4 m) memory, updated in place: Î, filtered dΘ/dt, previous Θ (NaN: none yet), K̂.
        dt: control period [s].
        u_hi: largest |u| the wires can apply [V] (``v_max − bias``).
    """
    m = e.shape[1]
    est, rate_f, prev, k = (mem[:, i * m : (i + 1) * m] for i in range(N_MEMORY))
    first = np.isnan(prev)
    rate = np.where(first, 0.0, (angle - np.where(first, angle, prev)) / dt)  # [deg/s]
    alpha = 1.0 if g.tau_d <= 0.0 else 1.0 - math.exp(-dt / g.tau_d)  # exact for a held input
    rate_f = np.where(first, 0.0, rate_f + alpha * (rate - rate_f))
    s = sliding_surface(e, -rate_f, g.lam, g.gamma)
    k = np.where(first, g.k_min, k)
    u = ff + est + g.k_s * s + k * boundary_layer(s, g.phi)
    u_sat = np.clip(u, -u_hi, u_hi)
    mem[:, :m] = est + dt * (g.k_i * s + g.kaw * (u_sat - u))
    mem[:, m : 2 * m] = rate_f
    mem[:, 2 * m : 3 * m] = angle
    mem[:, 3 * m :] = adapt_gain(k, s, g, dt)
    return u_sat


def _initial_memory(n: int, m: int, k_min: float) -> np.ndarray:
    mem = np.zeros((n, N_MEMORY * m))
    mem[:, 2 * m : 3 * m] = np.nan
    mem[:, 3 * m :] = k_min
    return mem


def _checked_map(ss_map, feedforward: float, params, v_max: float) -> SteadyStateMap | None:
    if ss_map is not None and not isinstance(ss_map, SteadyStateMap):
        raise ValueError(f"ss_map must be a SteadyStateMap, got {type(ss_map).__name__}")
    if feedforward > 0.0 and ss_map is None:
        return steady_state_map(params, v_max=v_max)
    return ss_map


# --------------------------------------------------------------------------- planar
class SlidingModeController(PlanarController):
    """Adaptive terminal sliding-mode control of ``SmaSpine-v0``'s antagonistic pair (module docstring).

    Args:
        **settings: the fields of :class:`SMCGains` (defaults for those not given).
        preview_index: observation entry of the look-ahead target (used if ``preview`` > 0), >= 4.
        ss_map: steady-state map for the feedforward (default: :func:`.baselines.steady_state_map`).
        params: model parameters of the default map.
        v_max, dt, temperature_limit: as :class:`.base.BaseController` (the same guard).
    """

    name = "smc"
    state_size = N_MEMORY

    def __init__(
        self,
        *,
        preview_index: int = planar_obs_index("target_preview"),
        ss_map: SteadyStateMap | None = None,
        params: ModelParams | None = None,
        v_max: float = 5.0,
        dt: float = 0.1,
        temperature_limit: float | None = None,
        **settings,
    ):
        super().__init__(v_max=v_max, dt=dt, temperature_limit=temperature_limit)
        self.gains = SMCGains.checked(v_max=self.v_max, **settings)
        self.preview_index = checked_preview_index(preview_index)
        self.ss_map = _checked_map(ss_map, self.gains.feedforward, params, self.v_max)

    def _initial_state(self, n):
        return _initial_memory(n, 1, self.gains.k_min)

    def _volts(self, obs, mem):
        g = self.gains
        ref = self._previewed_target(obs, self.gains.preview)[:, None]
        angle = obs[:, OBS_ANGLE][:, None]
        ff = g.feedforward * np.sign(ref) * self.ss_map.voltage_for(ref) if g.feedforward > 0.0 else 0.0
        u = sliding_mode_step(g, ref - angle, angle, ff, mem, self.dt, self.v_max - g.bias)[:, 0]
        return np.stack([np.maximum(u, 0.0), np.maximum(-u, 0.0)], axis=1) + g.bias

    def config(self) -> dict:
        return {**dataclasses.asdict(self.gains), "preview_index": self.preview_index, **super().config()}


# --------------------------------------------------------------------------- spatial
class SpatialSlidingModeController(SpatialController):
    """The sliding-mode law per module and bending axis, split over that axis' antagonistic wires.

    References (the target, or the inverse kinematics of a tip-position target), the previewed
    reference, the wire split, the per-wire voltage scale and the guard are those of
    :class:`.spatial.SpatialController` (as for the spatial PID, whose ``tip_ki`` offset this law
    does not use: its equivalent-control estimate ``Î`` integrates each module's own surface).
    The feedforward is the planar steady-state voltage of each axis' reference component, the
    module's bend stretched to the seed's length (as the spatial PID's).

    Args:
        signals: see :class:`.spatial.SpatialSignals`.
        **settings: the fields of :class:`SMCGains`.
        ss_map: planar steady-state map for the feedforward.
        dt, temperature_limit: control period [s] and guard [K].
    """

    name = "smc"

    def __init__(
        self,
        signals: SpatialSignals,
        *,
        ss_map: SteadyStateMap | None = None,
        dt: float = 0.1,
        temperature_limit: float | None = None,
        **settings,
    ):
        super().__init__(signals, dt=dt, temperature_limit=temperature_limit)
        self.gains = SMCGains.checked(v_max=self.v_max, **settings)
        if self.gains.preview > 0.0 and signals.preview is None:
            raise ValueError("preview > 0 needs a target preview in the observation (signals.preview)")
        self.ss_map = _checked_map(ss_map, self.gains.feedforward, signals.layout.params, self.v_max)
        self._stretch = (self._seed_length() / signals.module_lengths)[None, :, None]
        self._na = 2 * signals.n_modules  # axes
        self.state_size = N_MEMORY * self._na

    def _initial_state(self, n):
        return _initial_memory(n, self._na, self.gains.k_min)

    def _volts(self, obs, mem):
        g, n, sig = self.gains, obs.shape[0], self.signals
        ref = self._reference(obs, sig.target)
        if g.preview > 0.0:
            ref = (1.0 - g.preview) * ref + g.preview * self._reference(obs, sig.preview)
        ff = 0.0
        if g.feedforward > 0.0:
            seed_ref = (ref * self._stretch).reshape(n, self._na)
            ff = g.feedforward * np.sign(seed_ref) * self.ss_map.voltage_for(seed_ref)
        ref, meas = ref.reshape(n, self._na), self._bending(obs).reshape(n, self._na)
        u = sliding_mode_step(g, ref - meas, meas, ff, mem, self.dt, self.v_max - g.bias)
        return self._split(u.reshape(n, -1, 2)) + g.bias

    def config(self) -> dict:
        return {**dataclasses.asdict(self.gains), **super().config()}
