"""Reproducible tuning of the bang-bang and PID baselines on training scenarios only.

Example (``spine-gym tune`` is the same command)::

    python -m spine_gym.agents.tune --trials 60 --episodes 8 --seed 0      # writes results/tune/baselines.yml
    python -m spine_gym.agents.tune --env SmaSpine3D-v0 --controllers pid  # results/tune/baselines_SmaSpine3D-v0.yml
    python -m spine_gym.agents.tune --env SmaSpine-v0 -o spine_gym/controllers/tuned/baselines.yml --overwrite  # the shipped gains

An existing output file is refused unless ``--overwrite`` (which replaces the tuned controllers'
entries and keeps the others).

The objective (``--objective``, :data:`OBJECTIVES`) is a mean over ``--episodes`` episodes of the env
(``--env``, default ``SmaSpine-v1``) drawn by the env's own samplers (random targets and loads)
with reset seeds ``TRAIN_SEED_BASE + i`` — the same distribution the RL agents train on, and
disjoint from the evaluation suite's seeds (:data:`spine_gym.agents.scenarios.EVAL_SEED_BASE`):

* ``rmse`` — the tracking RMSE [deg; mm for the chain's tip position];
* ``rmse_energy`` — the RMSE plus the energy term of the env's own reward in the same unit:
  ``error_scale × energy_weight × mean(E_step / E_ref)`` (the exchange rate of tracking error
  against energy the RL agents are trained with: 5° per unit of normalised step energy on the
  ``-v1``/``-v2`` ids, 10 mm on the chain), so a gain set cannot win by burning energy.

Optuna's TPE sampler is seeded, every trial sees the same episodes and the rollouts are
deterministic, so the same command gives the same gains. The hand-set start point and the gains
in use (:func:`load_tuned`) are tried first. On ids without a thermal cut-off in the plant the
controllers cut a wire whose temperature reaches the env's limit minus :data:`GUARD_MARGIN_K` (as
in the evaluation); on the ``-v2`` ids the plant's cut-off is the only protection.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from spine_gym import cli_conventions as cli
from spine_gym.controllers.registry import (
    DEFAULT_TUNED_BY_ENV,
    GUARD_MARGIN_K,
    get_spec,
    load_tuned,
    tunable_for,
    tuned_file,
)
from spine_gym.envs import base_id

from .runtime import build_controller, run_episode
from .runtime import make_env as default_make_env
from .zoo_config import DEFAULT_ENV_ID, ENV_ID

__all__ = [
    "tune",
    "objective_value",
    "episode_score",
    "energy_exchange_rate",
    "OBJECTIVES",
    "load_tuned",
    "TRAIN_SEED_BASE",
    "GUARD_MARGIN_K",
]

TRAIN_SEED_BASE = 1_000  # reset seeds of the tuning episodes: TRAIN_SEED_BASE + i (i < 10_000)


OBJECTIVES = ("rmse", "rmse_energy")


def energy_exchange_rate(env) -> float:
    """The tracking error [deg; mm] the env's reward trades against one unit of normalised step
    energy E / E_ref: ``error_scale × energy_weight``."""
    cfg = env.unwrapped.config
    return float(cfg.error_scale * cfg.energy_weight)


def episode_score(env, traj, objective: str = "rmse") -> float:
    """One episode's value of ``objective`` (:data:`OBJECTIVES`; module docstring)."""
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    rmse = float(np.sqrt(np.mean(traj.error**2)))
    if objective == "rmse":
        return rmse
    e_ref = float(env.unwrapped.config.energy_reference)
    return rmse + energy_exchange_rate(env) * float(np.mean(traj.energy_J)) / e_ref


def objective_value(env, ctrl, seeds: list[int], objective: str = "rmse") -> float:
    """Mean ``objective`` (:func:`episode_score`) of ``ctrl`` over the training episodes ``seeds``."""
    return float(np.mean([episode_score(env, run_episode(env, ctrl, seed=s), objective) for s in seeds]))


def tune(
    kind: str,
    *,
    n_trials: int = 60,
    n_episodes: int = 8,
    seed: int = 0,
    env_kwargs: dict | None = None,
    make_env=None,
    verbose: bool = True,
    env_id: str = ENV_ID,
    objective: str = "rmse",
) -> dict:
    """Tune one registered baseline (e.g. ``"pid"``, ``"smc"``) with seeded TPE; returns the record.

    Args:
        kind: which controller.
        n_trials: Optuna trials, >= 1.
        n_episodes: training episodes per trial, in [1, 10000].
        seed: sampler seed (the episodes are always ``TRAIN_SEED_BASE + i``).
        env_kwargs: env kwargs (default: the env's defaults).
        make_env: env factory ``(env_kwargs) -> env`` (default :func:`spine_gym.agents.runtime.make_env` of ``env_id``).
        verbose: print progress.
        env_id: the env whose registry entry is tuned (any registered id).
        objective: what is minimised (:data:`OBJECTIVES`).

    Returns:
        ``{"params": best settings, "train_rmse_deg" (``rmse``) or "train_score" (``rmse_energy``):
        the best objective value, "objective", "n_trials", "n_episodes", "seed", ...}``.
    """
    import optuna

    if kind not in tunable_for(env_id):
        raise ValueError(f"kind must be one of {sorted(tunable_for(env_id))}, got {kind!r}")
    if not 1 <= n_episodes <= 10_000:
        raise ValueError(f"n_episodes must be in [1, 10000], got {n_episodes}")
    if n_trials < 1:
        raise ValueError(f"n_trials must be >= 1, got {n_trials}")
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    env = make_env(env_kwargs or {}) if make_env else default_make_env(env_kwargs or {}, env_id=env_id)
    spec = get_spec(kind, env_id)
    v_max = float(env.v_max)
    seeds = [TRAIN_SEED_BASE + i for i in range(n_episodes)]

    def trial_value(trial):
        # built as runtime.build_controller builds it for the evaluation (same guard, same env)
        ctrl = build_controller(kind, env, tuned={kind: spec.search_space(trial, v_max)})
        return objective_value(env, ctrl, seeds, objective)

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(seed=seed))
    for start in _start_points(kind, env_id)[:n_trials]:
        study.enqueue_trial(start)
    t0 = time.perf_counter()
    for i in range(n_trials):
        study.optimize(trial_value, n_trials=1)
        if verbose and (i % 10 == 9 or i == n_trials - 1):
            best = f"best train {objective} {study.best_value:.3f}"
            print(f"  {kind}: {i + 1}/{n_trials} trials, {best}", flush=True)
    env.close()
    return {
        "params": {k: round(float(v), 6) for k, v in study.best_params.items()},
        "train_rmse_deg" if objective == "rmse" else "train_score": round(float(study.best_value), 4),
        "objective": objective,
        "n_trials": n_trials,
        "n_episodes": n_episodes,
        "episode_seeds": f"{seeds[0]}..{seeds[-1]}",
        "sampler_seed": seed,
        "env_id": env_id,
        "env_kwargs": dict(env_kwargs or {}),
        "wall_time_s": round(time.perf_counter() - t0, 1),
    }


def _start_points(kind: str, env_id: str) -> list[dict]:
    """The settings tried first: the hand-set start point, then the gains in use (if different)."""
    hand_set = DEFAULT_TUNED_BY_ENV[base_id(env_id)][kind]
    in_use = load_tuned(env_id=env_id)[kind]
    return [hand_set] if in_use == hand_set else [hand_set, in_use]


#: this command's name as ``python -m <module>`` (``spine-gym <command>`` passes its own ``prog``)
PROG = cli.module_prog(__spec__.name)

EXAMPLES = """
spine-gym tune --trials 60 --episodes 8 --seed 0      # writes results/tune/baselines.yml
spine-gym tune --env SmaSpine3D-v0 --controllers pid -o results/tune/pid_3d.yml
spine-gym tune --env SmaSpine-v0 -o spine_gym/controllers/tuned/baselines.yml --overwrite   # the shipped gains
"""
DEFAULT_OUT = Path("results/tune")  # the default output folder (the file is named after the shipped one)


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    p = cli.Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES)
    cli.add_env(p, default=DEFAULT_ENV_ID)
    p.add_argument(
        "--controllers", nargs="+", default=None, help="tuned registry entries (default: all of --env)"
    )
    p.add_argument("--trials", type=int, default=60, help="Optuna trials per controller")
    p.add_argument("--episodes", type=int, default=8, help="training episodes per trial")
    p.add_argument("--seed", type=int, default=0, help="TPE sampler seed")
    p.add_argument(
        "--objective", choices=OBJECTIVES, default="rmse",
        help="rmse, or rmse_energy: the RMSE plus the env reward's energy term in the same unit",
    )  # fmt: skip
    cli.add_env_kwargs(p)
    cli.add_out(
        p, metavar="FILE",
        help=f"output YAML (default: {DEFAULT_OUT}/<name of the env's shipped file>, e.g. {DEFAULT_OUT}/baselines.yml)",
    )  # fmt: skip
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="update an existing --out (the tuned controllers' entries are replaced, the others kept)",
    )
    cli.add_progress(p)
    return p


def _check(args) -> Path:
    """The output file, every argument checked (ValueError, one line) before any tuning."""
    tunable = list(tunable_for(args.env))
    args.controllers = tunable if args.controllers is None else args.controllers
    cli.check_keys(args.controllers, tunable, "--controllers", what=f"tuned controller of {args.env}")
    if args.trials < 1:
        raise ValueError(f"--trials must be >= 1, got {args.trials}")
    if not 1 <= args.episodes <= 10_000:
        raise ValueError(f"--episodes must be in [1, 10000], got {args.episodes}")
    out = Path(args.out) if args.out else DEFAULT_OUT / tuned_file(args.env).name
    if out.is_dir():
        raise ValueError(f"--out {out} is a folder; give a file name (.yml)")
    cli.check_out_file(out)
    if out.exists() and not args.overwrite:
        raise ValueError(f"--out {out} exists; pass --overwrite to update it or give another --out")
    cli.check_env_kwargs(args.env, args.env_kwargs)
    return out


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """Run the CLI; exit status 0 (the record is the YAML file written). Usage errors exit with
    status 2 before any tuning."""
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    with cli.usage_errors(parser):
        out = _check(args)
    command = f"{PROG} " + " ".join(sys.argv[1:] if argv is None else argv)
    record = yaml.safe_load(out.read_text()) if out.exists() else {}
    for kind in args.controllers:
        rec = tune(
            kind, n_trials=args.trials, n_episodes=args.episodes, seed=args.seed, env_id=args.env,
            env_kwargs=args.env_kwargs, verbose=args.progress, objective=args.objective,
        )  # fmt: skip
        rec["command"] = command
        record[kind] = rec
        best = rec.get("train_rmse_deg", rec.get("train_score"))
        print(f"{kind}: {rec['params']} (train {args.objective} {best})")
    header = (
        "# Tuned baseline settings, written by spine_gym/agents/tune.py (see its docstring); do not edit by hand.\n"
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(header + yaml.safe_dump(record, sort_keys=False))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
