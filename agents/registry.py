"""The one registry of controllers: name → class, how it is built for an env, its tuning space.

:mod:`agents.evaluate`, :mod:`agents.tune` and :mod:`agents.residual` choose controllers only
through :data:`REGISTRY` (and :func:`agents.runtime.build_controller`, which builds an entry for an
env). The tuned settings of the tuned entries live in ``agents/hyperparams/baselines.yml``
(:func:`load_tuned`), written by :mod:`agents.tune` from each entry's :attr:`ControllerSpec.search_space`.

Every entry except the open-loop step drive gets the temperature guard the tuning used: a wire
whose observed temperature reaches the env's limit minus :data:`GUARD_MARGIN_K` gets 0 V.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from spine_gym.controllers import (
    BangBangController,
    MPPIController,
    PIDController,
    StepVoltageController,
)

from .common import HYPERPARAMS_DIR

GUARD_MARGIN_K = 5.0  # [K] the guarded controllers cut a wire at (env temperature limit - margin)
TUNED_FILE = HYPERPARAMS_DIR / "baselines.yml"

# used when no tuned file exists (e.g. before the first tuning run)
DEFAULT_TUNED = {
    "bang_bang": {"v_on": 3.5, "band": 1.0, "release": 0.0, "v_hold": 0.0},
    "pid": {
        "kp": 0.3,
        "ki": 0.03,
        "kd": 0.0,
        "tau_d": 0.3,
        "bias": 0.5,
        "kaw": 1.0,
        "feedforward": 0.0,
        "preview": 0.0,
    },
}


def _pid_space(trial, v_max: float) -> dict:
    return {
        "kp": trial.suggest_float("kp", 0.02, 2.0, log=True),
        "ki": trial.suggest_float("ki", 1e-3, 0.5, log=True),
        "kd": trial.suggest_float("kd", 0.0, 1.0),
        "tau_d": trial.suggest_float("tau_d", 0.1, 2.0, log=True),
        "bias": trial.suggest_float("bias", 0.0, 0.5 * v_max),
        "kaw": trial.suggest_float("kaw", 0.1, 10.0, log=True),
        "feedforward": trial.suggest_float("feedforward", 0.0, 1.0),
        "preview": trial.suggest_float("preview", 0.0, 1.0),
    }


def _bang_bang_space(trial, v_max: float) -> dict:
    band = trial.suggest_float("band", 0.1, 5.0, log=True)
    return {
        "v_on": trial.suggest_float("v_on", 1.5, v_max),
        "band": band,
        "release": trial.suggest_float("release", -band, 3.0),
        "v_hold": trial.suggest_float("v_hold", 0.0, 0.6 * v_max),
    }


@dataclass(frozen=True)
class ControllerSpec:
    """One registered controller.

    Attributes:
        cls: the controller class (``spine_gym.controllers``).
        description: one line for tables and ``--help``.
        search_space: ``(optuna trial, v_max) -> constructor kwargs`` for :mod:`agents.tune`, or
            None (not tuned); tuned entries read their settings from :func:`load_tuned`.
        guard: give it the temperature guard (env limit − :data:`GUARD_MARGIN_K`).
        kwargs: fixed constructor kwargs (e.g. the MPC state mode).
        plans_on_env: the constructor takes the env's ``EnvConfig`` first (and the oracle the env).
        in_default: run by ``agents.evaluate`` without being asked for.
    """

    cls: type
    description: str
    search_space: Callable | None = None
    guard: bool = True
    kwargs: Mapping = field(default_factory=dict)
    plans_on_env: bool = False
    in_default: bool = True

    @property
    def tuned(self) -> bool:
        return self.search_space is not None


REGISTRY: dict[str, ControllerSpec] = {
    "step": ControllerSpec(
        StepVoltageController, "open-loop steady-state step voltage (the paper)", guard=False
    ),
    "bang_bang": ControllerSpec(BangBangController, "three-level relay with hysteresis", _bang_bang_space),
    "pid": ControllerSpec(PIDController, "PID with feedforward, preview and anti-windup", _pid_space),
    "mpc_oracle": ControllerSpec(
        MPPIController,
        "MPPI on the env's physics, true state, future targets and loads (privileged upper bound)",
        kwargs={"mode": "oracle"},
        plans_on_env=True,
        in_default=False,
    ),
    "mpc_estimated": ControllerSpec(
        MPPIController,
        "MPPI on the env's physics from the observation (phase-fraction estimator)",
        kwargs={"mode": "estimated"},
        plans_on_env=True,
        in_default=False,
    ),
}
BASELINES = tuple(name for name, spec in REGISTRY.items() if spec.in_default)
TUNABLE = tuple(name for name, spec in REGISTRY.items() if spec.tuned)


def get_spec(name: str) -> ControllerSpec:
    """The registry entry ``name``; ValueError listing the registered names otherwise."""
    if name not in REGISTRY:
        raise ValueError(f"unknown controller {name!r}; registered: {sorted(REGISTRY)}")
    return REGISTRY[name]


def load_tuned(path: Path | None = None) -> dict:
    """Tuned settings ``{name: {...}}`` of the tuned entries (defaults if not tuned yet)."""
    path = Path(path) if path else TUNED_FILE
    if not path.exists():
        return {k: dict(v) for k, v in DEFAULT_TUNED.items()}
    data = yaml.safe_load(path.read_text())
    return {k: dict(data[k]["params"]) if k in data else dict(v) for k, v in DEFAULT_TUNED.items()}
