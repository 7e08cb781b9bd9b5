"""What every controller shares, whatever the geometry: input checks, SB3's ``predict`` and memory.

* :class:`BaseController` — Stable-Baselines3's ``predict(observation, state, episode_start,
  deterministic) -> (action, state)`` (``PolicyPredictor``), so one evaluation path serves
  controllers and trained models; the temperature guard; actions from volts
  (:func:`spine_gym.envs.drive.volts_to_action`, the env's own map). It reads no observation
  entry itself: the planar controllers (:mod:`.planar`) and the spatial ones (:mod:`.spatial`)
  say where their readings are.
* :class:`PIDGains` and the relay settings (:func:`checked_relay`) both geometries' PID and
  bang-bang controllers take; :func:`check_range`, :func:`observation_batch`.
* :func:`action_to_volts` / :func:`volts_to_action` — the env's map with a ceiling ``v_max``.

Controller memory (relay mode, PID integrator, filtered derivative…) follows SB3's recurrent
convention: ``predict`` returns it as ``state`` (an ``(n_envs, k)`` array) and takes it back on the
next call; rows whose ``episode_start`` is True are reset. If ``state`` is ``None`` the controller
keeps the memory itself (so ``ctrl.predict(obs)`` in a loop works); call :meth:`~BaseController.reset`
between episodes in that case, or pass ``episode_start``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..envs import drive
from ..envs.drive import check_v_max, volts_to_action

__all__ = [
    "BaseController",
    "PIDGains",
    "check_range",
    "checked_relay",
    "relay_config",
    "observation_batch",
    "volts_to_action",
    "action_to_volts",
]


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


def action_to_volts(action: np.ndarray, v_max: float) -> np.ndarray:
    """Inverse of :func:`volts_to_action`: ``V = (clip(a, -1, 1) + 1) / 2 * v_max`` [V] (the env's
    map, :func:`spine_gym.envs.drive.action_to_volts`)."""
    return drive.action_to_volts(np.asarray(action, dtype=np.float64), drive.volt_coef(v_max))


class BaseController:
    """Common input checks, action conversion and SB3-style memory handling, for every geometry.

    The base class knows no observation index: each geometry's controllers say where their
    readings are, from the env's table (:class:`spine_gym.controllers.planar.PlanarController`,
    :class:`spine_gym.controllers.spatial.SpatialSignals`), by implementing ``_check_obs(observation)
    -> (obs (n, d) float64, single)`` and ``_temperatures(obs) -> (n, W)`` (the guard's input).
    Subclasses set ``state_size`` and implement ``_initial_state(n)`` and
    ``_volts(obs (n, d) float64, mem (n, k) float64) -> volts (n, W)`` (which updates ``mem`` in
    place).

    Args:
        v_max: the env's full-scale wire voltage [V] (action +1), in (0, 8]
            (:func:`spine_gym.envs.drive.check_v_max`).
        dt: control period [s] (time between two ``predict`` calls), in (0, 10].
        temperature_limit: optional wire-temperature guard [K]: a wire whose observed temperature
            is at or above it gets 0 V for that step. ``None`` disables the guard.
    """

    state_size = 0
    name = "controller"

    def __init__(self, *, v_max: float = 5.0, dt: float = 0.1, temperature_limit: float | None = None):
        self.v_max = check_v_max(v_max)
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
            observation: env observation(s) (the entries the controller reads must be finite).
            state: controller memory returned by the previous call, ``(n_envs, state_size)``, or
                ``None`` to let the controller keep it internally.
            episode_start: ``(n_envs,)`` booleans; rows that are True start from fresh memory.
            deterministic: accepted for SB3 compatibility; these controllers are deterministic.

        Returns:
            ``(action, state)``: actions in [-1, 1], float32, shape ``(W,)`` or ``(n_envs, W)``
            (the env's wire order), and the updated memory.

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
    def _temperatures(self, obs: np.ndarray) -> np.ndarray:  # pragma: no cover - per geometry
        """(n, n_wires) observed wire temperatures [K] (the guard's input)."""
        raise NotImplementedError

    def _action(self, obs: np.ndarray, volts: np.ndarray) -> np.ndarray:
        """Temperature guard, clip to [0, v_max] and map to actions in [-1, 1]."""
        if self.temperature_limit is not None:
            volts = np.where(self._temperatures(obs) >= self.temperature_limit, 0.0, volts)
        volts = np.clip(volts, 0.0, self.v_max)
        return volts_to_action(volts, self.v_max)

    def _check_obs(self, observation) -> tuple[np.ndarray, bool]:  # pragma: no cover - per geometry
        """(obs (n, d) float64, whether it was one (d,) observation), or ValueError for an
        observation the controller cannot read."""
        raise NotImplementedError

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


# --------------------------------------------------------------------------- settings both geometries take
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
