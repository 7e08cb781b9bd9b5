"""Train PPO, SAC, TD3 or TQC on ``SmaSpine-v0`` or a spatial spine (``--env SmaSpine3D-v0``, ...).

RL-Zoo-style CLI (``spine-gym train``; the conventions of :mod:`spine_gym.cli_conventions`).

Example::

    spine-gym train --algo ppo -n 300000 --seed 1 --n-envs 8 -o logs --env-kwargs episode_duration=60.0
    python -m spine_gym.agents.train --algo ppo -n 300000 --seed 1 --n-envs 8 -f logs \\
        --env-kwargs episode_duration:60.0

Every argument is checked before the run folder is made (the env id, the env kwargs by building one
env, the hyperparameter keys, the files to read): a bad one is a one-line usage error, exit status 2.

Hyperparameters come from ``spine_gym/agents/hyperparams/{algo}.yml`` (entry keyed by the env id, RL Zoo's
format: ``n_envs``, ``n_timesteps``, ``policy``, ``normalize``, ``policy_kwargs`` as a
``dict(...)`` string, ``lin_<x>`` schedules, plus an optional ``env_kwargs`` dict); command-line
flags override them (``-params key:value``). The training env is the package's native vector env
(one jitted batch step for all sub-envs) behind an SB3 ``VecEnv`` adapter, wrapped in
``VecMonitor`` and ``VecNormalize``.

Each run gets a folder ``<log folder>/<algo>/<env id>_<k>/`` holding ``command.txt`` (the exact
command line), ``args.yml`` (parsed arguments), ``config.yml`` (the hyperparameters used),
``meta.json`` (what :func:`spine_gym.agents.runtime.load_policy` needs), ``checkpoints/`` (model,
``VecNormalize`` and Lagrange multiplier every ``--save-freq`` steps), ``best_model.zip`` (by the
evaluation callback), ``best_vecnormalize.pkl`` (the statistics at that moment), ``evaluations.npz``,
TensorBoard logs in ``tb/`` and the final ``model.zip`` + ``vecnormalize.pkl`` (+ ``lagrangian.json`` with an
energy budget).

Resuming an interrupted run (a crash, ``kill -9``)::

    python -m spine_gym.agents.train --resume logs/ppo/SmaSpine-v0_3            # its newest checkpoint
    python -m spine_gym.agents.train --resume logs/ppo/SmaSpine-v0_3/checkpoints/rl_model_200000_steps.zip

continues the run in its own folder with the run's command line (``command.txt``'s first line; flags
given with ``--resume`` are appended and win): the checkpoint's weights, optimiser state,
``VecNormalize`` statistics, step counter and Lagrange multiplier (:mod:`spine_gym.agents.checkpoints`), up to
the run's ``-n`` steps in all, so learning-rate and clip schedules and later checkpoints fall on the
steps of an uninterrupted run. The envs restart their episodes from ``--seed`` and the random streams
are seeded afresh, so the result is not the uninterrupted run's, but two resumes from one checkpoint
give the same weights (``tests/test_train_resume.py``). Evaluations up to the checkpoint stay in
``evaluations.npz`` and ``best_model.zip`` is replaced only by a better one.
``-i path/to/model.zip`` is a fine-tune instead: a new run folder, ``-n`` more steps, the model's
normalisation statistics and step counter, the multiplier from ``lagrangian_init``.

The pieces are public for :mod:`spine_gym.agents.benchmark`, which trains through the same path:
:func:`resolve_config` (the YAML entry with overrides), :func:`build_envs` (the wrapped training
env), :func:`build_model` and :func:`lagrangian_callbacks`. ``noise_type: normal`` (or
``ornstein-uhlenbeck``) with ``noise_std`` gives the off-policy algorithms exploration noise (TD3).

``residual: pid`` in the hyperparameters (or ``-params residual:pid``) trains a residual policy on
top of the tuned PID (:mod:`spine_gym.agents.residual`; ``residual_scale`` sets the authority of the
correction, default 1); the baseline's settings go into ``meta.json`` with the model.

``energy_budget: pid`` (or a number of joules) replaces the reward's fixed energy weight by a
Lagrange multiplier that dual ascent adjusts after every rollout so that the mean episode energy
meets the budget (:mod:`spine_gym.agents.lagrangian`); ``pid`` is the tuned PID's mean energy on
``budget_episodes`` validation episodes of the training distribution (with the env's default
observation: a longer ``target_preview`` of the policy is not given to the PID). ``lagrangian_init`` and
``lagrangian_lr`` set the initial multiplier and its step, ``budget_window`` how many finished
episodes the mean energy of the dual step is taken over (default 32; 0: the episodes finished
since the previous dual step), ``budget_scale`` (default 1, in (0, 2]) multiplies the budget (e.g. 0.93
with ``pid``: 7 % under the PID's energy); the budget goes into ``meta.json``.

``obs_integral: <τ [s] or inf>`` appends the (leaky) integral of the tracking error to the
observation (:mod:`spine_gym.agents.observations`; ``obs_integral_limit`` its clip, default 300 deg s); its
settings go into ``meta.json``, so :func:`spine_gym.agents.runtime.load_policy` rebuilds it for evaluation.
``obs_history: <k>`` appends the k earlier frames of the measured angle and the previous action
(:mod:`spine_gym.agents.observations`), after the integral; likewise stored and rebuilt.
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import shlex
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import yaml
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, EvalCallback
from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import VecNormalize

from spine_gym.cli_conventions import (
    Parser,
    add_env,
    add_env_kwargs,
    add_out,
    add_progress,
    add_workers,
    check_env_kwargs,
    check_file,
    check_keys,
    first_line,
)

from .checkpoints import (
    RunCheckpointCallback,
    checkpoint_steps,
    lagrangian_candidates,
    latest_checkpoint,
    load_lagrangian,
    restore_eval_history,
    save_lagrangian,
)
from .envs import make_vec_env
from .lagrangian import EnergyBudgetVecEnv, LagrangianCallback
from .observations import HistoryObsVecEnv, HistorySpec, IntegralObsVecEnv, IntegralSpec
from .residual import ResidualVecEnv, base_spec
from .runtime import (
    OBSERVATION_KWARGS,
    build_controller,
    env_temperature_limit,
    make_env,
    validation_scores,
    vecnormalize_candidates,
)
from .zoo_config import (
    ALGOS,
    ENV_ID,
    OFF_POLICY,
    SPECIAL_KEYS,
    StoreDict,
    algo_class,
    load_hyperparams,
    preprocess_hyperparams,
)

EXAMPLES = (
    "spine-gym train --algo ppo -n 300000 --seed 1 --n-envs 8 -o logs --env-kwargs episode_duration=60.0",
    "spine-gym train --algo sac --env SmaSpine-v1 -params learning_starts=1000 batch_size=256",
    "spine-gym train --resume logs/ppo/SmaSpine-v0_3           # an interrupted run, from its newest checkpoint",
    "python -m spine_gym.agents.train --algo ppo -f logs        # the same module, RL Zoo's -f",
)


def build_parser(prog: str = "python -m spine_gym.agents.train") -> argparse.ArgumentParser:
    p = Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES)
    p.add_argument("--algo", choices=ALGOS, help="RL algorithm (required unless --resume)")
    add_env(p, default=ENV_ID)
    p.add_argument(
        "-n", "--n-timesteps", type=int, default=-1, help="training steps (default: from the YAML)"
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (env sampling, network init)")
    p.add_argument("--n-envs", type=int, default=-1, help="parallel sub-envs (default: from the YAML)")
    add_env_kwargs(p)
    p.add_argument(
        "-params", "--hyperparams", nargs="+", action=StoreDict, default={}, metavar="KEY=VALUE",
        help="override hyperparameters of the YAML entry, key=value (key:value also accepted)",
    )  # fmt: skip
    p.add_argument(
        "-conf",
        "--conf-file",
        type=str,
        default=None,
        help="hyperparameter YAML (default: spine_gym/agents/hyperparams/<algo>.yml)",
    )
    add_out(
        p, "-f", "--log-folder", dest="log_folder", default="logs",
        help="output folder: runs go to <out>/<algo>/<env id>_<k>/ (-f/--log-folder: RL Zoo's name)",
    )  # fmt: skip
    p.add_argument(
        "-i",
        "--trained-agent",
        type=str,
        default="",
        help="fine-tune this model .zip in a new run folder (-n more steps)",
    )
    p.add_argument(
        "--resume",
        type=str,
        default="",
        metavar="RUN",
        help="continue an interrupted run in its folder: the run folder (its newest checkpoint) or one "
        "of its checkpoints/rl_model_<n>_steps.zip; reuses the run's command line (flags given here "
        "are appended to it)",
    )
    p.add_argument("--eval-freq", type=int, default=25_000, help="evaluate every N env steps (<= 0: never)")
    p.add_argument("--eval-episodes", type=int, default=8, help="episodes per evaluation")
    p.add_argument("--save-freq", type=int, default=50_000, help="checkpoint every N env steps (<= 0: never)")
    p.add_argument(
        "--vec-env", choices=("native", "dummy"), default="native", help="vector env implementation"
    )
    add_progress(p, "-P", default=False)
    p.add_argument("--no-tensorboard", action="store_true", help="do not write TensorBoard logs")
    add_workers(p, "--torch-threads", dest="torch_threads", help="torch intra-op threads")
    p.add_argument("--device", default="cpu", help="torch device (default: %(default)s)")
    p.add_argument("-v", "--verbose", type=int, default=1, help="verbosity 0/1/2")
    return p


def _next_run_folder(log_folder: Path, algo: str, env_id: str) -> Path:
    base = log_folder / algo
    base.mkdir(parents=True, exist_ok=True)
    k = 1 + max(
        [
            int(p.name.rsplit("_", 1)[1])
            for p in base.glob(f"{env_id}_*")
            if p.name.rsplit("_", 1)[1].isdigit()
        ]
        or [0]
    )
    folder = base / f"{env_id}_{k}"
    folder.mkdir()
    return folder


def _yaml_safe(d: dict) -> dict:
    out = {}
    for k, v in d.items():
        if callable(v):
            v = f"lin_{v.initial:g}" if hasattr(v, "initial") else repr(v)
        elif isinstance(v, tuple):
            v = list(v)
        elif isinstance(v, dict):
            v = _yaml_safe(v)
        out[k] = v
    return out


def _resume_target(path: Path) -> tuple[Path, Path]:
    """(run folder, checkpoint) of ``--resume path``: a run folder and its newest complete
    checkpoint, or a checkpoint ``<run>/checkpoints/rl_model_<n>_steps.zip`` and its run."""
    if path.is_dir():
        run, ckpt = path, latest_checkpoint(path)
        if ckpt is None:
            raise ValueError(f"--resume: no checkpoint in {path / 'checkpoints'} to resume from")
    elif checkpoint_steps(path) is not None and path.parent.name == "checkpoints" and path.exists():
        run, ckpt = path.parent.parent, path
    else:
        raise ValueError(
            f"--resume must be a run folder or its checkpoints/rl_model_<n>_steps.zip, got {path}"
        )
    if not (run / "command.txt").exists() or not (run / "meta.json").exists():
        raise ValueError(f"--resume: {run} is not a run folder of spine_gym.agents.train (no command.txt / meta.json)")
    return run, ckpt


def _parse(argv: list[str] | None, prog: str = "python -m spine_gym.agents.train"):
    """(arguments, argv, resume target or None, run config). With ``--resume`` the run's first command
    line comes first and this one's flags after it, so they override. Every argument is checked here,
    before a run folder exists: a bad one is a one-line usage error (exit status 2)."""
    parser = build_parser(prog)
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    resume = None
    try:
        if args.resume:
            if args.trained_agent:
                raise ValueError("--resume continues a run from its own checkpoint: drop -i")
            resume = _resume_target(Path(args.resume))
            first = shlex.split((resume[0] / "command.txt").read_text().splitlines()[0])
            args = parser.parse_args([*first[3:], *argv])  # first[:3]: python -m spine_gym.agents.train
        if args.algo is None:
            raise ValueError("--algo is required (or --resume RUN)")
        cfg = _checked_config(args, str(resume[1]) if resume else args.trained_agent)
    except ValueError as e:
        parser.error(str(e))
    return args, argv, resume, cfg


_SET_BY_FLAGS = ("env", "seed", "device", "verbose", "tensorboard_log")  # arguments of the algorithm


def hyperparameter_keys(algo: str) -> set[str]:
    """The keys a hyperparameter entry of ``algo`` may hold: the arguments of the algorithm's class
    (but those that :func:`build_model` sets from flags) and :data:`~spine_gym.agents.zoo_config.SPECIAL_KEYS`."""
    own = set(inspect.signature(algo_class(algo)).parameters) - set(_SET_BY_FLAGS)
    return {k for k in own if not k.startswith("_")} | set(SPECIAL_KEYS)


def _checked_config(args, checkpoint: str) -> RunConfig:
    """The run's configuration, with every argument checked (ValueError, one line): step counts,
    the files to read (``checkpoint``: the model to start from), the hyperparameter keys and
    values, and the env kwargs (one env is built)."""
    for name, v in (("--n-envs", args.n_envs), ("-n", args.n_timesteps)):
        if v == 0 or v < -1:
            raise ValueError(f"{name} must be a positive integer, got {v}")
    if args.trained_agent:
        check_file(args.trained_agent, "-i/--trained-agent")
    if args.conf_file:
        check_file(args.conf_file, "-conf/--conf-file")
    check_keys(args.hyperparams, hyperparameter_keys(args.algo), "-params/--hyperparams")
    try:
        cfg = resolve_config(
            args.algo,
            args.env,
            n_envs=args.n_envs,
            n_timesteps=args.n_timesteps,
            hyperparams=args.hyperparams,
            env_kwargs=args.env_kwargs,
            conf_file=args.conf_file,
        )
    except (ValueError, TypeError, SyntaxError, NameError) as e:
        raise ValueError(f"hyperparameters of {args.algo} on {args.env}: {first_line(e)}") from None
    check_env_kwargs(args.env, cfg.env_kwargs)
    if checkpoint and cfg.special["normalize"] is not None:
        _checkpoint_vecnormalize(Path(checkpoint))
    return cfg


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
    entry's), ``env_kwargs`` update the entry's."""
    hp_raw = load_hyperparams(algo, env_id, conf_file)
    hp_raw.update(hyperparams or {})
    hp, special = preprocess_hyperparams(hp_raw)
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
    meta: dict = {}
    env = make_vec_env(env_id, cfg.n_envs, seed=seed, env_kwargs=env_kwargs, kind=vec_env)
    norm = special["normalize"]
    ev = None
    if eval_env:
        ev = make_vec_env(env_id, 1, seed=seed + 1_000_003, env_kwargs=env_kwargs, kind="dummy")
    if special["residual"]:
        # residual RL: the policy learns a correction on top of the tuned baseline (spine_gym.agents.residual)
        probe = make_env(env_kwargs, env_id=env_id)
        spec = base_spec(
            special["residual"],
            v_max=probe.v_max,
            dt=probe.control_period,
            temperature_limit=env_temperature_limit(probe),
            scale=special["residual_scale"],
            env_id=env_id,
            env_kwargs=env_kwargs,
        )
        probe.close()
        meta["residual"] = spec
        env = ResidualVecEnv(env, spec)
        if ev is not None:
            ev = ResidualVecEnv(ev, spec)
    if special["obs_integral"] is not None:
        # the integral-of-error observation (spine_gym.agents.observations), above the residual's baseline
        probe = make_env(env_kwargs, env_id=env_id)
        ispec = IntegralSpec.from_env(probe, special["obs_integral"], float(special["obs_integral_limit"]))
        probe.close()
        meta["obs_integral"] = ispec.to_dict()
        env = IntegralObsVecEnv(env, ispec)
        if ev is not None:
            ev = IntegralObsVecEnv(ev, ispec)
    if special["obs_history"] is not None:
        # the frame history (spine_gym.agents.observations), after the integral
        probe = make_env(env_kwargs, env_id=env_id)
        hspec = HistorySpec.from_env(probe, special["obs_history"])
        probe.close()
        meta["obs_history"] = hspec.to_dict()
        env = HistoryObsVecEnv(env, hspec)
        if ev is not None:
            ev = HistoryObsVecEnv(ev, hspec)
    budget_env = None
    if special["energy_budget"] is not None:
        budget_env = _budget_env(cfg, env, trained_agent if resume else "", verbose)
        env = budget_env
        meta["energy_budget_J"] = budget_env.budget
    if norm is not None:
        if trained_agent:
            stats = _checkpoint_vecnormalize(Path(trained_agent))
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
    probe = make_env(cfg.env_kwargs, env_id=cfg.env_id)
    budget_env = EnergyBudgetVecEnv(
        env,
        budget,
        probe.config.energy_reference,
        lam0=float(special["lagrangian_init"]),
        window=int(special["budget_window"]),
    )
    probe.close()
    if checkpoint:
        load_lagrangian(budget_env, Path(checkpoint))
    if verbose:
        print(f"energy budget {budget:.1f} J per episode", flush=True)
    return budget_env


def _action_noise(cfg: RunConfig, n_actions: int):
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
):
    """The algorithm of ``cfg`` on ``env`` (new, or loaded from the checkpoint ``trained_agent``).
    ``resume``: the checkpoint's last observation belongs to the envs of the stopped process, so the
    model resets ``env`` when it starts learning."""
    algo_cls = algo_class(cfg.algo)
    if not trained_agent:
        noise = _action_noise(cfg, int(np.prod(env.action_space.shape)))
        extra = {} if noise is None else {"action_noise": noise}
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
    model = algo_cls.load(
        trained_agent, env=env, device=device, tensorboard_log=tensorboard_log, verbose=verbose
    )
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


def lagrangian_callbacks(cfg: RunConfig, envs: TrainingEnvs, verbose: int = 0) -> list:
    """The dual-ascent callback of an energy-budget run (empty list otherwise)."""
    if envs.budget_env is None:
        return []
    eta = float(cfg.special["lagrangian_lr"])
    return [LagrangianCallback(envs.budget_env, eta=eta, verbose=verbose)]


def _start_run(args, argv: list[str], cfg: RunConfig, resume: tuple[Path, Path] | None) -> tuple[Path, dict]:
    """(run folder, meta): a new folder with ``command.txt``, ``args.yml``, ``config.yml``; or with
    ``resume`` the run's folder, this command line appended to ``command.txt`` and a new entry in
    ``meta["resumes"]``."""
    command = "python -m spine_gym.agents.train " + " ".join(shlex.quote(a) for a in argv)
    if resume:
        run = resume[0]
        with open(run / "command.txt", "a") as f:
            f.write(command + "\n")
        meta = json.loads((run / "meta.json").read_text())
        meta.setdefault("resumes", []).append({"checkpoint": str(resume[1]), "command": command})
        return run, meta
    n_envs, n_timesteps = cfg.n_envs, cfg.n_timesteps
    run = _next_run_folder(Path(args.log_folder), args.algo, args.env)
    (run / "command.txt").write_text(command + "\n")
    (run / "args.yml").write_text(
        yaml.safe_dump({**vars(args), "n_envs": n_envs, "n_timesteps": n_timesteps})
    )
    entry = {
        **cfg.hp,
        **cfg.special,
        "n_envs": n_envs,
        "n_timesteps": n_timesteps,
        "env_kwargs": cfg.env_kwargs,
    }
    (run / "config.yml").write_text(yaml.safe_dump({args.env: _yaml_safe(entry)}))
    meta = {
        "algo": args.algo,
        "env_id": args.env,
        "env_kwargs": cfg.env_kwargs,
        "seed": args.seed,
        "n_envs": n_envs,
        "n_timesteps": n_timesteps,
        "command": command,
        "resumed_from": args.trained_agent or None,
    }
    return run, meta


def _eval_callback(args, run: Path, eval_env, normalized: bool, n_envs: int, resumed_at: int | None):
    """The evaluation callback of the run (best model and its ``VecNormalize`` statistics into
    ``run``); ``resumed_at``: the checkpoint's step, whose earlier evaluations it keeps."""
    on_best = None
    if normalized:
        # keep the normalisation statistics of the moment the best model was saved (RL Zoo's
        # SaveVecNormalizeCallback): the final ones differ from those the best model saw
        class _SaveBestVecNormalize(BaseCallback):
            def _on_step(self) -> bool:
                self.model.get_vec_normalize_env().save(str(run / "best_vecnormalize.pkl"))
                return True

        on_best = _SaveBestVecNormalize()
    evaluation = EvalCallback(
        eval_env,
        callback_on_new_best=on_best,
        eval_freq=max(1, args.eval_freq // n_envs),
        n_eval_episodes=args.eval_episodes,
        best_model_save_path=str(run),
        log_path=str(run),
        deterministic=True,
        verbose=args.verbose,
    )
    if resumed_at is not None:
        restore_eval_history(evaluation, run, resumed_at)
    return evaluation


def train(argv: list[str] | None = None, prog: str = "python -m spine_gym.agents.train") -> Path:
    """Run the CLI with ``argv`` (default ``sys.argv[1:]``; ``prog``: the name in its messages);
    returns the run folder."""
    args, argv, resume, cfg = _parse(argv, prog)
    ckpt = str(resume[1]) if resume else args.trained_agent  # the model to load, if any
    os.environ.setdefault("OMP_NUM_THREADS", str(args.torch_threads))
    torch.set_num_threads(max(1, args.torch_threads))
    set_random_seed(args.seed)
    run, meta = _start_run(args, argv, cfg, resume)
    envs = build_envs(
        cfg,
        args.seed,
        eval_env=args.eval_freq > 0,
        vec_env=args.vec_env,
        trained_agent=ckpt,
        resume=resume is not None,
        verbose=args.verbose,
    )
    meta.update(envs.meta)
    env, eval_env, norm = envs.env, envs.eval_env, cfg.special["normalize"]
    tb = None if args.no_tensorboard else str(run / "tb")
    model = build_model(
        cfg, env, args.seed, device=args.device, tensorboard_log=tb, verbose=args.verbose,
        trained_agent=ckpt, resume=resume is not None,
    )  # fmt: skip
    if resume:
        start = int(meta.get("start_timesteps", 0))
    else:
        start = int(model.num_timesteps)  # 0, or the fine-tuned model's count
        meta["start_timesteps"] = start
    # up to the run's -n steps in all: a resume trains the rest, a fine-tune -n more
    remaining = max(0, start + cfg.n_timesteps - int(model.num_timesteps))

    callbacks = lagrangian_callbacks(cfg, envs, args.verbose)
    if args.save_freq > 0:
        save_freq = max(1, args.save_freq // cfg.n_envs)
        callbacks.append(
            RunCheckpointCallback(run / "checkpoints", save_freq, start, envs.budget_env, args.verbose)
        )
    if eval_env is not None:
        resumed_at = int(model.num_timesteps) if resume else None
        callbacks.append(_eval_callback(args, run, eval_env, norm is not None, cfg.n_envs, resumed_at))
    segment = meta["resumes"][-1] if resume else meta
    segment["start_step"] = int(model.num_timesteps)
    if envs.budget_env is not None:
        segment["lagrangian_start"] = envs.budget_env.lam
    (run / "meta.json").write_text(json.dumps(meta, indent=2))
    t0, c0 = time.time(), time.process_time()
    model.learn(
        total_timesteps=remaining,
        callback=CallbackList(callbacks),
        progress_bar=args.progress,
        reset_num_timesteps=not ckpt,
        tb_log_name=args.algo,
    )
    wall, cpu = time.time() - t0, time.process_time() - c0
    model.save(run / "model.zip")
    if norm is not None:
        env.save(str(run / "vecnormalize.pkl"))
    segment.update({"train_wall_time_s": round(wall, 1), "train_cpu_time_s": round(cpu, 1)})
    meta["total_timesteps"] = int(model.num_timesteps)
    if envs.budget_env is not None:
        meta["lagrangian_final"] = envs.budget_env.lam
        save_lagrangian(envs.budget_env, run / "lagrangian.json")
    (run / "meta.json").write_text(json.dumps(meta, indent=2))
    if args.verbose:
        print(f"saved {run / 'model.zip'} after {model.num_timesteps} steps in {wall:.0f} s")
    env.close()
    if eval_env is not None:
        eval_env.close()
    return run


def energy_budget(
    spec, env_kwargs: dict, n_episodes: int, scale: float = 1.0, env_id: str = ENV_ID
) -> float:
    """The energy budget per episode [J]: ``scale`` × a number as given, or ``"pid"``: ``scale`` ×
    the tuned PID's mean energy on ``n_episodes`` validation episodes of ``env_id`` with the training
    distribution ``env_kwargs``."""
    try:
        scale = float(scale)
    except (TypeError, ValueError):
        raise ValueError(f"budget_scale must be a number in (0, 2], got {scale!r}") from None
    if not 0.0 < scale <= 2.0:
        raise ValueError(f"budget_scale must be a number in (0, 2], got {scale!r}")
    if spec == "pid":  # the PID as evaluated: the task's kwargs, the env's default observation
        kw = {k: v for k, v in env_kwargs.items() if k not in OBSERVATION_KWARGS}
        probe = make_env(kw, env_id=env_id)
        pid = build_controller("pid", probe)
        probe.close()
        return scale * validation_scores(pid, n_episodes, kw, env_id)[1]
    try:
        value = float(spec)
    except (TypeError, ValueError):
        raise ValueError(f"energy_budget must be 'pid' or a number of joules > 0, got {spec!r}") from None
    if not value > 0.0:
        raise ValueError(f"energy_budget must be 'pid' or a number of joules > 0, got {spec!r}")
    return scale * value


def _checkpoint_vecnormalize(ckpt: Path) -> Path:
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


def main(argv: list[str] | None = None, prog: str = "python -m spine_gym.agents.train") -> int:
    """The command line (``spine-gym train``); exit status 0 (usage errors exit with 2)."""
    train(argv, prog)
    return 0


if __name__ == "__main__":
    sys.exit(main())
