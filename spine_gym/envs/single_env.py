"""Deprecated module path, kept for one release: the planar env is :mod:`spine_gym.envs.planar_env`,
the class every env is built on :mod:`spine_gym.envs.spine_env`."""

from __future__ import annotations

from .planar_env import SmaSpineEnv
from .spine_env import SpineEnv

__all__ = ["SmaSpineEnv", "SpineEnv"]
