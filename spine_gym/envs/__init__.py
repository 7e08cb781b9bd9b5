"""Gymnasium environments of spine_gym; importing this package registers ``SmaSpine-v0``.

* :class:`SmaSpineEnv` (``gym.make("SmaSpine-v0")``) — the single environment; its class docstring
  is the documentation page.
* :class:`SmaSpineVectorEnv` (``gym.make_vec("SmaSpine-v0", num_envs=N)``) — N environments stepped
  by one parallel numba loop over the same code.
* :mod:`spine_gym.envs.task` — :class:`TargetProfile`, :class:`LoadSchedule`, :class:`TipForceEvent`.
* :mod:`spine_gym.envs.sb3` — a Stable-Baselines3 ``VecEnv`` over the vector env (imports SB3).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from .core import OBS_NAMES, OBS_UNITS, EnvConfig, default_randomization
from .spine_env import SmaSpineEnv
from .task import LoadSchedule, TargetProfile, TipForceEvent
from .vector_env import SmaSpineVectorEnv

__all__ = [
    "ENV_ID",
    "SmaSpineEnv",
    "SmaSpineVectorEnv",
    "TargetProfile",
    "LoadSchedule",
    "TipForceEvent",
    "EnvConfig",
    "OBS_NAMES",
    "OBS_UNITS",
    "default_randomization",
]

ENV_ID = "SmaSpine-v0"
MAX_EPISODE_STEPS = 600  # default episode_duration / control_period = 60 s / 0.1 s

if ENV_ID not in registry:
    register(
        id=ENV_ID,
        entry_point="spine_gym.envs.spine_env:SmaSpineEnv",
        vector_entry_point="spine_gym.envs.vector_env:SmaSpineVectorEnv",
        max_episode_steps=MAX_EPISODE_STEPS,
    )
