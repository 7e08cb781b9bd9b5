"""Reproducible tuning of the bang-bang and PID baselines on training scenarios only.

Example::

    python -m agents.tune --trials 60 --episodes 8 --seed 0      # writes hyperparams/baselines.yml

The objective is the mean tracking RMSE [deg] over ``--episodes`` episodes of ``SmaSpine-v0``
drawn by the env's own samplers (random targets and loads) with reset seeds
``TRAIN_SEED_BASE + i`` — the same distribution the RL agents train on, and disjoint from the
evaluation suite's seeds (:data:`agents.scenarios.EVAL_SEED_BASE`). Optuna's TPE sampler is
seeded, every trial sees the same episodes and the rollouts are deterministic, so the same
command gives the same gains. Both controllers cut a wire whose temperature reaches the env's
limit minus :data:`GUARD_MARGIN_K` (as in the evaluation).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from .common import HYPERPARAMS_DIR

GUARD_MARGIN_K = 5.0  # [K] the baselines cut a wire at (env temperature limit - margin)

TUNED_FILE = HYPERPARAMS_DIR / "baselines.yml"
TRAIN_SEED_BASE = 1_000  # reset seeds of the tuning episodes: TRAIN_SEED_BASE + i (i < 10_000)

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


def load_tuned(path: Path | None = None) -> dict:
    """Tuned baseline settings ``{"bang_bang": {...}, "pid": {...}}`` (defaults if not tuned yet)."""
    path = Path(path) if path else TUNED_FILE
    if not path.exists():
        return {k: dict(v) for k, v in DEFAULT_TUNED.items()}
    data = yaml.safe_load(path.read_text())
    return {k: dict(data[k]["params"]) for k in DEFAULT_TUNED}


def objective_value(env, ctrl, seeds: list[int]) -> float:
    """Mean RMSE [deg] of ``ctrl`` over the training episodes ``seeds``."""
    from .evaluate import run_episode

    rmse = []
    for s in seeds:
        tr = run_episode(env, ctrl, seed=s)
        rmse.append(np.sqrt(np.mean((tr.angle_deg - tr.target_deg) ** 2)))
    return float(np.mean(rmse))


def _suggest(trial, kind: str, v_max: float) -> dict:
    if kind == "pid":
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
    band = trial.suggest_float("band", 0.1, 5.0, log=True)
    return {
        "v_on": trial.suggest_float("v_on", 1.5, v_max),
        "band": band,
        "release": trial.suggest_float("release", -band, 3.0),
        "v_hold": trial.suggest_float("v_hold", 0.0, 0.6 * v_max),
    }


def tune(
    kind: str,
    *,
    n_trials: int = 60,
    n_episodes: int = 8,
    seed: int = 0,
    env_kwargs: dict | None = None,
    make_env=None,
    verbose: bool = True,
) -> dict:
    """Tune one baseline (``"pid"`` or ``"bang_bang"``) with seeded TPE; returns the record.

    Args:
        kind: which controller.
        n_trials: Optuna trials, >= 1.
        n_episodes: training episodes per trial, in [1, 10000].
        seed: sampler seed (the episodes are always ``TRAIN_SEED_BASE + i``).
        env_kwargs: env kwargs (default: the env's defaults).
        make_env: env factory (default :func:`agents.evaluate.make_env`).
        verbose: print progress.

    Returns:
        ``{"params": best settings, "train_rmse_deg": value, "n_trials", "n_episodes", "seed", ...}``.
    """
    import optuna

    from spine_gym.controllers import BangBangController, PIDController

    if kind not in DEFAULT_TUNED:
        raise ValueError(f"kind must be one of {sorted(DEFAULT_TUNED)}, got {kind!r}")
    if not 1 <= n_episodes <= 10_000:
        raise ValueError(f"n_episodes must be in [1, 10000], got {n_episodes}")
    if n_trials < 1:
        raise ValueError(f"n_trials must be >= 1, got {n_trials}")
    if make_env is None:
        from .evaluate import make_env
    env = make_env(env_kwargs or {})
    from .evaluate import env_temperature_limit

    common = {
        "v_max": float(env.v_max),
        "dt": float(env.control_period),
        "temperature_limit": env_temperature_limit(env) - GUARD_MARGIN_K,  # as agents.evaluate builds them
    }
    cls = PIDController if kind == "pid" else BangBangController
    seeds = [TRAIN_SEED_BASE + i for i in range(n_episodes)]

    def objective(trial):
        return objective_value(env, cls(**_suggest(trial, kind, common["v_max"]), **common), seeds)

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(seed=seed))
    study.enqueue_trial(DEFAULT_TUNED[kind])  # the hand-set start point is always tried
    t0 = time.perf_counter()
    for i in range(n_trials):
        study.optimize(objective, n_trials=1)
        if verbose and (i % 10 == 9 or i == n_trials - 1):
            print(
                f"  {kind}: {i + 1}/{n_trials} trials, best train RMSE {study.best_value:.3f} deg", flush=True
            )
    env.close()
    return {
        "params": {k: round(float(v), 6) for k, v in study.best_params.items()},
        "train_rmse_deg": round(float(study.best_value), 4),
        "n_trials": n_trials,
        "n_episodes": n_episodes,
        "episode_seeds": f"{seeds[0]}..{seeds[-1]}",
        "sampler_seed": seed,
        "env_kwargs": dict(env_kwargs or {}),
        "wall_time_s": round(time.perf_counter() - t0, 1),
    }


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(prog="python -m agents.tune", description=__doc__.split("\n")[0])
    p.add_argument("--controllers", nargs="+", default=["bang_bang", "pid"], choices=sorted(DEFAULT_TUNED))
    p.add_argument("--trials", type=int, default=60, help="Optuna trials per controller")
    p.add_argument("--episodes", type=int, default=8, help="training episodes per trial")
    p.add_argument("--seed", type=int, default=0, help="TPE sampler seed")
    p.add_argument("-o", "--out", default=str(TUNED_FILE), help="output YAML (default: %(default)s)")
    args = p.parse_args(argv)
    command = "python -m agents.tune " + " ".join(sys.argv[1:] if argv is None else argv)
    out = Path(args.out)
    record = yaml.safe_load(out.read_text()) if out.exists() else {}
    for kind in args.controllers:
        rec = tune(kind, n_trials=args.trials, n_episodes=args.episodes, seed=args.seed)
        rec["command"] = command
        record[kind] = rec
        print(f"{kind}: {rec['params']} (train RMSE {rec['train_rmse_deg']} deg)")
    header = (
        "# Tuned baseline settings, written by agents/tune.py (see its docstring); do not edit by hand.\n"
    )
    out.write_text(header + yaml.safe_dump(record, sort_keys=False))
    return record


if __name__ == "__main__":
    main()
