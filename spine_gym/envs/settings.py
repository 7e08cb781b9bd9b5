"""The settings of a registered id, read without building its env.

:func:`config_of` gives the validated configuration an env of ``env_id`` made with keyword
arguments ``kwargs`` would hold (``gym.make(env_id, **kwargs).unwrapped.config``): the id's
registration settings (:data:`.ids.ENV_SPECS`) under the caller's keyword arguments, validated by
the env class's ``CONFIG`` with the same errors. No batch, no kernel and no episode is made, so a
caller that needs one setting (the voltage ceiling, the energy normaliser, the temperature limit)
reads it here instead of building a throw-away env.
"""

from __future__ import annotations

import importlib
from typing import Any

from .config import BaseEnvConfig
from .env_facts import make_config
from .ids import ENV_SPECS, family_of

__all__ = ["env_class", "config_of"]


def env_class(env_id: str) -> type:
    """The single-env class of a registered id (its registration's entry point); ValueError for an
    id that is not one of spine_gym's."""
    family_of(env_id)  # the one check of the id
    module, name = ENV_SPECS[env_id].entry_point.split(":")
    return getattr(importlib.import_module(module), name)


def config_of(env_id: str, **kwargs: Any) -> BaseEnvConfig:
    """The configuration of ``gym.make(env_id, **kwargs)`` without making the env.

    ``kwargs`` override the id's registration settings as in ``gym.make``; a keyword that is not an
    argument of the env raises ``TypeError`` and a bad value the configuration's one-line
    ``ValueError`` (the errors ``gym.make`` raises); an unknown id raises ``ValueError``.
    """
    cls = env_class(env_id)
    return make_config(cls.CONFIG, cls.__name__, {**ENV_SPECS[env_id].kwargs, **kwargs})
