"""What the single and the vector env share above their batch: settings, facts and frames.

:class:`EnvFacts` is the mixin both :class:`~spine_gym.envs.SmaSpineEnv` and
:class:`~spine_gym.envs.SmaSpineVectorEnv` inherit: the read-only facts of their configuration
(``config``) and of their batch's table (``_core``), and the renderer behind ``render()``
(made on first use: ``import spine_gym`` stays free of matplotlib). :func:`make_config` is the one
path from an env's keyword arguments to its configuration class, and :func:`settings_signature`
the signature an env class shows for them (``inspect.signature``, the docs, the CLI's checks).
"""

from __future__ import annotations

import dataclasses
import inspect
from typing import Any

from .batch import TableBatch
from .config import BaseEnvConfig, config_fields

__all__ = ["EnvFacts", "make_config", "make_renderer", "settings_signature"]


def make_config(config_class: type, owner: str, settings: dict[str, Any]) -> BaseEnvConfig:
    """``config_class(**settings)``; TypeError naming ``owner`` for a keyword that is not one of its
    fields (as Python's own), and the configuration's one-line ValueError for a bad value."""
    unknown = set(settings) - set(config_fields(config_class))
    if unknown:
        raise TypeError(f"{owner} got unexpected keyword argument(s) {sorted(unknown)}")
    return config_class(**settings)


def settings_signature(config_class: type, *head: inspect.Parameter) -> inspect.Signature:
    """The signature of an env class that takes ``head`` and then, keyword-only, the fields of
    ``config_class`` with their defaults (what its ``**settings`` accept)."""
    kw = inspect.Parameter.KEYWORD_ONLY
    fields = dataclasses.fields(config_class)
    return inspect.Signature([*head, *(inspect.Parameter(f.name, kw, default=f.default) for f in fields)])


def make_renderer(cfg: BaseEnvConfig):
    """The ``rgb_array`` renderer of an env (imported on the first ``render()``: ``import spine_gym``
    stays free of matplotlib)."""
    from . import render  # noqa: PLC0415  (matplotlib only when rendering)

    return render.make_renderer(cfg)


def _setting(name: str, doc: str) -> property:
    """A read-only property giving the configuration's ``name``."""
    return property(lambda self: getattr(self.config, name), doc=doc)


class EnvFacts:
    """Read-only facts, the table and the frames of an env with a ``config`` and a batch ``_core``."""

    config: BaseEnvConfig
    _core: TableBatch
    _renderer: Any = None

    v_max = _setting(
        "v_max",
        "Voltage of action +1 [V] on a full-length wire (a chain module's shorter wires get it × their "
        "length / L0: ``config.volt_coef``).",
    )
    control_period = _setting("control_period", "Time per step [s].")
    episode_duration = _setting(
        "episode_duration",
        "Episode length [s] (a vector env truncates earlier if ``max_episode_steps`` is smaller).",
    )
    temperature_limit = _setting("temperature_limit", 'Threshold of ``info["cost"]`` [K].')
    thermal_cutoff = _setting(
        "thermal_cutoff",
        "The driver's thermal cut-off [K]: a wire at or above it gets 0 V for the step (None: none).",
    )

    @property
    def observation_names(self) -> tuple[str, ...]:
        """Names of the observation entries (units in the class docstring)."""
        return self._core.obs_names

    @property
    def table(self):
        """The env's declarative observation/info table (:class:`spine_gym.envs.table.Table`)."""
        return self._core.table

    def obs_index(self, key: str) -> slice:
        """Observation indices of the table entry ``key`` (e.g. ``"temperature"``), a slice."""
        return self._core.table.obs_index(key)

    # ------------------------------------------------------------------ frames
    def _frame(self, i: int, slot: int = 0):
        """The (480, 480, 3) uint8 frame of the batch's environment ``i`` (the renderer's ``slot``)."""
        if self._renderer is None:
            self._renderer = make_renderer(self.config)
        return self._renderer.draw(self._core.state_summary(i), slot=slot)

    def _close_renderer(self) -> None:
        """Release the renderer's figure."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self):
        d = self.__dict__.copy()
        d["_renderer"] = None  # matplotlib figures are not pickled
        return d
