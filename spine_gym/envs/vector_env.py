"""Deprecated module path, kept for one release: the planar vector env is
:class:`spine_gym.envs.planar_env.SmaSpineVectorEnv`, the vector env every id is built on
:mod:`spine_gym.envs.spine_vector_env`."""

from __future__ import annotations

from .planar_env import SmaSpineVectorEnv
from .spine_vector_env import PARALLEL_MIN_ENVS, FinalArrays, SpineVectorEnv, StepArrays

__all__ = ["SmaSpineVectorEnv", "SpineVectorEnv", "StepArrays", "FinalArrays", "PARALLEL_MIN_ENVS"]
