"""Gymnasium environments of spine_gym; importing this package registers every id of
:mod:`spine_gym.envs.ids`: ``SmaSpine-v0``, ``SmaSpine3D-v0``, ``SmaSpineChain-v0``, their ``-v1``
versions (observed tracking errors, rewards of order one) and the ``Easy``/``Hard`` tiers of ``-v1``.

* :class:`SpineEnv` and :class:`SpineVectorEnv` — the env and the native vector env every id is
  built on (a configuration class and a batch class; ``gym.make_vec(id, num_envs=N)`` steps N
  environments in one numba loop over the same code, from 64 envs serial or parallel, whichever
  runs faster).
* One env per geometry, each with its configuration, targets and documentation page (its class
  docstring): :class:`SmaSpineEnv` (``gym.make("SmaSpine-v0")``, the planar spine,
  :class:`PlanarConfig`, :mod:`spine_gym.envs.planar_env`), :class:`SmaSpine3DEnv`
  (``"SmaSpine3D-v0"``, four wires, two bending planes) and :class:`SmaSpineChainEnv`
  (``"SmaSpineChain-v0"``, chained four-wire modules) — the spatial spines (SPATIAL.md,
  :mod:`spine_gym.envs.spatial_env`); their vector envs :class:`SmaSpineVectorEnv`,
  :class:`SmaSpine3DVectorEnv`, :class:`SmaSpineChainVectorEnv`.
* :func:`config_of` — the validated configuration of an id and keyword arguments, without
  building the env.
* :mod:`spine_gym.envs.table` — the declarative observation/info table every env is built from.
* :mod:`spine_gym.envs.targets_planar`, :mod:`spine_gym.envs.targets_spatial` — :class:`TargetProfile`,
  :class:`BendTarget`, :class:`ChainTarget`; :mod:`spine_gym.envs.loads` — :class:`LoadSchedule`,
  :class:`TipForceEvent`.
* ``EnvConfig`` (now :class:`PlanarConfig`) and the module paths ``spine_gym.envs.single_env``,
  ``spine_gym.envs.vector_env`` and ``spine_gym.envs.targets`` are the former names, kept for one
  release.
* :mod:`spine_gym.envs.sb3` — a Stable-Baselines3 ``VecEnv`` over the vector env (imports SB3).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from .config import default_randomization
from .ids import BENCHMARK_IDS, ENV_SPECS, base_id, family_of, tier_of
from .loads import LoadSchedule, TipForceEvent
from .planar import OBS_NAMES, OBS_UNITS, EnvConfig, PlanarConfig
from .planar_env import SmaSpineEnv, SmaSpineVectorEnv
from .settings import config_of
from .spatial import ChainConfig, Spine3DConfig
from .spatial_env import SmaSpine3DEnv, SmaSpine3DVectorEnv, SmaSpineChainEnv, SmaSpineChainVectorEnv
from .spine_env import SpineEnv
from .spine_vector_env import SpineVectorEnv
from .targets_planar import TargetProfile
from .targets_spatial import BendTarget, ChainTarget

__all__ = [
    "ENV_ID",
    "ENV_ID_3D",
    "ENV_ID_CHAIN",
    "ENV_SPECS",
    "BENCHMARK_IDS",
    "base_id",
    "family_of",
    "tier_of",
    "config_of",
    "SpineEnv",
    "SpineVectorEnv",
    "SmaSpineEnv",
    "SmaSpineVectorEnv",
    "SmaSpine3DEnv",
    "SmaSpine3DVectorEnv",
    "SmaSpineChainEnv",
    "SmaSpineChainVectorEnv",
    "BendTarget",
    "ChainTarget",
    "TargetProfile",
    "LoadSchedule",
    "TipForceEvent",
    "PlanarConfig",
    "Spine3DConfig",
    "ChainConfig",
    "EnvConfig",
    "OBS_NAMES",
    "OBS_UNITS",
    "default_randomization",
]

ENV_ID = "SmaSpine-v0"
ENV_ID_3D = "SmaSpine3D-v0"
ENV_ID_CHAIN = "SmaSpineChain-v0"
MAX_EPISODE_STEPS = 600  # default episode_duration / control_period = 60 s / 0.1 s

for _spec in ENV_SPECS.values():
    if _spec.id not in registry:
        register(
            id=_spec.id,
            entry_point=_spec.entry_point,
            vector_entry_point=_spec.vector_entry_point,
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs=dict(_spec.kwargs),
        )
