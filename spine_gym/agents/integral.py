"""An integral-of-error observation for learned policies (the hard group's loads are not observed).

A feed-forward policy sees the current error but not how long it has persisted; the PID's integral
is what lets it hold a target under an unobserved payload or push. This wrapper appends, per
tracked component, the (optionally leaky) integral of the tracking error ``e = target − tracked``
[deg s for ``SmaSpine-v0``] to the env's observation:

    I_t = clip(d · I_{t−1} + dt · e_t, −limit, limit),    d = exp(−dt / τ)  (τ = inf: d = 1),

with ``I = 0`` before an episode's first observation, ``dt`` the control period and ``e_t`` read
from the observation at step t (so ``I_0 = dt · e_0``). A leak τ of a few seconds forgets the
transient error of a target step while keeping a load's persistent one (steady state ``I = τ e``).
No env change: the env's observation is untouched and the entry lives in the agents layer.

* :class:`IntegralSpec` — τ, the clip, dt and where the tracked value and its target sit in the
  observation (from the env's table); JSON-able (stored as ``obs_integral`` in ``meta.json``).
* :func:`integral_step` — the update above on a batch (pure NumPy).
* :class:`IntegralObsVecEnv` — an SB3 ``VecEnvWrapper`` for training (above ``VecMonitor`` and a
  :class:`spine_gym.agents.residual.ResidualVecEnv`, below ``VecNormalize``); terminal observations in
  ``infos`` are augmented with the integral continued to the last state.
* :class:`IntegralObsPolicy` — a saved model behind SB3's ``predict`` that keeps the integral
  itself, restarted by ``episode_start`` / ``reset()`` (:func:`spine_gym.agents.runtime.load_policy` returns
  it for a model trained with the wrapper).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv

from .augment import AugmentedObsPolicy, AugmentedObsVecEnv

__all__ = ["IntegralSpec", "integral_step", "IntegralObsVecEnv", "IntegralObsPolicy", "parse_tau"]


def parse_tau(value) -> float:
    """The leak time constant τ [s] of a ``obs_integral`` hyperparameter: a number > 0 or ``"inf"``."""
    try:
        tau = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"obs_integral (leak time constant) must be a number > 0 s or 'inf', got {value!r}") from None
    if not tau > 0.0:
        raise ValueError(f"obs_integral (leak time constant) must be a number > 0 s or 'inf', got {value!r}")
    return tau


@dataclass(frozen=True)
class IntegralSpec:
    """Settings of the integral observation.

    Attributes:
        tau: leak time constant [s], > 0 (``math.inf``: a pure integral).
        limit: clip of the integral, > 0 [deg s].
        dt: control period [s], > 0.
        tracked: (start, stop) of the tracked value in the observation (the angle).
        target: (start, stop) of its target in the observation, the same length.
    """

    tau: float
    limit: float
    dt: float
    tracked: tuple[int, int]
    target: tuple[int, int]

    def __post_init__(self):
        parse_tau(self.tau)
        for name in ("limit", "dt"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0.0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        for name in ("tracked", "target"):
            a, b = getattr(self, name)
            if not 0 <= a < b:
                raise ValueError(f"{name} must be an index range (start, stop) with 0 <= start < stop, got {(a, b)}")
            object.__setattr__(self, name, (int(a), int(b)))
        if self.tracked[1] - self.tracked[0] != self.target[1] - self.target[0]:
            raise ValueError(f"tracked {self.tracked} and target {self.target} must have the same length")

    @property
    def size(self) -> int:
        """Number of appended entries (one per tracked component)."""
        return self.tracked[1] - self.tracked[0]

    @property
    def min_obs(self) -> int:
        """Shortest observation the tracked value and its target fit in."""
        return max(self.tracked[1], self.target[1])

    @property
    def decay(self) -> float:
        """d = exp(−dt/τ) (1 for a pure integral)."""
        return 1.0 if math.isinf(self.tau) else math.exp(-self.dt / self.tau)

    @classmethod
    def from_env(cls, env, tau: float, limit: float = 300.0) -> IntegralSpec:
        """The spec for ``env``: its control period and the observation entries of its task
        (tracked quantity) and target (the env's declarative table)."""
        base = getattr(env, "unwrapped", env)
        table = base.config.table()
        target_keys = [e.key for e in table.entries if e.source == "target" and e.obs is not None]
        if not target_keys:
            raise ValueError(f"env {type(base).__name__} observes no target entry")
        tr, tg = base.obs_index(table.task.key), base.obs_index(target_keys[0])
        return cls(parse_tau(tau), float(limit), float(base.control_period), (tr.start, tr.stop), (tg.start, tg.stop))

    def to_dict(self) -> dict:
        d = asdict(self)
        d["tau"] = "inf" if math.isinf(self.tau) else self.tau
        return d

    @classmethod
    def from_dict(cls, d: dict) -> IntegralSpec:
        return cls(parse_tau(d["tau"]), float(d["limit"]), float(d["dt"]), tuple(d["tracked"]), tuple(d["target"]))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return -self.limit * np.ones(self.size, np.float32), self.limit * np.ones(self.size, np.float32)


def integral_step(mem: np.ndarray, obs: np.ndarray, spec: IntegralSpec) -> np.ndarray:
    """``clip(d · mem + dt · (target − tracked), ±limit)`` for a batch ``obs`` (n, d), ``mem`` (n, size)."""
    obs = np.asarray(obs, dtype=np.float64)
    e = obs[:, spec.target[0] : spec.target[1]] - obs[:, spec.tracked[0] : spec.tracked[1]]
    return np.clip(spec.decay * mem + spec.dt * e, -spec.limit, spec.limit)


def augment_space(space: spaces.Box, spec: IntegralSpec) -> spaces.Box:
    lo, hi = spec.bounds()
    return spaces.Box(
        np.concatenate([space.low, lo]).astype(np.float32),
        np.concatenate([space.high, hi]).astype(np.float32),
        dtype=np.float32,
    )


class _IntegralMemory:
    """The memory of :class:`IntegralObsVecEnv` and :class:`IntegralObsPolicy`: the integral,
    0 before an episode's first observation."""

    def _memory(self, n: int) -> np.ndarray:
        return np.zeros((n, self.spec.size))

    def _advance(self, mem: np.ndarray, obs: np.ndarray, start: np.ndarray) -> np.ndarray:
        mem = np.where(np.asarray(start, dtype=bool).reshape(-1, 1), 0.0, mem)
        return integral_step(mem, obs, self.spec)

    def _features(self, mem: np.ndarray) -> np.ndarray:
        return mem


class IntegralObsVecEnv(_IntegralMemory, AugmentedObsVecEnv):
    """Observation = the wrapped env's observation ++ the integral of the tracking error
    (:class:`spine_gym.agents.augment.AugmentedObsVecEnv`: terminal observations in ``infos`` are augmented
    with the integral continued to the episode's last state).

    Args:
        venv: the vector env (raw, un-normalised observations).
        spec: the :class:`IntegralSpec` (e.g. :meth:`IntegralSpec.from_env`).
    """

    def __init__(self, venv: VecEnv, spec: IntegralSpec):
        if not isinstance(spec, IntegralSpec):
            raise ValueError(f"spec must be an IntegralSpec, got {type(spec).__name__}")
        super().__init__(venv, spec, augment_space(venv.observation_space, spec))


class IntegralObsPolicy(_IntegralMemory, AugmentedObsPolicy):
    """A model trained on :class:`IntegralObsVecEnv` observations, as a ``predict``-able controller.

    It keeps the integral per row of the observation batch; ``episode_start`` (or ``reset()``)
    restarts it (:class:`spine_gym.agents.augment.AugmentedObsPolicy`).
    """

    def __repr__(self) -> str:
        return f"IntegralObsPolicy({self.name}, tau={self.spec.tau}, limit={self.spec.limit})"
