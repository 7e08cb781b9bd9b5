"""Train PPO, SAC, TD3, TQC, CrossQ, DroQ or SBX SAC on ``SmaSpine-v1`` or another spine env (``--env ...``).

RL-Zoo-style CLI (``spine-gym train``; the conventions of :mod:`spine_gym.cli_conventions`).

Example::

    spine-gym train --algo ppo -n 300000 --seed 1 --n-envs 8 -o logs --env-kwargs episode_duration=60.0
    python -m spine_gym.agents.train --algo ppo -n 300000 --seed 1 --n-envs 8 -f logs \\
        --env-kwargs episode_duration:60.0

Every argument is checked before the run folder is made (the env id, the env kwargs by building one
env, the hyperparameter keys, the files to read, that ``-o`` can be written, that an ``-i`` model was
trained on ``--env``): a bad one is a one-line usage error, exit status 2. Without ``--env`` the run
uses ``-i``'s env (its ``meta.json``), else ``SmaSpine-v1``.

By default it prints one progress line and, at the end, where the model went and the command that
evaluates it; ``-v`` adds Stable-Baselines3's tables (``-v 2``: its debug output).

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
give the same weights (``tests/agents/test_train_resume.py``). Evaluations up to the checkpoint stay in
``evaluations.npz`` and ``best_model.zip`` is replaced only by a better one.
``-i path/to/model.zip`` is a fine-tune instead: a new run folder, ``-n`` more steps, the model's
normalisation statistics and step counter, the multiplier from ``lagrangian_init``, and the
hyperparameters given with ``-params`` set on the loaded model (rollout length, batch size,
learning rate, SAC's ``ent_coef`` learned or fixed as :mod:`spine_gym.agents.entropy_coef` says...; not
those that make its network, ``policy_kwargs`` and ``use_sde``: a usage error).

The run is built by :mod:`spine_gym.agents.training` (shared with :mod:`spine_gym.agents.benchmark`):
:func:`~spine_gym.agents.training.resolve_config` (the YAML entry with overrides),
:func:`~spine_gym.agents.training.build_envs` (the wrapped training env),
:func:`~spine_gym.agents.training.build_model` and :func:`~spine_gym.agents.training.lagrangian_callbacks`.
``noise_type: normal`` (or ``ornstein-uhlenbeck``) with ``noise_std`` gives the off-policy algorithms
exploration noise (TD3).

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
import json
import os
import shlex
import sys
import time
from pathlib import Path

import torch
import yaml
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, EvalCallback
from stable_baselines3.common.utils import set_random_seed

from spine_gym.cli_conventions import PROG as SPINE_GYM
from spine_gym.cli_conventions import (
    ENV_IDS,
    Parser,
    add_env,
    add_env_kwargs,
    add_out,
    add_progress,
    add_workers,
    check_env_kwargs,
    check_file,
    check_keys,
    check_out_dir,
    first_line,
    module_prog,
    usage_errors,
)

from .checkpoints import (
    RunCheckpointCallback,
    checkpoint_steps,
    latest_checkpoint,
    restore_eval_history,
    save_lagrangian,
)
from .training import (
    FIXED_ON_LOAD,
    RunConfig,
    build_envs,
    build_model,
    checkpoint_vecnormalize,
    hyperparameter_keys,
    lagrangian_callbacks,
    load_overrides,
    resolve_config,
    yaml_safe,
)
from .policy_files import check_policy_env, trained_env_id
from .zoo_config import ALGOS, DEFAULT_ENV_ID, ENV_ID, StoreDict

#: this command's name as ``python -m <module>`` (``spine-gym <command>`` passes its own ``prog``)
PROG = module_prog(__spec__.name)

EXAMPLES = """
spine-gym train --algo ppo -n 4000 --seed 1 --n-envs 8 --save-freq 2000 -o logs --env-kwargs episode_duration=60.0
spine-gym train --algo sac --env SmaSpine-v1 -n 2000 -params learning_starts=1000 batch_size=256
spine-gym train --algo crossq --env SmaSpineEasy-v2 -n 30000  # a JAX learner (pip install 'spine_gym[jax]')
spine-gym train --resume logs/ppo/SmaSpine-v2_1           # an interrupted run, from its newest checkpoint
python -m spine_gym.agents.train --algo ppo -n 2000 -f logs        # the same module, RL Zoo's -f
"""


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    p = Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES)
    p.add_argument("--algo", choices=ALGOS, help="RL algorithm (required unless --resume)")
    add_env(p, help=f"environment id (default: -i's env, else {DEFAULT_ENV_ID}), one of: " + ", ".join(ENV_IDS))
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
    p.add_argument(
        "-v", "--verbose", type=int, nargs="?", const=1, default=0, metavar="LEVEL",
        help="Stable-Baselines3's output: -v its tables (1), -v 2 its debug output (default: 0, a progress line)",
    )  # fmt: skip
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


def _parse(argv: list[str] | None, prog: str = PROG):
    """(arguments, argv, resume target or None, run config). With ``--resume`` the run's first command
    line comes first and this one's flags after it, so they override. Every argument is checked here,
    before a run folder exists: a bad one is a one-line usage error (exit status 2)."""
    parser = build_parser(prog)
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    resume = None
    with usage_errors(parser):
        if args.resume:
            if args.trained_agent:
                raise ValueError("--resume continues a run from its own checkpoint: drop -i")
            resume = _resume_target(Path(args.resume))
            first = shlex.split((resume[0] / "command.txt").read_text().splitlines()[0])
            args = parser.parse_args([*first[3:], *argv])  # first[:3]: python -m spine_gym.agents.train
        if args.algo is None:
            raise ValueError("--algo is required (or --resume RUN)")
        args.env = _resolved_env(args, resume)
        cfg = _checked_config(args, str(resume[1]) if resume else args.trained_agent)
        check_out_dir(resume[0] if resume else args.log_folder, "--resume" if resume else "-o/--out")
    return args, argv, resume, cfg


def _resolved_env(args, resume: tuple[Path, Path] | None) -> str:
    """``--env``, else the env of the run resumed or of the ``-i`` model (their ``meta.json``),
    else :data:`DEFAULT_ENV_ID`."""
    if args.env:
        return args.env
    if resume:
        return json.loads((resume[0] / "meta.json").read_text()).get("env_id", ENV_ID)
    if args.trained_agent and Path(args.trained_agent).exists():
        return trained_env_id(args.trained_agent) or DEFAULT_ENV_ID
    return DEFAULT_ENV_ID


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
    if args.trained_agent:
        check_policy_env(args.trained_agent, args.env, "-i/--trained-agent", cfg.env_kwargs)
        load_overrides(cfg, args.hyperparams)  # what cannot change on the loaded model
    if checkpoint and cfg.special["normalize"] is not None:
        checkpoint_vecnormalize(Path(checkpoint))
    return cfg


def _start_run(args, argv: list[str], cfg: RunConfig, resume: tuple[Path, Path] | None) -> tuple[Path, dict]:
    """(run folder, meta): a new folder with ``command.txt``, ``args.yml``, ``config.yml``; or with
    ``resume`` the run's folder, this command line appended to ``command.txt`` and a new entry in
    ``meta["resumes"]``."""
    command = f"{PROG} " + " ".join(shlex.quote(a) for a in argv)
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
    (run / "config.yml").write_text(yaml.safe_dump({args.env: yaml_safe(entry)}))
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


class ProgressLine(BaseCallback):
    """One line of progress on stdout: rewritten in place on a terminal, else printed at each
    quarter of the run."""

    def __init__(self, total: int, start: int):
        super().__init__()
        self.total, self.start, self.t0 = max(1, total), start, time.perf_counter()
        self.tty, self.shown = sys.stdout.isatty(), 0

    def _on_training_start(self) -> None:
        self.t0 = time.perf_counter()

    def _line(self) -> str:
        done = min(self.num_timesteps - self.start, self.total)
        return f"training: {done}/{self.total} steps ({100 * done // self.total} %), {time.perf_counter() - self.t0:.0f} s"

    def _on_step(self) -> bool:
        done = min(self.num_timesteps - self.start, self.total)  # the last rollout may run past -n
        if self.tty and done % 512 < self.training_env.num_envs:
            print("\r" + self._line(), end="", flush=True)
        elif not self.tty and 4 * done // self.total > self.shown:
            self.shown = 4 * done // self.total
            print(self._line(), flush=True)
        return True

    def _on_training_end(self) -> None:
        if self.tty or self.shown < 4:
            print(("\r" if self.tty else "") + self._line(), flush=True)


def _next_step(run: Path, args) -> str:
    """The command that evaluates the run's model."""
    return f"{SPINE_GYM} evaluate --models {args.algo}={shlex.quote(str(run))} --suite quick"


def train(argv: list[str] | None = None, prog: str = PROG) -> Path:
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
    # the loaded model takes the command line's hyperparameters; a resumed run's network ones are its own
    given = [k for k in args.hyperparams if not (resume and k in FIXED_ON_LOAD)]
    model = build_model(
        cfg, env, args.seed, device=args.device, tensorboard_log=tb, verbose=args.verbose,
        trained_agent=ckpt, resume=resume is not None,
        overrides=load_overrides(cfg, given) if ckpt else None,
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
    if not args.verbose and not args.progress:
        callbacks.append(ProgressLine(remaining, int(model.num_timesteps)))
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
    print(
        f"saved {run / 'model.zip'} after {model.num_timesteps} steps in {wall:.0f} s — next: {_next_step(run, args)}"
    )
    env.close()
    if eval_env is not None:
        eval_env.close()
    return run


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """The command line (``spine-gym train``); exit status 0 (usage errors exit with 2)."""
    train(argv, prog)
    return 0


if __name__ == "__main__":
    sys.exit(main())
