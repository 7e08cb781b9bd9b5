"""Classical controllers for ``SmaSpine-v0``: step voltage, bang-bang and PID (no torch needed).

Three ways of driving the two antagonistic SMA wires that the learned policies of ``spine_gym/agents/`` are
compared against:

* :class:`StepVoltageController` — the paper's open-loop drive (MODEL.md §9): a constant voltage
  on the wire that bends toward the target. The voltage for a target angle is read from the
  model's steady-state map (:func:`steady_state_map`, simulated once and cached), so it would be
  exact on the nominal model without loads or hysteresis; it never looks at the measured angle.
* :class:`BangBangController` — a three-level relay with a hysteresis band on the tracking error
  (heat the right wire, heat none, heat the left wire).
* :class:`PIDController` — PID on the angle error with derivative on the measurement, a
  first-order derivative filter, back-calculation anti-windup and an optional steady-state
  feedforward; its signed output ``u`` [V] is split between the wires as
  ``right = max(u, 0) + bias``, ``left = max(-u, 0) + bias``.

All three expose Stable-Baselines3's ``predict(observation, state, episode_start,
deterministic) -> (action, state)`` (``PolicyPredictor``), so one evaluation path serves baselines
and trained models. They read only the fixed observation entries of the env contract
(0 angle [deg], 1 target [deg], 2/3 right/left wire temperature [K]) and return actions in the
env's ``Box(-1, 1, (2,))`` convention: ``volts = (a + 1) / 2 * v_max`` with index 0 = right wire.

Controller memory (relay mode, PID integrator, filtered derivative…) follows SB3's recurrent
convention: ``predict`` returns it as ``state`` (an ``(n_envs, k)`` array) and takes it back on the
next call; rows whose ``episode_start`` is True are reset. If ``state`` is ``None`` the controller
keeps the memory itself (so ``ctrl.predict(obs)`` in a loop works); call :meth:`reset` between
episodes in that case, or pass ``episode_start``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np

from ..envs.planar import planar_obs_index
from ..params import ModelParams
from ..simulate import simulate

__all__ = [
    "SteadyStateMap",
    "steady_state_map",
    "BaseController",
    "StepVoltageController",
    "BangBangController",
    "PIDController",
    "volts_to_action",
    "action_to_volts",
]

# SmaSpine-v0's observation indices, from its table (the first four entries are the env contract)
OBS_ANGLE = planar_obs_index("angle_deg")
OBS_TARGET = planar_obs_index("target_deg")
OBS_TEMP_R = planar_obs_index("temperature")
OBS_TEMP_L = OBS_TEMP_R + 1
N_FIXED_OBS = 1 + max(OBS_ANGLE, OBS_TARGET, OBS_TEMP_L)


def check_range(name: str, value, lo: float, hi: float, *, lo_open: bool = False) -> float:
    """Return ``float(value)`` or raise ValueError naming ``name``, the allowed range and the value."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    bad = not math.isfinite(v) or (v <= lo if lo_open else v < lo) or v > hi
    if bad:
        raise ValueError(f"{name} must be in {'(' if lo_open else '['}{lo:g}, {hi:g}], got {value!r}")
    return v


def observation_batch(observation, need: int, layout: str = "") -> tuple[np.ndarray, bool]:
    """``observation`` as a float (n_envs, d) array and whether it was a single (d,) one.

    Raises ValueError unless it is numeric of shape (d,) or (n_envs, d) with d >= ``need``; ``layout``
    (e.g. " (angle, target, ... first)") is added to the shape message.
    """
    try:
        obs = np.asarray(observation, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f"observation must be a numeric array of shape (d,) or (n_envs, d) with d >= {need}, "
            f"got {type(observation).__name__}"
        ) from None
    single = obs.ndim == 1
    if single:
        obs = obs[None, :]
    if obs.ndim != 2 or obs.shape[1] < need or obs.shape[0] < 1:
        raise ValueError(
            f"observation must have shape (d,) or (n_envs, d) with d >= {need}{layout}, "
            f"got {np.shape(observation)}"
        )
    return obs, single


def volts_to_action(volts: np.ndarray, v_max: float) -> np.ndarray:
    """Map wire voltages [V] in [0, v_max] to env actions in [-1, 1] (``a = 2 V / v_max - 1``)."""
    return np.clip(2.0 * np.asarray(volts, dtype=np.float64) / v_max - 1.0, -1.0, 1.0).astype(np.float32)


def action_to_volts(action: np.ndarray, v_max: float) -> np.ndarray:
    """Inverse of :func:`volts_to_action`: ``V = (clip(a, -1, 1) + 1) / 2 * v_max`` [V]."""
    return (np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0) + 1.0) * 0.5 * v_max


# --------------------------------------------------------------------------- steady-state map
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
        v_max: largest voltage of the map [V], in (0, 100].
        n_points: number of voltages, in [3, 1000].
        settle_time: simulated time per voltage [s], in [1, 1000].

    Returns:
        A :class:`SteadyStateMap` (its arrays are read-only; the same object is returned for the
        same arguments).
    """
    params = params or ModelParams()
    if not isinstance(params, ModelParams):
        raise ValueError(f"params must be a ModelParams, got {type(params).__name__}")
    v_max = check_range("v_max", v_max, 0.0, 100.0, lo_open=True)
    if not isinstance(n_points, int | np.integer) or not 3 <= n_points <= 1000:
        raise ValueError(f"n_points must be an integer in [3, 1000], got {n_points!r}")
    settle_time = check_range("settle_time", settle_time, 1.0, 1000.0)
    return _steady_state_map_cached(params, v_max, int(n_points), settle_time)


# --------------------------------------------------------------------------- base class
class BaseController:
    """Common input checks, action conversion and SB3-style memory handling.

    Subclasses set ``state_size`` and implement ``_initial_state(n)`` and
    ``_volts(obs (n, d) float64, mem (n, k) float64) -> volts (n, 2)`` (which updates ``mem`` in
    place).

    Args:
        v_max: the env's full-scale wire voltage [V] (action +1), in (0, 100].
        dt: control period [s] (time between two ``predict`` calls), in (0, 10].
        temperature_limit: optional wire-temperature guard [K]: a wire whose observed temperature
            is at or above it gets 0 V for that step. ``None`` disables the guard.
    """

    state_size = 0
    name = "controller"

    def __init__(self, *, v_max: float = 5.0, dt: float = 0.1, temperature_limit: float | None = None):
        self.v_max = check_range("v_max", v_max, 0.0, 100.0, lo_open=True)
        self.dt = check_range("dt", dt, 0.0, 10.0, lo_open=True)
        self.temperature_limit = (
            None
            if temperature_limit is None
            else check_range("temperature_limit", temperature_limit, 200.0, 2000.0)
        )
        self._memory: np.ndarray | None = None

    # ---- SB3 PolicyPredictor interface
    def predict(
        self,
        observation: np.ndarray,
        state: np.ndarray | tuple | None = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Actions for one observation ``(d,)`` or a batch ``(n_envs, d)``.

        Args:
            observation: env observation(s); entries 0..3 are angle [deg], target [deg], right and
                left wire temperature [K]. Must be finite.
            state: controller memory returned by the previous call, ``(n_envs, state_size)``, or
                ``None`` to let the controller keep it internally.
            episode_start: ``(n_envs,)`` booleans; rows that are True start from fresh memory.
            deterministic: accepted for SB3 compatibility; these controllers are deterministic.

        Returns:
            ``(action, state)``: actions in [-1, 1], float32, shape ``(2,)`` or ``(n_envs, 2)``
            (index 0 = right wire), and the updated memory.

        Raises:
            ValueError: non-numeric, non-finite or wrongly shaped observation, state or
                episode_start.
        """
        obs, single = self._check_obs(observation)
        n = obs.shape[0]
        internal = state is None
        if internal:
            mem = self._memory
            if mem is None or mem.shape[0] != n:
                mem = self._initial_state(n)
        else:
            if isinstance(state, tuple) and len(state) == 1:
                state = state[0]
            try:
                mem = np.array(state, dtype=np.float64)
            except (TypeError, ValueError):
                raise ValueError(f"state must be a numeric array of shape ({n}, {self.state_size})") from None
            if mem.shape != (n, self.state_size):
                raise ValueError(f"state must have shape ({n}, {self.state_size}), got {mem.shape}")
        if episode_start is not None:
            es = np.asarray(episode_start)
            if es.ndim == 0:
                es = es.reshape(1)
            if es.shape != (n,):
                raise ValueError(f"episode_start must have shape ({n},), got {es.shape}")
            es = es.astype(bool)
            if es.any():
                mem[es] = self._initial_state(int(es.sum()))
        action = self._action(obs, self._volts(obs, mem))
        if internal:
            self._memory = mem
        return (action[0] if single else action), mem

    def reset(self) -> None:
        """Forget the internal memory (start of a new episode when ``state`` is not passed)."""
        self._memory = None

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        """Shortcut for ``predict(observation)[0]`` with internal memory."""
        return self.predict(observation)[0]

    # ---- helpers
    def _temperatures(self, obs: np.ndarray) -> np.ndarray:
        """(n, n_wires) observed wire temperatures [K] (the guard's input)."""
        return obs[:, [OBS_TEMP_R, OBS_TEMP_L]]

    def _action(self, obs: np.ndarray, volts: np.ndarray) -> np.ndarray:
        """Temperature guard, clip to [0, v_max] and map to actions in [-1, 1]."""
        if self.temperature_limit is not None:
            volts = np.where(self._temperatures(obs) >= self.temperature_limit, 0.0, volts)
        volts = np.clip(volts, 0.0, self.v_max)
        return volts_to_action(volts, self.v_max)

    def _check_obs(self, observation) -> tuple[np.ndarray, bool]:
        obs, single = observation_batch(observation, N_FIXED_OBS, " (angle, target, T_right, T_left first)")
        if not np.all(np.isfinite(obs[:, :N_FIXED_OBS])):
            raise ValueError("observation must be finite, got NaN or inf in entries 0..3")
        return obs, single

    def _initial_state(self, n: int) -> np.ndarray:
        return np.zeros((n, self.state_size))

    def _volts(self, obs: np.ndarray, mem: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def config(self) -> dict:
        """Constructor arguments (for logging and the evaluation CSV)."""
        return {"v_max": self.v_max, "dt": self.dt, "temperature_limit": self.temperature_limit}

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.config().items())
        return f"{type(self).__name__}({args})"


# --------------------------------------------------------------------------- step voltage
class StepVoltageController(BaseController):
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


# --------------------------------------------------------------------------- bang-bang
def checked_relay(v_on, band, release, v_hold, v_max: float) -> tuple[float, float, float, float]:
    """The settings of a three-level relay (both bang-bang controllers), each checked against its
    range: (v_on, band, release, v_hold)."""
    v_on = check_range("v_on", v_on, 0.0, v_max, lo_open=True)
    band = check_range("band", band, 0.0, 90.0)
    release = check_range("release", release, -band, 90.0)
    return v_on, band, release, check_range("v_hold", v_hold, 0.0, v_max)


def relay_config(controller) -> dict:
    """The relay settings of a bang-bang controller, for its :meth:`~BaseController.config`."""
    return {
        "v_on": controller.v_on,
        "band": controller.band,
        "release": controller.release,
        "v_hold": controller.v_hold,
    }


class BangBangController(BaseController):
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
@dataclass(frozen=True)
class PIDGains:
    """Gains of :class:`PIDController` (error in deg, output in V).

    Attributes:
        kp: proportional gain [V/deg].
        ki: integral gain [V/(deg s)].
        kd: derivative gain [V s/deg] (on the measured angle, filtered).
        tau_d: derivative filter time constant [s].
        bias: voltage added to both wires [V] (keeps them warm, softens the dead zone).
        kaw: back-calculation anti-windup gain [1/s].
        feedforward: weight in [0, 1] of the steady-state feedforward voltage (0: pure PID).
        preview: weight in [0, 1] of the previewed target in the reference (0: current target only).
    """

    kp: float = 0.4
    ki: float = 0.05
    kd: float = 0.0
    tau_d: float = 0.3
    bias: float = 0.0
    kaw: float = 1.0
    feedforward: float = 0.0
    preview: float = 0.0

    @classmethod
    def checked(cls, kp, ki, kd, tau_d, bias, kaw, feedforward, preview, *, v_max: float) -> PIDGains:
        """The gains, each checked against its range (ValueError naming the first one out of range)."""
        return cls(
            kp=check_range("kp", kp, 0.0, 1e3),
            ki=check_range("ki", ki, 0.0, 1e3),
            kd=check_range("kd", kd, 0.0, 1e3),
            tau_d=check_range("tau_d", tau_d, 0.0, 100.0),
            bias=check_range("bias", bias, 0.0, v_max),
            kaw=check_range("kaw", kaw, 0.0, 1e3),
            feedforward=check_range("feedforward", feedforward, 0.0, 1.0),
            preview=check_range("preview", preview, 0.0, 1.0),
        )


class PIDController(BaseController):
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
        if (
            isinstance(preview_index, bool)
            or not isinstance(preview_index, int | np.integer)
            or preview_index < N_FIXED_OBS
        ):
            raise ValueError(f"preview_index must be an integer >= {N_FIXED_OBS}, got {preview_index!r}")
        self.preview_index = int(preview_index)
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
        angle, target = obs[:, OBS_ANGLE], obs[:, OBS_TARGET]
        if g.preview > 0.0:
            if obs.shape[1] <= self.preview_index:
                raise ValueError(
                    f"preview > 0 needs observation entry {self.preview_index} (target preview), "
                    f"got observations of size {obs.shape[1]}"
                )
            ahead = obs[:, self.preview_index]
            if not np.all(np.isfinite(ahead)):
                raise ValueError(f"observation must be finite, got NaN or inf in entry {self.preview_index}")
            target = (1.0 - g.preview) * target + g.preview * ahead
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
