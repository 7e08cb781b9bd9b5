"""Deprecated module path, kept for one release: the planar targets are
:mod:`spine_gym.envs.targets_planar` (beside :mod:`spine_gym.envs.targets_spatial`)."""

from __future__ import annotations

from .targets_planar import ANGLE_LIMIT, TARGET_KINDS, TargetProfile

__all__ = ["TargetProfile", "TARGET_KINDS", "ANGLE_LIMIT"]
