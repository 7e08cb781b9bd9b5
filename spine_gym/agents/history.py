"""A frame-history observation for learned policies: the last k measured angles and actions.

A feed-forward policy sees one frame; a payload or a push shows only in how the angle answered
the recent actions (a heavier load bends less for the same heating). This wrapper appends the
``k`` frames *before* the current one of chosen observation entries (default: the measured angle
and the previous action, the env's ``angle_deg`` and ``previous_action``), newest first:

    h_t = [x_{t−1}, x_{t−2}, …, x_{t−k}],    x_s = obs_s[entries],

with x_s = x_0 for s < 0 (the first frame repeated before an episode's start, so a fresh episode
shows no step in its history). No env change: the entry lives in the agents layer, like
:mod:`spine_gym.agents.integral`.

* :class:`HistorySpec` — k and the observation ranges of the entries; JSON-able (stored as
  ``obs_history`` in ``meta.json``).
* :func:`history_step` — the shift above on a batch (pure NumPy): the memory holds the newest
  k + 1 frames, the appended part is all but the current one (:func:`history_features`).
* :class:`HistoryObsVecEnv` — an SB3 ``VecEnvWrapper`` for training (above the integral's
  wrapper, below ``VecNormalize``); terminal observations in ``infos`` are augmented too.
* :class:`HistoryObsPolicy` — a saved model behind SB3's ``predict`` that keeps the frames itself,
  restarted by ``episode_start`` / ``reset()`` (:func:`spine_gym.agents.runtime.load_policy` returns it for a
  model trained with the wrapper).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv

from .augment import AugmentedObsPolicy, AugmentedObsVecEnv

__all__ = [
    "DEFAULT_HISTORY_KEYS",
    "HistorySpec",
    "history_step",
    "history_features",
    "HistoryObsVecEnv",
    "HistoryObsPolicy",
]

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

    def space(self, base: spaces.Box) -> spaces.Box:
        """``base`` with the k frames' bounds appended."""
        lo, hi = np.tile(self.low, self.frames), np.tile(self.high, self.frames)
        return spaces.Box(
            np.concatenate([base.low, lo]).astype(np.float32),
            np.concatenate([base.high, hi]).astype(np.float32),
            dtype=np.float32,
        )


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


def _memory(n: int, spec: HistorySpec) -> np.ndarray:
    return np.zeros((n, (spec.frames + 1) * spec.width))


class _HistoryMemory:
    """The memory of :class:`HistoryObsVecEnv` and :class:`HistoryObsPolicy`: the newest k + 1 frames."""

    def _memory(self, n: int) -> np.ndarray:
        return _memory(n, self.spec)

    def _advance(self, mem: np.ndarray, obs: np.ndarray, start: np.ndarray) -> np.ndarray:
        return history_step(mem, obs, self.spec, start)

    def _features(self, mem: np.ndarray) -> np.ndarray:
        return history_features(mem, self.spec)


class HistoryObsVecEnv(_HistoryMemory, AugmentedObsVecEnv):
    """Observation = the wrapped env's observation ++ the k previous frames of the spec's entries
    (:class:`spine_gym.agents.augment.AugmentedObsVecEnv`: terminal observations in ``infos`` are augmented
    with the history continued to the episode's last state).

    Args:
        venv: the vector env (raw, un-normalised observations).
        spec: the :class:`HistorySpec` (e.g. :meth:`HistorySpec.from_env`).
    """

    def __init__(self, venv: VecEnv, spec: HistorySpec):
        if not isinstance(spec, HistorySpec):
            raise ValueError(f"spec must be a HistorySpec, got {type(spec).__name__}")
        super().__init__(venv, spec, spec.space(venv.observation_space))


class HistoryObsPolicy(_HistoryMemory, AugmentedObsPolicy):
    """A model trained on :class:`HistoryObsVecEnv` observations, as a ``predict``-able controller.

    It keeps the frames per row of the observation batch; ``episode_start`` (or ``reset()``)
    restarts them (:class:`spine_gym.agents.augment.AugmentedObsPolicy`).
    """

    def __repr__(self) -> str:
        return f"HistoryObsPolicy({self.name}, frames={self.spec.frames}, ranges={self.spec.ranges})"
