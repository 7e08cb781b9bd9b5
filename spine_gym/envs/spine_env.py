"""The env class every spine_gym id is built on: one spine, stepped through a batch of one.

:class:`SpineEnv` is a ``gymnasium.Env`` over a configuration class (``CONFIG``, its fields the
keyword arguments) and a batch class (``BATCH``, a :class:`spine_gym.envs.batch.TableBatch`): it
maps actions to wire voltages, runs one control period of the model per step through the batch
(the code the vector env runs too) and returns observations, rewards and infos. Each geometry's
env is a subclass that names its configuration and batch and carries its documentation page
(:mod:`.planar_env`, :mod:`.spatial_env`).
"""

from __future__ import annotations

import inspect
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..params import ModelParams
from .batch import SpineSnapshot
from .env_facts import EnvFacts, make_config, settings_signature

__all__ = ["SpineEnv"]

_RENDER_MODE = inspect.Parameter("render_mode", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=None)


class SpineEnv(EnvFacts, gym.Env):
    """One SMA-actuated spine as a Gymnasium env: the machinery every env id shares.

    A subclass sets ``CONFIG`` (the configuration class; its fields are the keyword arguments)
    and ``BATCH`` (the batch class behind the env); its class docstring is the env's
    documentation page (spaces, rewards, starting state, episode end, info, arguments). The
    action space is ``Box(-1, 1, (n_wires,))``, the observation space follows from the
    configuration's declarative table (:mod:`spine_gym.envs.table`).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}
    CONFIG: type = None  # the configuration class (its fields are the keyword arguments)
    BATCH: type = None  # the batch class behind the env

    def __init__(self, render_mode: str | None = None, **settings):
        """The keyword arguments (``settings``) are the fields of ``CONFIG``; the
        spaces and a batch of one of ``BATCH`` follow from them (every single env id of spine_gym)."""
        self.config = config = make_config(self.CONFIG, type(self).__name__, settings)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": 1.0 / config.control_period}
        self.action_space = spaces.Box(-1.0, 1.0, (config.n_wires,), np.float32)
        self._core = self.BATCH(config, 1, parallel=False, action_shape=self.action_space.shape)
        self.observation_space = spaces.Box(self._core.obs_low, self._core.obs_high, dtype=np.float32)
        self._renderer = None
        self._needs_reset = True
        self._done = False

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.CONFIG is not None:
            cls.__signature__ = settings_signature(cls.CONFIG, _RENDER_MODE)

    # ------------------------------------------------------------------ read-only facts
    @property
    def max_steps(self) -> int:
        """Steps per episode (the env truncates after this many)."""
        return self.config.n_steps

    @property
    def target_profile(self):
        """The target of the current episode (the geometry's target class)."""
        return self._episode()[0]

    @property
    def load_schedule(self):
        """The :class:`~spine_gym.envs.loads.LoadSchedule` of the current episode."""
        return self._episode()[1]

    @property
    def model_params(self) -> ModelParams:
        """The :class:`ModelParams` of the current episode (randomised or nominal)."""
        return self._episode()[2]

    @property
    def state(self) -> np.ndarray:
        """Copy of the model state vector (``spine_gym.physics.planar.columns``, or
        ``spine_gym.physics.spatial.columns`` for a spatial spine)."""
        return self._core.states[0].copy()

    def _episode(self):
        ep = self._core.episodes[0]
        if ep is None:
            raise RuntimeError("call reset() first")
        return ep

    # ------------------------------------------------------------------ API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Start an episode (see "Starting state" in the env's documentation page)."""
        super().reset(seed=seed)
        obs = self._core.reset_env(0, self.np_random, options)
        self._needs_reset = False
        self._done = False
        return obs, self._info()

    def step(self, action):
        """One control period; returns ``(obs, reward, terminated, truncated, info)``."""
        if self._needs_reset:
            raise RuntimeError("call reset() before step()")
        core = self._core
        actions = core.check_actions(action)
        if self._done:
            gym.logger.warn(
                "step() called after the episode ended (terminated or truncated); call reset(). "
                "The model keeps running with the last target and loads."
            )
        core.advance(actions, (self.np_random,))
        term, trunc = bool(core.terminated[0]), bool(core.truncated[0])
        self._done = self._done or term or trunc
        return core.obs[0].copy(), float(core.last_row[0, core.reward_col]), term, trunc, self._info()

    def _info(self) -> dict[str, Any]:
        """The info of the last step or reset (the batch's row 0)."""
        core = self._core
        return core.row_infos(core.last_row[:1].copy(), core.status[:1])[0]

    def snapshot(self) -> SpineSnapshot:
        """The env's full state (model state, episode, bookkeeping, generator) as a copy.

        ``restore(snap)`` later (on this env or another one made with the same arguments) makes
        the env continue exactly as it would have from here: same observations, rewards and infos
        for the same actions, bit for bit. Used by model-predictive control to plan from the true
        state (``spine_gym.controllers.MPPIController``, oracle mode).
        """
        snap = self._core.snapshot(0)
        return snap.with_rng(self.np_random.bit_generator.state, done=self._done)

    def restore(self, snap: SpineSnapshot) -> None:
        """Return to a :meth:`snapshot`; ValueError if it comes from an env of another configuration."""
        self._core.restore(0, snap)
        if snap.rng_state is not None:
            self.np_random.bit_generator.state = snap.rng_state
        self._done = bool(snap.extra.get("done", False))
        self._needs_reset = False

    def render(self):
        """An (480, 480, 3) uint8 frame if ``render_mode == "rgb_array"``, else None."""
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without render_mode; create the env with render_mode='rgb_array'"
            )
            return None
        if self._core.episodes[0] is None:
            raise RuntimeError("call reset() before render()")
        return self._frame(0)

    def close(self):
        """Release the figure of the renderer."""
        self._close_renderer()


