"""Deprecated module path, kept for one release: the controller registry and the tuned settings
live with the controllers, :mod:`spine_gym.controllers.registry`."""

from __future__ import annotations

from spine_gym.controllers.registry import *  # noqa: F403  (every public name, re-exported)
from spine_gym.controllers.registry import __all__  # noqa: F401
