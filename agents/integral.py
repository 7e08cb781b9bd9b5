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
  :class:`agents.residual.ResidualVecEnv`, below ``VecNormalize``); terminal observations in
  ``infos`` are augmented with the integral continued to the last state.
* :class:`IntegralObsPolicy` — a saved model behind SB3's ``predict`` that keeps the integral
  itself, restarted by ``episode_start`` / ``reset()`` (:func:`agents.runtime.load_policy` returns
  it for a model trained with the wrapper).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

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


class IntegralObsVecEnv(VecEnvWrapper):
    """Observation = the wrapped env's observation ++ the integral of the tracking error.

    Args:
        venv: the vector env (raw, un-normalised observations).
        spec: the :class:`IntegralSpec` (e.g. :meth:`IntegralSpec.from_env`).
    """

    def __init__(self, venv: VecEnv, spec: IntegralSpec):
        if not isinstance(spec, IntegralSpec):
            raise ValueError(f"spec must be an IntegralSpec, got {type(spec).__name__}")
        self.spec = spec
        super().__init__(venv, observation_space=augment_space(venv.observation_space, spec))
        self.mem = np.zeros((self.num_envs, spec.size))

    def _augment(self, obs: np.ndarray) -> np.ndarray:
        self.mem = integral_step(self.mem, obs, self.spec)
        return np.concatenate([obs, self.mem], axis=1).astype(np.float32)

    def reset(self) -> np.ndarray:
        self.mem[:] = 0.0
        return self._augment(self.venv.reset())

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        for i in np.flatnonzero(dones):
            term = infos[i].get("terminal_observation")
            if term is not None:  # the integral continued to the last state of the episode
                last = integral_step(self.mem[i : i + 1], term[None, :], self.spec)[0]
                infos[i]["terminal_observation"] = np.concatenate([term, last]).astype(np.float32)
            self.mem[i] = 0.0
        return self._augment(obs), rewards, dones, infos


class IntegralObsPolicy:
    """A model trained on :class:`IntegralObsVecEnv` observations, as a ``predict``-able controller.

    It keeps the integral per row of the observation batch; ``episode_start`` (or ``reset()``)
    restarts it. ``predict`` returns the model's action and ``state`` ``None``.
    """

    def __init__(self, model, spec: IntegralSpec, name: str | None = None):
        self.model = model
        self.spec = spec
        self.name = name or getattr(model, "name", "policy")
        self.meta = getattr(model, "meta", {})
        self.env_kwargs = getattr(model, "env_kwargs", {})
        self.mem = None

    def reset(self) -> None:
        self.mem = None
        if hasattr(self.model, "reset"):
            self.model.reset()

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        obs = np.asarray(observation)
        if obs.ndim not in (1, 2) or not np.issubdtype(obs.dtype, np.number):
            raise ValueError(f"observation must be a numeric array (d,) or (n_envs, d), got shape {obs.shape}")
        single = obs.ndim == 1
        obs2 = np.atleast_2d(obs).astype(np.float32)
        if obs2.shape[1] < max(self.spec.tracked[1], self.spec.target[1]):
            raise ValueError(f"observation must have >= {max(self.spec.tracked[1], self.spec.target[1])} entries, got {obs2.shape[1]}")
        if self.mem is None or self.mem.shape[0] != obs2.shape[0]:
            self.mem = np.zeros((obs2.shape[0], self.spec.size))
        if episode_start is not None:
            self.mem[np.asarray(episode_start, dtype=bool).reshape(-1)] = 0.0
        self.mem = integral_step(self.mem, obs2, self.spec)
        aug = np.concatenate([obs2, self.mem], axis=1).astype(np.float32)
        action, _ = self.model.predict(aug, None, episode_start, deterministic)
        action = np.asarray(action)
        return (action[0] if single else action), None

    def __repr__(self) -> str:
        return f"IntegralObsPolicy({self.name}, tau={self.spec.tau}, limit={self.spec.limit})"
