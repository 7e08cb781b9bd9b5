"""Train PPO or SAC on ``SmaSpine-v0`` or a spatial spine (``--env SmaSpine3D-v0``, ...; RL-Zoo-style CLI).

Example::

    python -m agents.train --algo ppo -n 300000 --seed 1 --n-envs 8 -f logs \\
        --env-kwargs episode_duration:60.0

Hyperparameters come from ``agents/hyperparams/{algo}.yml`` (entry keyed by the env id, RL Zoo's
format: ``n_envs``, ``n_timesteps``, ``policy``, ``normalize``, ``policy_kwargs`` as a
``dict(...)`` string, ``lin_<x>`` schedules, plus an optional ``env_kwargs`` dict); command-line
flags override them (``-params key:value``). The training env is the package's native vector env
(one jitted batch step for all sub-envs) behind an SB3 ``VecEnv`` adapter, wrapped in
``VecMonitor`` and ``VecNormalize``.

Each run gets a folder ``<log folder>/<algo>/<env id>_<k>/`` holding ``command.txt`` (the exact
command line), ``args.yml`` (parsed arguments), ``config.yml`` (the hyperparameters used),
``meta.json`` (what :func:`agents.runtime.load_policy` needs), ``checkpoints/`` (model +
``VecNormalize`` every ``--save-freq`` steps), ``best_model.zip`` (by the evaluation callback),
``best_vecnormalize.pkl`` (the statistics at that moment), ``evaluations.npz``, TensorBoard
logs in ``tb/`` and the final ``model.zip`` + ``vecnormalize.pkl`` (+ ``lagrangian.json`` with an
energy budget).

Resuming an interrupted run (a crash, ``kill -9``)::

    python -m agents.train --resume logs/ppo/SmaSpine-v0_3            # its newest checkpoint
    python -m agents.train --resume logs/ppo/SmaSpine-v0_3/checkpoints/rl_model_200000_steps.zip

continues the run in its own folder with the run's command line (``command.txt``'s first line; flags
given with ``--resume`` are appended and win): the checkpoint's weights, optimiser state,
``VecNormalize`` statistics, step counter and Lagrange multiplier (:mod:`agents.checkpoints`), up to
the run's ``-n`` steps in all, so learning-rate and clip schedules and later checkpoints fall on the
steps of an uninterrupted run. The envs restart their episodes from ``--seed`` and the random streams
are seeded afresh, so the result is not the uninterrupted run's, but two resumes from one checkpoint
give the same weights (``tests/test_train_resume.py``). Evaluations up to the checkpoint stay in
``evaluations.npz`` and ``best_model.zip`` is replaced only by a better one.
``-i path/to/model.zip`` is a fine-tune instead: a new run folder, ``-n`` more steps, the model's
normalisation statistics and step counter, the multiplier from ``lagrangian_init``.

``residual: pid`` in the hyperparameters (or ``-params residual:pid``) trains a residual policy on
top of the tuned PID (:mod:`agents.residual`; ``residual_scale`` sets the authority of the
correction, default 1); the baseline's settings go into ``meta.json`` with the model.

``energy_budget: pid`` (or a number of joules) replaces the reward's fixed energy weight by a
Lagrange multiplier that dual ascent adjusts after every rollout so that the mean episode energy
meets the budget (:mod:`agents.lagrangian`); ``pid`` is the tuned PID's mean energy on
``budget_episodes`` validation episodes of the training distribution (with the env's default
observation: a longer ``target_preview`` of the policy is not given to the PID). ``lagrangian_init`` and
``lagrangian_lr`` set the initial multiplier and its step, ``budget_window`` how many finished
episodes the mean energy of the dual step is taken over (default 32; 0: the episodes finished
since the previous dual step), ``budget_scale`` (default 1, in (0, 2]) multiplies the budget (e.g. 0.93
with ``pid``: 7 % under the PID's energy); the budget goes into ``meta.json``.

``obs_integral: <τ [s] or inf>`` appends the (leaky) integral of the tracking error to the
observation (:mod:`agents.integral`; ``obs_integral_limit`` its clip, default 300 deg s); its
settings go into ``meta.json``, so :func:`agents.runtime.load_policy` rebuilds it for evaluation.
``obs_history: <k>`` appends the k earlier frames of the measured angle and the previous action
(:mod:`agents.history`), after the integral; likewise stored and rebuilt.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
import time
from pathlib import Path

import yaml

from .checkpoints import (
    RunCheckpointCallback,
    checkpoint_steps,
    lagrangian_candidates,
    latest_checkpoint,
    load_lagrangian,
    restore_eval_history,
    save_lagrangian,
)
from .common import ALGOS, ENV_ID, StoreDict, load_hyperparams, preprocess_hyperparams
from .envs import make_vec_env
from .history import HistoryObsVecEnv, HistorySpec
from .integral import IntegralObsVecEnv, IntegralSpec
from .lagrangian import EnergyBudgetVecEnv, LagrangianCallback
from .residual import ResidualVecEnv, base_spec
from .runtime import (
    OBSERVATION_KWARGS,
    build_controller,
    env_temperature_limit,
    make_env,
    validation_scores,
    vecnormalize_candidates,
)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m agents.train", description=__doc__.split("\n")[0])
    p.add_argument("--algo", choices=ALGOS, help="RL algorithm (required unless --resume)")
    p.add_argument("--env", default=ENV_ID, help="environment id (default: %(default)s)")
    p.add_argument(
        "-n", "--n-timesteps", type=int, default=-1, help="training steps (default: from the YAML)"
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (env sampling, network init)")
    p.add_argument("--n-envs", type=int, default=-1, help="parallel sub-envs (default: from the YAML)")
    p.add_argument("--env-kwargs", nargs="+", action=StoreDict, default={}, help="env kwargs key:value")
    p.add_argument(
        "-params", "--hyperparams", nargs="+", action=StoreDict, default={}, help="override key:value"
    )
    p.add_argument(
        "-conf",
        "--conf-file",
        type=str,
        default=None,
        help="hyperparameter YAML (default: agents/hyperparams/<algo>.yml)",
    )
    p.add_argument("-f", "--log-folder", type=str, default="logs", help="log folder (default: %(default)s)")
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
    p.add_argument("-P", "--progress", action="store_true", help="show a progress bar")
    p.add_argument("--no-tensorboard", action="store_true", help="do not write TensorBoard logs")
    p.add_argument(
        "--torch-threads", type=int, default=1, help="torch intra-op threads (default: %(default)s)"
    )
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
            raise SystemExit(f"--resume: no checkpoint in {path / 'checkpoints'} to resume from")
    elif checkpoint_steps(path) is not None and path.parent.name == "checkpoints" and path.exists():
        run, ckpt = path.parent.parent, path
    else:
        raise SystemExit(f"--resume must be a run folder or its checkpoints/rl_model_<n>_steps.zip, got {path}")
    if not (run / "command.txt").exists() or not (run / "meta.json").exists():
        raise SystemExit(f"--resume: {run} is not a run folder of agents.train (no command.txt / meta.json)")
    return run, ckpt


def _parse(argv: list[str] | None):
    """(arguments, argv, resume target or None). With ``--resume`` the run's first command line
    comes first and this one's flags after it, so they override."""
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    resume = None
    if args.resume:
        if args.trained_agent:
            parser.error("--resume continues a run from its own checkpoint: drop -i")
        resume = _resume_target(Path(args.resume))
        first = shlex.split((resume[0] / "command.txt").read_text().splitlines()[0])
        args = parser.parse_args([*first[3:], *argv])  # first[:3]: python -m agents.train
    if args.algo is None:
        parser.error("--algo is required (or --resume RUN)")
    return args, argv, resume


def train(argv: list[str] | None = None) -> Path:
    """Run the CLI with ``argv`` (default ``sys.argv[1:]``); returns the run folder."""
    args, argv, resume = _parse(argv)
    ckpt = str(resume[1]) if resume else args.trained_agent  # the model to load, if any
    os.environ.setdefault("OMP_NUM_THREADS", str(args.torch_threads))
    import torch

    torch.set_num_threads(max(1, args.torch_threads))
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import CallbackList, EvalCallback
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import VecNormalize


    for name, v in (("--n-envs", args.n_envs), ("-n", args.n_timesteps)):
        if v == 0 or v < -1:
            raise SystemExit(f"{name} must be a positive integer, got {v}")
    hp_raw = load_hyperparams(args.algo, args.env, args.conf_file)
    hp_raw.update(args.hyperparams)
    hp, special = preprocess_hyperparams(hp_raw)
    n_envs = args.n_envs if args.n_envs > 0 else int(special.get("n_envs", 1))
    n_timesteps = args.n_timesteps if args.n_timesteps > 0 else int(float(special.get("n_timesteps", 1e5)))
    env_kwargs = {**special["env_kwargs"], **args.env_kwargs}
    set_random_seed(args.seed)

    command = "python -m agents.train " + " ".join(shlex.quote(a) for a in argv)
    if resume:
        run = resume[0]
        with open(run / "command.txt", "a") as f:
            f.write(command + "\n")
        meta = json.loads((run / "meta.json").read_text())
        meta.setdefault("resumes", []).append({"checkpoint": ckpt, "command": command})
    else:
        run = _next_run_folder(Path(args.log_folder), args.algo, args.env)
        (run / "command.txt").write_text(command + "\n")
        (run / "args.yml").write_text(
            yaml.safe_dump({**vars(args), "n_envs": n_envs, "n_timesteps": n_timesteps})
        )
        (run / "config.yml").write_text(
            yaml.safe_dump(
                {
                    args.env: _yaml_safe(
                        {**hp, **special, "n_envs": n_envs, "n_timesteps": n_timesteps, "env_kwargs": env_kwargs}
                    )
                }
            )
        )
        meta = {
            "algo": args.algo,
            "env_id": args.env,
            "env_kwargs": env_kwargs,
            "seed": args.seed,
            "n_envs": n_envs,
            "n_timesteps": n_timesteps,
            "command": command,
            "resumed_from": args.trained_agent or None,
        }

    env = make_vec_env(args.env, n_envs, seed=args.seed, env_kwargs=env_kwargs, kind=args.vec_env)
    norm = special["normalize"]
    eval_env = None
    if args.eval_freq > 0:
        eval_env = make_vec_env(args.env, 1, seed=args.seed + 1_000_003, env_kwargs=env_kwargs, kind="dummy")
    if special["residual"]:
        # residual RL: the policy learns a correction on top of the tuned baseline (agents.residual)
        probe = make_env(env_kwargs, env_id=args.env)
        spec = base_spec(
            special["residual"],
            v_max=probe.v_max,
            dt=probe.control_period,
            temperature_limit=env_temperature_limit(probe),
            scale=special["residual_scale"],
            env_id=args.env,
            env_kwargs=env_kwargs,
        )
        probe.close()
        meta["residual"] = spec
        env = ResidualVecEnv(env, spec)
        if eval_env is not None:
            eval_env = ResidualVecEnv(eval_env, spec)
    if special["obs_integral"] is not None:
        # the integral-of-error observation (agents.integral), above the residual's baseline
        probe = make_env(env_kwargs, env_id=args.env)
        ispec = IntegralSpec.from_env(probe, special["obs_integral"], float(special["obs_integral_limit"]))
        probe.close()
        meta["obs_integral"] = ispec.to_dict()
        env = IntegralObsVecEnv(env, ispec)
        if eval_env is not None:
            eval_env = IntegralObsVecEnv(eval_env, ispec)
    if special["obs_history"] is not None:
        # the frame history (agents.history), after the integral
        probe = make_env(env_kwargs, env_id=args.env)
        hspec = HistorySpec.from_env(probe, special["obs_history"])
        probe.close()
        meta["obs_history"] = hspec.to_dict()
        env = HistoryObsVecEnv(env, hspec)
        if eval_env is not None:
            eval_env = HistoryObsVecEnv(eval_env, hspec)
    budget_env = None
    if special["energy_budget"] is not None:
        if resume:  # the checkpoint's budget: a "pid" budget is not measured again
            budget = float(json.loads(lagrangian_candidates(resume[1])[0].read_text())["budget_J"])
        else:
            budget = energy_budget(
                special["energy_budget"], env_kwargs, int(special["budget_episodes"]), special["budget_scale"]
            )
        probe = make_env(env_kwargs)
        budget_env = EnergyBudgetVecEnv(
            env,
            budget,
            probe.config.energy_reference,
            lam0=float(special["lagrangian_init"]),
            window=int(special["budget_window"]),
        )
        probe.close()
        if resume:
            load_lagrangian(budget_env, resume[1])
        env = budget_env
        meta["energy_budget_J"] = budget
        if args.verbose:
            print(f"energy budget {budget:.1f} J per episode", flush=True)
    if norm is not None:
        if ckpt:
            stats = _checkpoint_vecnormalize(Path(ckpt))
            env = VecNormalize.load(str(stats), env)
            env.training = True
        else:
            env = VecNormalize(env, gamma=hp.get("gamma", 0.99), **norm)
        if eval_env is not None:
            eval_env = VecNormalize(
                eval_env,
                training=False,
                norm_reward=False,
                **{k: v for k, v in norm.items() if k != "norm_reward"},
            )

    algo_cls = {"ppo": PPO, "sac": SAC}[args.algo]
    tb = None if args.no_tensorboard else str(run / "tb")
    if ckpt:
        model = algo_cls.load(
            ckpt, env=env, device=args.device, tensorboard_log=tb, verbose=args.verbose
        )
        if model.seed != args.seed:
            # SB3's load seeds with the checkpoint's own seed, so --seed alone did nothing on a resume.
            # Only re-seed when it differs: a second seeding after the network's construction changes
            # the RNG stream, and the same-seed fine-tunes in agents/policies/COMMANDS.md must reproduce.
            model.seed = args.seed
            model.set_random_seed(args.seed)
        replay = Path(ckpt).with_name("replay_buffer.pkl")
        if args.algo == "sac" and replay.exists():
            model.load_replay_buffer(str(replay))
    else:
        model = algo_cls(
            special["policy"],
            env,
            seed=args.seed,
            device=args.device,
            tensorboard_log=tb,
            verbose=args.verbose,
            **hp,
        )

    if resume:
        # the checkpoint's last observation belongs to the killed process's envs: reset the new ones
        model._last_obs = None
        start = int(meta.get("start_timesteps", 0))
    else:
        start = int(model.num_timesteps)  # 0, or the fine-tuned model's count
        meta["start_timesteps"] = start
    remaining = max(0, start + n_timesteps - int(model.num_timesteps))
    callbacks = []
    if budget_env is not None:
        eta = float(special["lagrangian_lr"])
        callbacks.append(LagrangianCallback(budget_env, eta=eta, verbose=args.verbose))
    if args.save_freq > 0:
        callbacks.append(
            RunCheckpointCallback(
                run / "checkpoints", max(1, args.save_freq // n_envs), start, budget_env, args.verbose
            )
        )
    if eval_env is not None:
        on_best = None
        if norm is not None:
            # keep the normalisation statistics of the moment the best model was saved (RL Zoo's
            # SaveVecNormalizeCallback): the final ones differ from those the best model saw
            from stable_baselines3.common.callbacks import BaseCallback

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
        if resume:
            restore_eval_history(evaluation, run, int(model.num_timesteps))
        callbacks.append(evaluation)
    segment = meta["resumes"][-1] if resume else meta
    segment["start_step"] = int(model.num_timesteps)
    if budget_env is not None:
        segment["lagrangian_start"] = budget_env.lam
    (run / "meta.json").write_text(json.dumps(meta, indent=2))
    t0, c0 = time.time(), time.process_time()
    model.learn(
        total_timesteps=remaining if resume else n_timesteps,
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
    if budget_env is not None:
        meta["lagrangian_final"] = budget_env.lam
        save_lagrangian(budget_env, run / "lagrangian.json")
    (run / "meta.json").write_text(json.dumps(meta, indent=2))
    if args.verbose:
        print(f"saved {run / 'model.zip'} after {model.num_timesteps} steps in {wall:.0f} s")
    env.close()
    if eval_env is not None:
        eval_env.close()
    return run


def energy_budget(spec, env_kwargs: dict, n_episodes: int, scale: float = 1.0) -> float:
    """The energy budget per episode [J]: ``scale`` × a number as given, or ``"pid"``: ``scale`` ×
    the tuned PID's mean energy on ``n_episodes`` validation episodes of the training distribution
    ``env_kwargs``."""
    try:
        scale = float(scale)
    except (TypeError, ValueError):
        raise ValueError(f"budget_scale must be a number in (0, 2], got {scale!r}") from None
    if not 0.0 < scale <= 2.0:
        raise ValueError(f"budget_scale must be a number in (0, 2], got {scale!r}")
    if spec == "pid":  # the PID as evaluated: the task's kwargs, the env's default observation
        kw = {k: v for k, v in env_kwargs.items() if k not in OBSERVATION_KWARGS}
        probe = make_env(kw)
        pid = build_controller("pid", probe)
        probe.close()
        return scale * validation_scores(pid, n_episodes, kw)[1]
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
        raise SystemExit(f"checkpoint {ckpt} does not exist")
    candidates = vecnormalize_candidates(ckpt)
    for c in candidates:
        if c.exists():
            return c
    raise SystemExit(
        f"no VecNormalize statistics found beside {ckpt} (looked for {[str(c) for c in candidates]})"
    )


def main() -> None:
    train()


if __name__ == "__main__":
    main()
