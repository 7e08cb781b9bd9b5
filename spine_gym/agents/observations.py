"""Observation features of learned policies: the env's observation ++ features of a memory.

A feed-forward policy sees one frame. Two features give it a memory, appended to the env's
observation by the agents layer (no env change); each has a JSON-able spec (stored in ``meta.json``
so :func:`spine_gym.agents.runtime.load_policy` rebuilds it), a pure-NumPy step, an SB3
``VecEnvWrapper`` for training and a ``predict``-able policy around a saved model:

* the integral of the tracking error (``obs_integral``; :class:`IntegralSpec`,
  :func:`integral_step`, :class:`IntegralObsVecEnv`, :class:`IntegralObsPolicy`). The PID's
  integral is what lets it hold a target under an unobserved payload or push. Per tracked
  component, the (optionally leaky) integral of ``e = target − tracked`` [deg s for ``SmaSpine-v0``]:

      I_t = clip(d · I_{t−1} + dt · e_t, −limit, limit),    d = exp(−dt / τ)  (τ = inf: d = 1),

  with ``I = 0`` before an episode's first observation, ``dt`` the control period and ``e_t`` read
  from the observation at step t (so ``I_0 = dt · e_0``). A leak τ of a few seconds forgets the
  transient error of a target step while keeping a load's persistent one (steady state ``I = τ e``).
  Its wrapper sits above ``VecMonitor`` and a :class:`spine_gym.agents.residual.ResidualVecEnv`,
  below ``VecNormalize``.

* the frame history (``obs_history``; :class:`HistorySpec`, :func:`history_step`,
  :func:`history_features`, :class:`HistoryObsVecEnv`, :class:`HistoryObsPolicy`). A payload or a
  push shows only in how the angle answered the recent actions (a heavier load bends less for the
  same heating). It appends the ``k`` frames *before* the current one of chosen observation entries
  (default: the measured angle and the previous action, the env's ``angle_deg`` and
  ``previous_action``), newest first:

      h_t = [x_{t−1}, x_{t−2}, …, x_{t−k}],    x_s = obs_s[entries],

  with x_s = x_0 for s < 0 (the first frame repeated before an episode's start, so a fresh episode
  shows no step in its history). The memory holds the newest k + 1 frames. Its wrapper sits above
  the integral's, below ``VecNormalize``.

What both share, once:

* :class:`AugmentedObsVecEnv` — the SB3 ``VecEnvWrapper`` for training: the memory restarts at an
  episode's first observation, and the terminal observation in ``infos`` is augmented with the
  memory continued to the episode's last state (what SB3 bootstraps from on a truncation).
* :class:`AugmentedObsPolicy` — a saved model behind SB3's ``predict`` that keeps the memory per
  row of the observation batch, restarted by ``episode_start`` / ``reset()``.

A feature says what its memory is through three methods: ``_memory(n)`` (a fresh memory of n
rows), ``_advance(mem, obs, start)`` (the memory after observing the batch ``obs``; rows with
``start`` begin an episode) and ``_features(mem)`` (the appended part). Its spec gives
``min_obs``, the shortest observation the memory reads, and ``bounds()``, the appended part's bounds.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from .zoo_config import checked_number

__all__ = [
    "AugmentedObsVecEnv",
    "AugmentedObsPolicy",
    "augmented_space",
    "DEFAULT_HISTORY_KEYS",
    "HistorySpec",
    "history_step",
    "history_features",
    "HistoryObsVecEnv",
    "HistoryObsPolicy",
    "IntegralSpec",
    "integral_step",
    "IntegralObsVecEnv",
    "IntegralObsPolicy",
    "parse_tau",
    "FEATURES",
    "feature_specs",
    "specs_from_meta",
    "feature_vec_env",
    "feature_policy",
]

def augmented_space(base: spaces.Box, spec) -> spaces.Box:
    """``base`` with the bounds of ``spec``'s appended part (``spec.bounds()``) after it (float32)."""
    lo, hi = spec.bounds()
    return spaces.Box(
        np.concatenate([base.low, lo]).astype(np.float32),
        np.concatenate([base.high, hi]).astype(np.float32),
        dtype=np.float32,
    )


class _Memory:
    """The three methods a memory-carrying observation defines (see the module docstring)."""

    spec = None

    def _memory(self, n: int) -> np.ndarray:
        raise NotImplementedError

    def _advance(self, mem: np.ndarray, obs: np.ndarray, start: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _features(self, mem: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _augmented(self, obs: np.ndarray, mem: np.ndarray) -> np.ndarray:
        """``obs`` (n, d) ++ the features of ``mem`` (float32, as the policy saw them in training)."""
        return np.concatenate([obs, self._features(mem)], axis=1).astype(np.float32)


class AugmentedObsVecEnv(_Memory, VecEnvWrapper):
    """Observation = the wrapped env's observation ++ the features of the subclass's memory.

    Args:
        venv: the vector env (raw, un-normalised observations).
        spec: the subclass's spec, an instance of its ``spec_type``.
    """

    spec_type: type = object

    def __init__(self, venv: VecEnv, spec):
        if not isinstance(spec, self.spec_type):
            name = self.spec_type.__name__
            article = "an" if name[0] in "AEIOU" else "a"
            raise ValueError(f"spec must be {article} {name}, got {type(spec).__name__}")
        self.spec = spec
        super().__init__(venv, observation_space=augmented_space(venv.observation_space, spec))
        self.mem = self._memory(self.num_envs)
        self.fresh = np.ones(self.num_envs, dtype=bool)

    def _augment(self, obs: np.ndarray) -> np.ndarray:
        self.mem = self._advance(self.mem, obs, self.fresh)
        self.fresh[:] = False
        return self._augmented(obs, self.mem)

    def reset(self) -> np.ndarray:
        self.fresh[:] = True
        return self._augment(self.venv.reset())

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        for i in np.flatnonzero(dones):
            term = infos[i].get("terminal_observation")
            if term is not None:  # the memory continued to the last state of the episode
                last = self._advance(self.mem[i : i + 1], term[None, :], np.zeros(1, dtype=bool))
                infos[i]["terminal_observation"] = self._augmented(term[None, :], last)[0]
        self.fresh[:] = dones
        return self._augment(obs), rewards, dones, infos


class AugmentedObsPolicy(_Memory):
    """A model trained on an :class:`AugmentedObsVecEnv`'s observations, as a ``predict``-able
    controller. ``predict`` returns the model's action and ``state`` ``None``."""

    def __init__(self, model, spec, name: str | None = None):
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
        if obs2.shape[1] < self.spec.min_obs:
            raise ValueError(f"observation must have >= {self.spec.min_obs} entries, got {obs2.shape[1]}")
        start = np.zeros(obs2.shape[0], dtype=bool)
        if self.mem is None or self.mem.shape[0] != obs2.shape[0]:
            self.mem = self._memory(obs2.shape[0])
            start[:] = True
        if episode_start is not None:
            start |= np.asarray(episode_start, dtype=bool).reshape(-1)
        self.mem = self._advance(self.mem, obs2, start)
        action, _ = self.model.predict(self._augmented(obs2, self.mem), None, episode_start, deterministic)
        action = np.asarray(action)
        return (action[0] if single else action), None


# --------------------------------------------------------------------------- frame history
DEFAULT_HISTORY_KEYS = ("angle_deg", "previous_action")
MAX_FRAMES = 50  # 5 s at the 0.1-s control period


@dataclass(frozen=True)
class HistorySpec:
    """Settings of the frame-history observation.

    Attributes:
        frames: k, the number of earlier frames appended, in [1, ``MAX_FRAMES``].
        ranges: (start, stop) observation index ranges of the recorded entries, in order.
        low, high: bounds of one frame (the entries' observation bounds), for the space.
    """

    frames: int
    ranges: tuple[tuple[int, int], ...]
    low: tuple[float, ...]
    high: tuple[float, ...]

    def __post_init__(self):
        if not (isinstance(self.frames, (int, np.integer)) and 1 <= self.frames <= MAX_FRAMES):
            raise ValueError(f"obs_history (frames) must be an integer in [1, {MAX_FRAMES}], got {self.frames!r}")
        if not self.ranges:
            raise ValueError("ranges must name at least one observation entry")
        for a, b in self.ranges:
            if not 0 <= a < b:
                raise ValueError(f"ranges must be index ranges (start, stop) with 0 <= start < stop, got {(a, b)}")
        object.__setattr__(self, "frames", int(self.frames))
        object.__setattr__(self, "ranges", tuple((int(a), int(b)) for a, b in self.ranges))
        if not len(self.low) == len(self.high) == self.width:
            raise ValueError(f"low/high must have one bound per recorded entry ({self.width}), got {len(self.low)}/{len(self.high)}")

    @property
    def width(self) -> int:
        """Entries of one frame."""
        return sum(b - a for a, b in self.ranges)

    @property
    def size(self) -> int:
        """Number of appended entries (k frames)."""
        return self.frames * self.width

    @property
    def min_obs(self) -> int:
        """Shortest observation the ranges fit in."""
        return max(b for _, b in self.ranges)

    @classmethod
    def from_env(cls, env, frames: int, keys: tuple[str, ...] = DEFAULT_HISTORY_KEYS) -> HistorySpec:
        """The spec for ``env``: where its observation holds ``keys`` and their bounds."""
        base = getattr(env, "unwrapped", env)
        space = base.observation_space
        ranges = []
        for k in keys:
            sl = base.obs_index(k)
            ranges.append((sl.start, sl.stop))
        idx = np.concatenate([np.arange(a, b) for a, b in ranges])
        return cls(frames, tuple(ranges), tuple(map(float, space.low[idx])), tuple(map(float, space.high[idx])))

    def to_dict(self) -> dict:
        return {"frames": self.frames, "ranges": [list(r) for r in self.ranges], "low": list(self.low), "high": list(self.high)}

    @classmethod
    def from_dict(cls, d: dict) -> HistorySpec:
        return cls(int(d["frames"]), tuple(tuple(r) for r in d["ranges"]), tuple(d["low"]), tuple(d["high"]))

    def frame(self, obs: np.ndarray) -> np.ndarray:
        """The recorded entries of a batch ``obs`` (n, d) -> (n, width)."""
        return np.concatenate([obs[:, a:b] for a, b in self.ranges], axis=1)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the appended part: one frame's, k times."""
        return np.tile(self.low, self.frames), np.tile(self.high, self.frames)

    def space(self, base: spaces.Box) -> spaces.Box:
        """``base`` with the k frames' bounds appended."""
        return augmented_space(base, self)


def history_step(mem: np.ndarray, obs: np.ndarray, spec: HistorySpec, start: np.ndarray) -> np.ndarray:
    """The newest k + 1 frames after observing ``obs`` (n, d): ``mem`` (n, (k+1)·width) shifted by
    one frame, the current frame first; rows with ``start`` (an episode's first observation) are
    filled with the current frame."""
    x = spec.frame(np.asarray(obs, dtype=np.float64))
    out = np.concatenate([x, mem[:, : spec.size]], axis=1)
    start = np.asarray(start, dtype=bool).reshape(-1)
    out[start] = np.tile(x[start], spec.frames + 1)
    return out


def history_features(mem: np.ndarray, spec: HistorySpec) -> np.ndarray:
    """The appended part: the k frames before the current one, newest first (n, k·width)."""
    return mem[:, spec.width :]


class _HistoryMemory:
    """The memory of :class:`HistoryObsVecEnv` and :class:`HistoryObsPolicy`: the newest k + 1 frames."""

    def _memory(self, n: int) -> np.ndarray:
        return np.zeros((n, (self.spec.frames + 1) * self.spec.width))

    def _advance(self, mem: np.ndarray, obs: np.ndarray, start: np.ndarray) -> np.ndarray:
        return history_step(mem, obs, self.spec, start)

    def _features(self, mem: np.ndarray) -> np.ndarray:
        return history_features(mem, self.spec)


# --------------------------------------------------------------------------- integral of the error
def parse_tau(value) -> float:
    """The leak time constant τ [s] of a ``obs_integral`` hyperparameter: a number > 0 or ``"inf"``."""
    message = f"obs_integral (leak time constant) must be a number > 0 s or 'inf', got {value!r}"
    return checked_number(value, lambda tau: tau > 0.0, message)


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


# --------------------------------------------------------------------------- the wrappers of both
class IntegralObsVecEnv(_IntegralMemory, AugmentedObsVecEnv):
    """:class:`AugmentedObsVecEnv` appending the integral of the tracking error (``spec``: an
    :class:`IntegralSpec`)."""

    spec_type = IntegralSpec


class HistoryObsVecEnv(_HistoryMemory, AugmentedObsVecEnv):
    """:class:`AugmentedObsVecEnv` appending the k previous frames of the entries of ``spec``, a
    :class:`HistorySpec`."""

    spec_type = HistorySpec


class IntegralObsPolicy(_IntegralMemory, AugmentedObsPolicy):
    """A model trained on :class:`IntegralObsVecEnv` observations, keeping the integral itself
    (:class:`AugmentedObsPolicy`)."""

    def __repr__(self) -> str:
        return f"IntegralObsPolicy({self.name}, tau={self.spec.tau}, limit={self.spec.limit})"


class HistoryObsPolicy(_HistoryMemory, AugmentedObsPolicy):
    """A model trained on :class:`HistoryObsVecEnv` observations, keeping the frames itself
    (:class:`AugmentedObsPolicy`)."""

    def __repr__(self) -> str:
        return f"HistoryObsPolicy({self.name}, frames={self.spec.frames}, ranges={self.spec.ranges})"


# --------------------------------------------------------------------------- both, in training's order
# hyperparameter (and meta.json) key -> (spec, training wrapper, policy wrapper); the training env wraps
# them in this order, so the model sees [obs, integral, frame history]
FEATURES = {
    "obs_integral": (IntegralSpec, IntegralObsVecEnv, IntegralObsPolicy),
    "obs_history": (HistorySpec, HistoryObsVecEnv, HistoryObsPolicy),
}


def feature_specs(env, special: dict) -> dict:
    """``{key: spec}`` of the features a hyperparameter entry's settings ``special`` switch on
    (``obs_integral``: τ, with ``obs_integral_limit``; ``obs_history``: k), for ``env``, in
    :data:`FEATURES`' order."""
    specs = {}
    if special.get("obs_integral") is not None:
        limit = float(special.get("obs_integral_limit", 300.0))
        specs["obs_integral"] = IntegralSpec.from_env(env, special["obs_integral"], limit)
    if special.get("obs_history") is not None:
        specs["obs_history"] = HistorySpec.from_env(env, special["obs_history"])
    return specs


def specs_from_meta(meta: dict) -> dict:
    """``{key: spec}`` of the features stored in a run's ``meta.json`` (``to_dict`` forms), in
    :data:`FEATURES`' order."""
    return {key: FEATURES[key][0].from_dict(meta[key]) for key in FEATURES if meta.get(key)}


def feature_vec_env(venv: VecEnv, specs: dict) -> VecEnv:
    """``venv`` inside the training wrappers of ``specs`` (from :func:`feature_specs`)."""
    for key, spec in specs.items():
        venv = FEATURES[key][1](venv, spec)
    return venv


def feature_policy(policy, specs: dict):
    """``policy`` (a model behind ``predict``, with a ``name``) inside the policy wrappers of ``specs``:
    the outermost computes the first feature, as the training env's innermost wrapper appends it first."""
    for key in reversed(list(specs)):
        policy = FEATURES[key][2](policy, specs[key])
    return policy
