"""How a training run is built: its configuration, wrapped envs and model (no CLI here).

:mod:`spine_gym.agents.train` (the training CLI) and :mod:`spine_gym.agents.benchmark` train through
these same pieces:

* :func:`resolve_config` — the YAML entry of an algorithm and env id with overrides, as a :class:`RunConfig`;
  :func:`hyperparameter_keys`, the keys an entry may hold.
* :func:`build_envs` — the native training env inside the entry's wrappers (residual baseline,
  observation features of :mod:`spine_gym.agents.observations`, Lagrangian energy budget,
  ``VecNormalize``), as :class:`TrainingEnvs`; :func:`energy_budget`, the budget in joules.
* :func:`build_model` — the algorithm, new or from a checkpoint (with :func:`load_overrides` applied);
  :func:`action_noise`; :func:`lagrangian_callbacks`, the dual-ascent callback of an energy-budget run.
* :func:`yaml_safe` — a hyperparameter entry as YAML writes it (schedules as ``lin_<x>``).
"""

from __future__ import annotations

import inspect
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise
from stable_baselines3.common.vec_env import VecNormalize

from spine_gym.envs import config_of

from .checkpoints import lagrangian_candidates, load_lagrangian
from .entropy_coef import ENTROPY_ALGOS, checked_ent_coef, set_ent_coef
from .lagrangian import EnergyBudgetVecEnv, EnergyRelabelReplayBuffer, LagrangianCallback
from .observations import feature_specs, feature_vec_env
from .residual import ResidualVecEnv, base_spec
from .runtime import (
    OBSERVATION_KWARGS,
    controller_for,
    make_env,
    validation_scores,
    vecnormalize_candidates,
)
from .vec_env import make_vec_env
from .zoo_config import (
    ENV_ID,
    OFF_POLICY,
    SPECIAL_KEYS,
    algo_class,
    checked_number,
    load_hyperparams,
    preprocess_hyperparams,
)

_SET_BY_FLAGS = ("env", "seed", "device", "verbose", "tensorboard_log")  # arguments of the algorithm


def hyperparameter_keys(algo: str) -> set[str]:
    """The keys a hyperparameter entry of ``algo`` may hold: the arguments of the algorithm's class
    (but those that :func:`build_model` sets from flags) and
    :data:`~spine_gym.agents.zoo_config.SPECIAL_KEYS`."""
    own = set(inspect.signature(algo_class(algo)).parameters) - set(_SET_BY_FLAGS)
    return {k for k in own if not k.startswith("_")} | set(SPECIAL_KEYS)


def yaml_safe(d: dict) -> dict:
    """``d`` as YAML can write it: schedules as ``lin_<x>``, tuples as lists, nested dicts likewise."""
    out = {}
    for k, v in d.items():
        if callable(v):
            v = f"lin_{v.initial:g}" if hasattr(v, "initial") else repr(v)
        elif isinstance(v, tuple):
            v = list(v)
        elif isinstance(v, dict):
            v = yaml_safe(v)
        out[k] = v
    return out


@dataclass
class RunConfig:
    """The resolved settings of one training run (the YAML entry, overrides and flags applied).

    Attributes:
        algo, env_id: the algorithm (:data:`spine_gym.agents.zoo_config.ALGOS`) and the registered env id.
        hp: constructor kwargs of the algorithm (schedules and ``policy_kwargs`` parsed).
        special: the entry's other settings (:data:`spine_gym.agents.zoo_config.SPECIAL_KEYS`, with defaults).
        n_envs, n_timesteps: sub-envs and training steps.
        env_kwargs: the training env's kwargs (the entry's, then the given ones).
    """

    algo: str
    env_id: str
    hp: dict
    special: dict
    n_envs: int
    n_timesteps: int
    env_kwargs: dict


@dataclass
class TrainingEnvs:
    """The wrapped training env (and evaluation env) of a run.

    Attributes:
        env: the outermost training ``VecEnv`` (``VecNormalize`` if the entry normalises).
        eval_env: the evaluation callback's env (same wrappers, frozen statistics) or None.
        budget_env: the Lagrangian energy-budget wrapper, if the entry sets ``energy_budget``.
        meta: the wrappers' settings for ``meta.json`` (what :func:`spine_gym.agents.runtime.load_policy`
            rebuilds: ``residual``, ``obs_integral``, ``obs_history``; ``energy_budget_J``).
    """

    env: object
    eval_env: object | None
    budget_env: EnergyBudgetVecEnv | None
    meta: dict


def resolve_config(
    algo: str,
    env_id: str,
    *,
    n_envs: int = -1,
    n_timesteps: int = -1,
    hyperparams: dict | None = None,
    env_kwargs: dict | None = None,
    conf_file: str | Path | None = None,
) -> RunConfig:
    """The hyperparameter entry of ``env_id`` in ``hyperparams/{algo}.yml`` (or ``conf_file``) with
    ``hyperparams`` overriding it; ``n_envs``/``n_timesteps`` > 0 override the entry's (-1: the
    entry's), ``env_kwargs`` update the entry's. A SAC-family ``ent_coef`` is checked
    (:func:`~spine_gym.agents.entropy_coef.checked_ent_coef`, ValueError)."""
    hp_raw = load_hyperparams(algo, env_id, conf_file)
    hp_raw.update(hyperparams or {})
    hp, special = preprocess_hyperparams(hp_raw)
    if algo in ENTROPY_ALGOS and "ent_coef" in hp:
        hp["ent_coef"] = checked_ent_coef(hp["ent_coef"])
    return RunConfig(
        algo=algo,
        env_id=env_id,
        hp=hp,
        special=special,
        n_envs=n_envs if n_envs > 0 else int(special.get("n_envs", 1)),
        n_timesteps=n_timesteps if n_timesteps > 0 else int(float(special.get("n_timesteps", 1e5))),
        env_kwargs={**special["env_kwargs"], **(env_kwargs or {})},
    )


def build_envs(
    cfg: RunConfig,
    seed: int,
    *,
    eval_env: bool = False,
    vec_env: str = "native",
    trained_agent: str = "",
    resume: bool = False,
    verbose: int = 0,
) -> TrainingEnvs:
    """The training env of ``cfg`` (native vector env seeded ``seed``) inside the entry's wrappers
    (residual, integral and history observations, energy budget, ``VecNormalize``; starting from
    ``trained_agent`` loads its statistics), and with ``eval_env`` the evaluation callback's env.
    ``resume``: ``trained_agent`` is a checkpoint of the run being continued, whose energy budget and
    Lagrange multiplier are restored too (:func:`_budget_env`)."""
    special, env_kwargs, env_id = cfg.special, cfg.env_kwargs, cfg.env_id
    meta: dict = {}  # the wrappers' settings
    env = make_vec_env(env_id, cfg.n_envs, seed=seed, env_kwargs=env_kwargs, kind=vec_env)
    norm = special["normalize"]
    ev = None
    if eval_env:
        ev = make_vec_env(env_id, 1, seed=seed + 1_000_003, env_kwargs=env_kwargs, kind="dummy")
    for wrap in _observation_wrappers(cfg, meta):
        env = wrap(env)
        if ev is not None:
            ev = wrap(ev)
    budget_env = None
    if special["energy_budget"] is not None:
        budget_env = _budget_env(cfg, env, trained_agent if resume else "", verbose)
        env = budget_env
        meta["energy_budget_J"] = budget_env.budget
    if norm is not None:
        if trained_agent:
            stats = checkpoint_vecnormalize(Path(trained_agent))
            env = VecNormalize.load(str(stats), env)
            env.training = True
        else:
            env = VecNormalize(env, gamma=cfg.hp.get("gamma", 0.99), **norm)
        if ev is not None:
            ev = VecNormalize(
                ev,
                training=False,
                norm_reward=False,
                **{k: v for k, v in norm.items() if k != "norm_reward"},
            )
    return TrainingEnvs(env=env, eval_env=ev, budget_env=budget_env, meta=meta)


def _observation_wrappers(cfg: RunConfig, meta: dict) -> list:
    """The entry's wrappers below the energy budget (``venv -> venv``, innermost first), their settings
    put into ``meta``: the residual's baseline (the policy learns a correction on top of the tuned
    controller, :mod:`spine_gym.agents.residual`), then the observation features (the integral of the
    error, then the frame history, :mod:`spine_gym.agents.observations`)."""
    special = cfg.special
    if not special["residual"] and special["obs_integral"] is None and special["obs_history"] is None:
        return []
    wrappers = []
    conf = config_of(cfg.env_id, **cfg.env_kwargs)
    if special["residual"]:
        spec = base_spec(
            special["residual"],
            v_max=conf.v_max,
            dt=conf.control_period,
            temperature_limit=conf.temperature_limit,
            scale=special["residual_scale"],
            env_id=cfg.env_id,
            env_kwargs=cfg.env_kwargs,
            thermal_cutoff=conf.thermal_cutoff,
        )
        meta["residual"] = spec
        wrappers.append(lambda venv: ResidualVecEnv(venv, spec))
    specs = {}
    if special["obs_integral"] is not None or special["obs_history"] is not None:
        probe = make_env(cfg.env_kwargs, env_id=cfg.env_id)  # the features read its spaces
        specs = feature_specs(probe, special)
        probe.close()
    if specs:
        meta |= {key: spec.to_dict() for key, spec in specs.items()}
        wrappers.append(lambda venv: feature_vec_env(venv, specs))
    return wrappers


def _budget_env(cfg: RunConfig, env, checkpoint: str = "", verbose: int = 0) -> EnergyBudgetVecEnv:
    """``env`` inside the Lagrangian energy budget of ``cfg``'s entry; resuming from the run's
    ``checkpoint``, its budget (a ``pid`` budget is not measured again) and multiplier."""
    special = cfg.special
    if checkpoint:
        budget = float(json.loads(lagrangian_candidates(Path(checkpoint))[0].read_text())["budget_J"])
    else:
        budget = energy_budget(
            special["energy_budget"],
            cfg.env_kwargs,
            int(special["budget_episodes"]),
            special["budget_scale"],
            env_id=cfg.env_id,
        )
    budget_env = EnergyBudgetVecEnv(
        env,
        budget,
        config_of(cfg.env_id, **cfg.env_kwargs).energy_reference,
        lam0=float(special["lagrangian_init"]),
        window=int(special["budget_window"]),
    )
    if checkpoint:
        load_lagrangian(budget_env, Path(checkpoint))
    if verbose:
        print(f"energy budget {budget:.1f} J per episode", flush=True)
    return budget_env


def action_noise(cfg: RunConfig, n_actions: int):
    """TD3-style exploration noise of the entry's ``noise_type``/``noise_std`` (None: none)."""
    kind = cfg.special["noise_type"]
    if kind in (None, "none", "None"):
        return None
    if cfg.algo not in OFF_POLICY:
        raise ValueError(f"noise_type is for the off-policy algorithms {OFF_POLICY}, not {cfg.algo!r}")
    mean, sigma = np.zeros(n_actions), float(cfg.special["noise_std"]) * np.ones(n_actions)
    if kind == "normal":
        return NormalActionNoise(mean, sigma)
    if kind == "ornstein-uhlenbeck":
        return OrnsteinUhlenbeckActionNoise(mean, sigma)
    raise ValueError(f"noise_type must be 'normal' or 'ornstein-uhlenbeck', got {kind!r}")


#: hyperparameters a loaded model keeps from its checkpoint: they shape its network
FIXED_ON_LOAD = ("policy_kwargs", "use_sde")


def load_overrides(cfg: RunConfig, given, source: str = "-params/--hyperparams") -> dict:
    """The hyperparameters ``given`` (their keys; e.g. those of the command line) as ``cfg`` resolved
    them, to set on a model loaded from a checkpoint (SB3's ``load`` sets them before it builds its
    rollout or replay buffer and its schedules; :func:`build_model` sets a SAC-family ``ent_coef``
    after it, :mod:`spine_gym.agents.entropy_coef`); ValueError (one line, naming ``source``) for
    one of :data:`FIXED_ON_LOAD`. The entry's other settings (energy budget, observation
    features...) shape the env, which is built anew either way."""
    fixed = sorted(set(given) & set(FIXED_ON_LOAD))
    if fixed:
        raise ValueError(
            f"{source} {', '.join(fixed)} cannot change on a loaded model (its network is the "
            "checkpoint's): drop them, or train a new model"
        )
    return {k: cfg.hp[k] for k in given if k in cfg.hp}


def build_model(
    cfg: RunConfig,
    env,
    seed: int,
    *,
    device: str = "cpu",
    tensorboard_log: str | None = None,
    verbose: int = 0,
    trained_agent: str = "",
    resume: bool = False,
    overrides: dict | None = None,
):
    """The algorithm of ``cfg`` on ``env`` (new, or loaded from the checkpoint ``trained_agent`` with
    the hyperparameters ``overrides`` set on it, :func:`load_overrides`). ``resume``: the checkpoint's
    last observation belongs to the envs of the stopped process, so the model resets ``env`` when it
    starts learning."""
    algo_cls = algo_class(cfg.algo)
    if not trained_agent:
        noise = action_noise(cfg, int(np.prod(env.action_space.shape)))
        extra = {} if noise is None else {"action_noise": noise}
        extra |= relabel_buffer(cfg)
        return algo_cls(
            cfg.special["policy"],
            env,
            seed=seed,
            device=device,
            tensorboard_log=tensorboard_log,
            verbose=verbose,
            **cfg.hp,
            **extra,
        )
    overrides = dict(overrides or {})
    ent_coef = overrides.pop("ent_coef", None) if cfg.algo in ENTROPY_ALGOS else None
    model = algo_cls.load(
        trained_agent, env=env, device=device, tensorboard_log=tensorboard_log, verbose=verbose,
        **overrides,
    )  # fmt: skip
    if ent_coef is not None:  # load keeps the checkpoint's coefficient: set it on the model
        set_ent_coef(model, ent_coef)
    if model.seed != seed:
        # SB3's load seeds with the checkpoint's own seed, so --seed alone did nothing on a resume.
        # Only re-seed when it differs: a second seeding after the network's construction changes
        # the RNG stream, and the same-seed fine-tunes in spine_gym/agents/policies/COMMANDS.md must reproduce.
        model.seed = seed
        model.set_random_seed(seed)
    replay = Path(trained_agent).with_name("replay_buffer.pkl")
    if cfg.algo in OFF_POLICY and replay.exists():
        model.load_replay_buffer(str(replay))
    if resume:
        model._last_obs = None  # SB3's learn resets the env when there is no last observation
    return model


def relabel_buffer(cfg: RunConfig) -> dict:
    """``replay_buffer_class`` and its kwargs of an energy-budget run with ``budget_relabel``
    (:class:`spine_gym.agents.lagrangian.EnergyRelabelReplayBuffer`; empty dict otherwise)."""
    relabel = cfg.special["budget_relabel"]
    if relabel not in (True, False):
        raise ValueError(f"budget_relabel must be true or false, got {relabel!r}")
    if not relabel:
        return {}
    if cfg.special["energy_budget"] is None or cfg.algo not in OFF_POLICY:
        raise ValueError(f"budget_relabel is for the off-policy algorithms {OFF_POLICY} with an energy_budget")
    energy_ref = config_of(cfg.env_id, **cfg.env_kwargs).energy_reference
    return {"replay_buffer_class": EnergyRelabelReplayBuffer, "replay_buffer_kwargs": {"energy_ref": energy_ref}}


def lagrangian_callbacks(cfg: RunConfig, envs: TrainingEnvs, verbose: int = 0) -> list:
    """The dual-ascent callback of an energy-budget run (empty list otherwise)."""
    if envs.budget_env is None:
        return []
    eta = float(cfg.special["lagrangian_lr"])
    return [LagrangianCallback(envs.budget_env, eta=eta, verbose=verbose)]


def energy_budget(
    spec, env_kwargs: dict, n_episodes: int, scale: float = 1.0, env_id: str = ENV_ID
) -> float:
    """The energy budget per episode [J]: ``scale`` × a number as given, or ``"pid"``: ``scale`` ×
    the tuned PID's mean energy on ``n_episodes`` validation episodes of ``env_id`` with the training
    distribution ``env_kwargs``."""
    message = f"budget_scale must be a number in (0, 2], got {scale!r}"
    scale = checked_number(scale, lambda x: 0.0 < x <= 2.0, message)
    if spec == "pid":  # the PID as evaluated: the task's kwargs, the env's default observation
        kw = {k: v for k, v in env_kwargs.items() if k not in OBSERVATION_KWARGS}
        pid = controller_for("pid", env_id, kw)
        return scale * validation_scores(pid, n_episodes, kw, env_id)[1]
    message = f"energy_budget must be 'pid' or a number of joules > 0, got {spec!r}"
    return scale * checked_number(spec, lambda x: x > 0.0, message)


def checkpoint_vecnormalize(ckpt: Path) -> Path:
    """``VecNormalize`` statistics saved with a checkpoint (or a run folder's final ones)."""
    if not ckpt.exists():
        raise ValueError(f"checkpoint {ckpt} does not exist")
    candidates = vecnormalize_candidates(ckpt)
    for c in candidates:
        if c.exists():
            return c
    raise ValueError(
        f"no VecNormalize statistics found beside {ckpt} (looked for {[str(c) for c in candidates]})"
    )
