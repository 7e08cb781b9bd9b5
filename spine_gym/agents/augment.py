"""Observation augmentation for learned policies: the env's observation ++ features of a memory.

:mod:`spine_gym.agents.integral` (the integral of the tracking error) and :mod:`spine_gym.agents.history` (the last k
frames) both append features that a per-row memory carries from one observation to the next. This
module holds what they share, once:

* :class:`AugmentedObsVecEnv` — the SB3 ``VecEnvWrapper`` for training: the memory restarts at an
  episode's first observation, and the terminal observation in ``infos`` is augmented with the
  memory continued to the episode's last state (what SB3 bootstraps from on a truncation).
* :class:`AugmentedObsPolicy` — a saved model behind SB3's ``predict`` that keeps the memory per
  row of the observation batch, restarted by ``episode_start`` / ``reset()``.

A subclass says what the memory is through three methods: ``_memory(n)`` (a fresh memory of n
rows), ``_advance(mem, obs, start)`` (the memory after observing the batch ``obs``; rows with
``start`` begin an episode) and ``_features(mem)`` (the appended part). Their spec gives
``min_obs``, the shortest observation the memory reads.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

__all__ = ["AugmentedObsVecEnv", "AugmentedObsPolicy"]


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
        spec: the subclass's spec.
        observation_space: the augmented observation space.
    """

    def __init__(self, venv: VecEnv, spec, observation_space: spaces.Box):
        self.spec = spec
        super().__init__(venv, observation_space=observation_space)
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
