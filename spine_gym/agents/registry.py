"""Deprecated module path, kept for one release: the controller registry and the tuned settings
live with the controllers, :mod:`spine_gym.controllers.registry`."""

from __future__ import annotations

from spine_gym.controllers.registry import (
    BASELINES,
    DEFAULT_TUNED,
    DEFAULT_TUNED_BY_ENV,
    GUARD_MARGIN_K,
    REGISTRIES,
    REGISTRY,
    TUNABLE,
    TUNED_DIR,
    TUNED_FILE,
    ControllerSpec,
    baselines_for,
    get_spec,
    load_tuned,
    registry_for,
    tunable_for,
    tuned_file,
)

__all__ = [
    "GUARD_MARGIN_K",
    "TUNED_DIR",
    "TUNED_FILE",
    "DEFAULT_TUNED",
    "DEFAULT_TUNED_BY_ENV",
    "ControllerSpec",
    "REGISTRY",
    "REGISTRIES",
    "BASELINES",
    "TUNABLE",
    "registry_for",
    "baselines_for",
    "tunable_for",
    "get_spec",
    "tuned_file",
    "load_tuned",
]
