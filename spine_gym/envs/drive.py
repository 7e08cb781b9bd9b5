"""The wire drive of every env: the one map between actions and wire voltages, and its ceiling.

An action a in [-1, 1] per wire puts ``(clip(a, -1, 1) + 1) · coef`` volts on the wire, with
``coef`` = ½ ``v_max`` × the wire's voltage scale (1 for the planar pair and a four-wire module;
L0_k / L0 for the shorter wires of a chain's module k, SPATIAL.md §6): :func:`volt_coef`,
:func:`action_to_volts`. :func:`action_to_volts` is an ordinary numpy function that numba also
compiles into the jitted step kernels (``register_jitable``), so the env's step, the controllers,
the state estimators and the renderer apply the same expression. :func:`volts_to_action` is its
inverse (what a controller that computes volts returns). :data:`V_MAX_LIMIT` and
:func:`check_v_max` are the one range of ``v_max`` (envs and controllers).
"""

from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

__all__ = ["V_MAX_LIMIT", "check_v_max", "volt_coef", "clip_action", "action_to_volts", "volts_to_action"]

V_MAX_LIMIT = 8.0  # [V] above ~8 V a wire held on for long exceeds the model's 2000 K bound


def check_v_max(value, name: str = "v_max") -> float:
    """``float(value)`` if it is a voltage ceiling in (0, :data:`V_MAX_LIMIT`] V, else ValueError
    naming ``name``, the range and the value received."""
    if isinstance(value, bool):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not (math.isfinite(v) and 0.0 < v <= V_MAX_LIMIT):
        raise ValueError(f"{name} must be in (0, {V_MAX_LIMIT:g}], got {value!r}")
    return v


def volt_coef(v_max, scale=1.0):
    """Volts per unit of (action + 1) of a wire whose voltage scale is ``scale`` (a number or an
    array, one per wire): ½ ``v_max`` × ``scale``."""
    return 0.5 * v_max * scale


@register_jitable
def clip_action(action):
    """``action`` clipped to [-1, 1] (a number or an array; NaN stays NaN)."""
    return np.minimum(np.maximum(action, -1.0), 1.0)


@register_jitable
def action_to_volts(action, coef):
    """Wire voltages [V] of ``action``: ``(clip(a, -1, 1) + 1) · coef`` (``coef`` from
    :func:`volt_coef`; numbers or broadcasting arrays)."""
    return (clip_action(action) + 1.0) * coef


def volts_to_action(volts, v_max) -> np.ndarray:
    """Actions in [-1, 1] (float32) of wire voltages [V] in [0, ``v_max``] (the inverse of
    :func:`action_to_volts` with ``coef = v_max / 2``): ``clip(2 V / v_max − 1, -1, 1)``; ``v_max``
    a number or one per wire."""
    return np.clip(2.0 * np.asarray(volts, dtype=np.float64) / v_max - 1.0, -1.0, 1.0).astype(np.float32)
