"""Deprecated module path, kept for one release: the shared base class is :mod:`.base`, the
steady-state map :mod:`.steady_state`, the planar controllers :mod:`.planar` (beside :mod:`.spatial`)."""

from __future__ import annotations

from .base import BaseController, PIDGains, action_to_volts, check_range, checked_relay  # noqa: F401
from .base import observation_batch, relay_config, volts_to_action  # noqa: F401
from .planar import BangBangController, PIDController, StepVoltageController
from .steady_state import SteadyStateMap, steady_state_map

__all__ = [
    "SteadyStateMap",
    "steady_state_map",
    "BaseController",
    "StepVoltageController",
    "BangBangController",
    "PIDController",
    "PIDGains",
    "volts_to_action",
    "action_to_volts",
    "check_range",
    "checked_relay",
    "observation_batch",
    "relay_config",
]
