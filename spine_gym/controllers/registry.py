"""The one registry of controllers: name → class, how it is built for an env, its tuning space.

:mod:`spine_gym.agents.evaluate`, :mod:`spine_gym.agents.tune` and :mod:`spine_gym.agents.residual`
choose controllers only through :data:`REGISTRY` (and :func:`spine_gym.agents.runtime.build_controller`, which builds an entry for an
env). The tuned settings of the tuned entries live beside the controllers, in
``spine_gym/controllers/tuned/baselines.yml`` (planar ``SmaSpine-v0``) and
``spine_gym/controllers/tuned/baselines_<env id>.yml`` (the spatial envs): the gains of a family,
written by :mod:`spine_gym.agents.tune` from each entry's :attr:`ControllerSpec.search_space`
(``spine_gym.agents.registry`` is the former module path, kept for one release). An id may hold
its own gains in ``spine_gym/controllers/tuned/<env id>.yml`` (:func:`id_tuned_file`, written by
:mod:`spine_gym.agents.retune` only for a re-tune that beat the family's gains on validation
episodes); :func:`load_tuned` reads an id's own entry where there is one and the family's otherwise.

Each env id has its own table (:data:`REGISTRIES`, :func:`registry_for`): :data:`REGISTRY` for
``SmaSpine-v0``; ``SmaSpine3D-v0`` and ``SmaSpineChain-v0`` get the spatial baselines of
:mod:`spine_gym.controllers.spatial` under the same names (``step``, ``bang_bang``, ``pid``),
built from the env (``from_env``: its layout, observation table and per-wire voltages).

Every entry except the open-loop step drive gets the temperature guard the tuning used: a wire
whose observed temperature reaches the env's limit minus :data:`GUARD_MARGIN_K` gets 0 V — except
where the plant cuts hot wires itself (the ``thermal_cutoff`` env setting of the ``-v2`` ids): there no
controller brings a guard of its own. :func:`guard_temperature` is that one rule (and
:func:`controller_kwargs` the kwargs it gives an entry).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from ..envs import ENV_ID, base_id
from ..envs import ENV_ID_3D as SPATIAL_ENV_ID
from ..envs import ENV_ID_CHAIN as CHAIN_ENV_ID
from .mpc import MPPIController
from .mpc_long import LongHorizonMPC
from .mpc_spatial import SpatialMPPIController
from .planar import BangBangController, PIDController, StepVoltageController
from .sliding_mode import SlidingModeController, SMCGains, SpatialSlidingModeController
from .spatial import SpatialBangBangController, SpatialPIDController, SpatialStepController

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
    "id_tuned_file",
    "load_tuned",
    "tuned_record",
    "controller_kwargs",
    "guard_temperature",
]

GUARD_MARGIN_K = 5.0  # [K] the guarded controllers cut a wire at (env temperature limit - margin)
TUNED_DIR = Path(__file__).parent / "tuned"  # the shipped tuned settings
TUNED_FILE = TUNED_DIR / "baselines.yml"

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
    "smc": {k: v for k, v in dataclasses.asdict(SMCGains()).items() if k != "kaw"},
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


def _chain_pid_space(trial, v_max: float) -> dict:
    return {**_pid_space(trial, v_max), "tip_ki": trial.suggest_float("tip_ki", 0.0, 1.0)}


def _smc_space(trial, v_max: float) -> dict:
    k_min = trial.suggest_float("k_min", 0.0, 0.3 * v_max)
    return {
        "lam": trial.suggest_float("lam", 0.1, 20.0, log=True),
        "gamma": trial.suggest_float("gamma", 0.3, 1.0),
        "tau_d": trial.suggest_float("tau_d", 0.05, 2.0, log=True),
        "k_s": trial.suggest_float("k_s", 0.01, 2.0, log=True),
        "k_i": trial.suggest_float("k_i", 1e-3, 1.0, log=True),
        "phi": trial.suggest_float("phi", 0.1, 10.0, log=True),
        "k_min": k_min,
        "k_max": trial.suggest_float("k_max", k_min, 0.6 * v_max),
        "rho": trial.suggest_float("rho", 1e-3, 1.0, log=True),
        "sigma": trial.suggest_float("sigma", 0.01, 2.0, log=True),
        "bias": trial.suggest_float("bias", 0.0, 0.5 * v_max),
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
        search_space: ``(optuna trial, v_max) -> constructor kwargs`` for :mod:`spine_gym.agents.tune`, or
            None (not tuned); tuned entries read their settings from :func:`load_tuned`.
        guard: give it the temperature guard (env limit − :data:`GUARD_MARGIN_K`).
        kwargs: fixed constructor kwargs (e.g. the MPC state mode).
        plans_on_env: the constructor takes the env's ``PlanarConfig`` first (and the oracle the env).
        in_default: run by ``spine_gym.agents.evaluate`` without being asked for.
        from_env: built by ``cls.from_env(env, **kwargs)`` (the spatial controllers read the
            env's layout and observation table).
    """

    cls: type
    description: str
    search_space: Callable | None = None
    guard: bool = True
    kwargs: Mapping = field(default_factory=dict)
    plans_on_env: bool = False
    in_default: bool = True
    from_env: bool = False

    @property
    def tuned(self) -> bool:
        return self.search_space is not None


def _mpc_specs(cls: type, model: str, estimator: str, **how) -> dict[str, ControllerSpec]:
    """The three MPPI entries (not run by default) of the planner ``cls`` on ``model`` (its dynamics),
    ``estimator`` the state estimate of ``mpc_estimated``; ``how``: how it is built from the env."""
    modes = (
        ("mpc_oracle", "oracle", "true state, future targets and loads (privileged upper bound)"),
        ("mpc_oracle_causal", "oracle_causal",
         "true state and plant, current load held, observed target preview (privileged, causal)"),
        ("mpc_estimated", "estimated", None),
    )  # fmt: skip
    return {
        name: ControllerSpec(
            cls,
            f"MPPI on {model}, {what}" if what else f"MPPI on {model} from the observation ({estimator})",
            kwargs={"mode": mode},
            in_default=False,
            **how,
        )
        for name, mode, what in modes
    }


def _mpc_long_specs() -> dict[str, ControllerSpec]:
    """The two long-horizon MPC entries (not run by default): the causal planner on the observation
    and its privileged twin on the true state."""
    modes = (
        ("mpc_long", "estimated", "(the thermal time scale) with an energy term, from the observation"),
        ("mpc_long_oracle_causal", "oracle_causal", "on the true state and plant (privileged, causal)"),
    )
    return {
        name: ControllerSpec(
            LongHorizonMPC,
            f"move-blocked MPPI over 15 s {what}",
            kwargs={"mode": mode},
            plans_on_env=True,
            in_default=False,
        )
        for name, mode, what in modes
    }


REGISTRY: dict[str, ControllerSpec] = {
    "step": ControllerSpec(
        StepVoltageController, "open-loop steady-state step voltage (the paper)", guard=False
    ),
    "bang_bang": ControllerSpec(BangBangController, "three-level relay with hysteresis", _bang_bang_space),
    "pid": ControllerSpec(PIDController, "PID with feedforward, preview and anti-windup", _pid_space),
    "smc": ControllerSpec(
        SlidingModeController,
        "adaptive terminal sliding mode with a boundary layer",
        _smc_space,
    ),
    **_mpc_specs(MPPIController, "the env's physics", "phase-fraction estimator", plans_on_env=True),
    **_mpc_long_specs(),
}
BASELINES = tuple(name for name, spec in REGISTRY.items() if spec.in_default)
TUNABLE = tuple(name for name, spec in REGISTRY.items() if spec.tuned)


def _spatial_registry(pid_space: Callable) -> dict[str, ControllerSpec]:
    return {
        "step": ControllerSpec(
            SpatialStepController,
            "open-loop steady-state step voltage per bending axis",
            guard=False,
            from_env=True,
        ),
        "bang_bang": ControllerSpec(
            SpatialBangBangController, "relay with hysteresis per wire", _bang_bang_space, from_env=True
        ),
        "pid": ControllerSpec(
            SpatialPIDController,
            "PID per module and bending axis, split over the antagonistic wires",
            pid_space,
            from_env=True,
        ),  # fmt: skip
        "smc": ControllerSpec(
            SpatialSlidingModeController,
            "adaptive terminal sliding mode per module and bending axis",
            _smc_space,
            from_env=True,
        ),
        **_mpc_specs(
            SpatialMPPIController, "the spatial core", "per-wire phase-fraction estimator", from_env=True
        ),
    }


REGISTRIES: dict[str, dict[str, ControllerSpec]] = {
    ENV_ID: REGISTRY,
    SPATIAL_ENV_ID: _spatial_registry(_pid_space),
    CHAIN_ENV_ID: _spatial_registry(_chain_pid_space),  # + tip_ki: integral of the tip-position error
}

# the spatial PIDs start from the planar hand-set gains (tip_ki: the chain's tip integral, off)
DEFAULT_TUNED_BY_ENV = {
    ENV_ID: DEFAULT_TUNED,
    SPATIAL_ENV_ID: DEFAULT_TUNED,
    CHAIN_ENV_ID: {**DEFAULT_TUNED, "pid": {**DEFAULT_TUNED["pid"], "tip_ki": 0.0}},
}


def registry_for(env_id: str = ENV_ID) -> dict[str, ControllerSpec]:
    """The controller table of ``env_id`` (one per family: every version and tier of a spine shares
    its ``-v0`` table); ValueError naming the registered ids otherwise."""
    return REGISTRIES[base_id(env_id)]


def baselines_for(env_id: str = ENV_ID) -> tuple[str, ...]:
    """Names of the entries ``spine_gym.agents.evaluate`` runs by default on ``env_id``."""
    return tuple(name for name, spec in registry_for(env_id).items() if spec.in_default)


def tunable_for(env_id: str = ENV_ID) -> tuple[str, ...]:
    """Names of the tuned entries of ``env_id``."""
    return tuple(name for name, spec in registry_for(env_id).items() if spec.tuned)


def get_spec(name: str, env_id: str = ENV_ID) -> ControllerSpec:
    """The registry entry ``name`` of ``env_id``; ValueError listing the registered names otherwise."""
    table = registry_for(env_id)
    if name not in table:
        raise ValueError(f"unknown controller {name!r} for {env_id}; registered: {sorted(table)}")
    return table[name]


def tuned_file(env_id: str = ENV_ID) -> Path:
    """Where :mod:`spine_gym.agents.tune` writes the tuned settings of ``env_id``."""
    env_id = base_id(env_id)
    return TUNED_FILE if env_id == ENV_ID else TUNED_DIR / f"baselines_{env_id}.yml"


def id_tuned_file(env_id: str) -> Path:
    """Where the gains of ``env_id`` alone live (an id's own re-tune, :mod:`spine_gym.agents.retune`);
    ValueError for an unregistered id."""
    base_id(env_id)  # ValueError naming the registered ids
    return TUNED_DIR / f"{env_id}.yml"


def _read(path: Path) -> dict:
    return (yaml.safe_load(path.read_text()) or {}) if path.exists() else {}


def tuned_record(env_id: str, name: str) -> dict | None:
    """The stored record (``params``, tuning budget, validation scores...) the tuned settings of entry
    ``name`` on ``env_id`` come from: the id's own file's entry, else the family file's, else None
    (the entry runs on :data:`DEFAULT_TUNED_BY_ENV`)."""
    for path in (id_tuned_file(env_id), tuned_file(env_id)):
        entry = _read(path).get(name)
        if entry:
            return entry
    return None


def load_tuned(path: Path | None = None, env_id: str = ENV_ID) -> dict:
    """Tuned settings ``{name: {...}}`` of the tuned entries of ``env_id``: per entry, the id's own
    gains (:func:`id_tuned_file`) if it has them, else its family's (:func:`tuned_file`), else the
    defaults (not tuned yet). ``path``: read that one file instead (entries it lacks: defaults)."""
    defaults = DEFAULT_TUNED_BY_ENV[base_id(env_id)]
    layers = [Path(path)] if path else [tuned_file(env_id), id_tuned_file(env_id)]
    out = {k: dict(v) for k, v in defaults.items()}
    for data in map(_read, layers):  # later layers win
        out.update((k, dict(data[k]["params"])) for k in defaults if k in data)
    return out


def controller_kwargs(
    name: str, env_id: str, tuned: dict | None, temperature_limit: float, cutoff: float | None = None
) -> dict:
    """The constructor kwargs of entry ``name`` of ``env_id``'s registry: fixed, tuned (``tuned``
    overrides :func:`load_tuned`, ``{name: {...}}``), and the guard below the env's
    ``temperature_limit`` [K] — none where the plant cuts hot wires itself (``cutoff`` [K], the
    ``-v2`` ids): there every controller meets the plant's protection and brings none of its own."""
    spec = get_spec(name, env_id)
    kwargs = dict(spec.kwargs)
    if spec.tuned:
        kwargs.update((load_tuned(env_id=env_id) if tuned is None else tuned)[name])
    own = guard_temperature(spec.guard, temperature_limit, cutoff)
    if own is not None:
        kwargs["temperature_limit"] = own
    return kwargs


def guard_temperature(guard: bool, temperature_limit: float, cutoff: float | None = None) -> float | None:
    """The observed temperature [K] at which a controller's own guard cuts a wire: the env's
    ``temperature_limit`` minus :data:`GUARD_MARGIN_K` for a guarded entry (``guard``, its
    :attr:`ControllerSpec.guard`) on a plant without a thermal cut-off (``cutoff`` ``None``); ``None``
    (no guard of its own) otherwise."""
    return float(temperature_limit) - GUARD_MARGIN_K if guard and cutoff is None else None
