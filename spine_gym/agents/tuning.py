"""The tuning of a registered controller (seeded Optuna TPE on training episodes): the library
behind ``spine-gym tune`` (:mod:`spine_gym.agents.tune`, whose docstring gives the objectives and
the seeds) and the per-id re-tunes of :mod:`spine_gym.agents.retune`."""

from __future__ import annotations

import time

import numpy as np

from spine_gym.controllers.registry import DEFAULT_TUNED_BY_ENV, get_spec, load_tuned, tunable_for
from spine_gym.envs import base_id

from .runtime import build_controller, run_episode
from .runtime import make_env as default_make_env
from .zoo_config import ENV_ID

__all__ = ["tune", "objective_value", "episode_score", "energy_exchange_rate", "OBJECTIVES", "TRAIN_SEED_BASE"]

TRAIN_SEED_BASE = 1_000  # reset seeds of the tuning episodes: TRAIN_SEED_BASE + i (i < 10_000)


OBJECTIVES = ("rmse", "rmse_energy")


def energy_exchange_rate(env) -> float:
    """The tracking error [deg; mm] the env's reward trades against one unit of normalised step
    energy E / E_ref: ``error_scale × energy_weight``."""
    cfg = env.unwrapped.config
    return float(cfg.error_scale * cfg.energy_weight)


def episode_score(env, traj, objective: str = "rmse") -> float:
    """One episode's value of ``objective`` (:data:`OBJECTIVES`; :mod:`spine_gym.agents.tune` defines them)."""
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
