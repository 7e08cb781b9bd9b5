"""Per-id re-tuning of the classical baselines, adopted only where it wins on validation episodes.

For one env id and one tuned registry entry (``pid``, ``smc``, ...) :func:`retune_one`

1. tunes the entry on that id with :func:`spine_gym.agents.tuning.tune` (seeded TPE, training
   episodes ``TRAIN_SEED_BASE + i``) under a stated :class:`Budget`;
2. scores the gains the id uses today (its family's, :func:`family_gains`) and the re-tuned ones on
   the same validation episodes (the env's own samplers, reset seeds
   :data:`spine_gym.agents.runtime.VALIDATION_SEED_BASE` ``+ i``; the evaluation suite's seeds are
   never touched): the tuning objective, RMSE, energy and time over the temperature limit;
3. adopts the re-tune only if its validation score is lower (:func:`adopt`): a re-tuned baseline
   replaces the old one only if it is better on validation episodes.

An adopted re-tune is written to the id's own file (:func:`spine_gym.controllers.registry.id_tuned_file`)
with its budget and both validation scores, so :func:`~spine_gym.controllers.registry.load_tuned`
gives it to every evaluation of that id; a rejected one leaves the id on its family's gains. Every
outcome is a record (:func:`record_row`), written as it finishes by the caller
(``benchmarks/retune_classical.py``), so a long run resumes where it stopped.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import yaml

from spine_gym.controllers.registry import id_tuned_file, load_tuned, tunable_for, tuned_file

from .metrics import episode_metrics
from .runtime import (
    MAX_VALIDATION_EPISODES,
    VALIDATION_SEED_BASE,
    build_controller,
    env_temperature_limit,
    make_env,
    run_episode,
)
from .tuning import OBJECTIVES, TRAIN_SEED_BASE, episode_score, tune

__all__ = [
    "Budget",
    "adopt",
    "family_gains",
    "validation_summary",
    "retune_one",
    "record_row",
    "write_id_gains",
    "ROW_FIELDS",
]

HEADER = (
    "# Gains of this id alone, written by spine_gym/agents/retune.py (adopted only where they beat the\n"
    "# family's gains on validation episodes; budget and both validation scores beside them); do not edit.\n"
)


@dataclass(frozen=True)
class Budget:
    """A tuning budget: ``trials`` Optuna TPE trials (sampler seed ``sampler_seed``), each scored on
    the same ``episodes`` training episodes; ``objective`` (:data:`spine_gym.agents.tuning.OBJECTIVES`);
    ``validation_episodes`` episodes for the comparison."""

    trials: int
    episodes: int
    sampler_seed: int = 0
    objective: str = "rmse_energy"
    validation_episodes: int = 20

    def __post_init__(self):
        if self.trials < 1:
            raise ValueError(f"trials must be >= 1, got {self.trials}")
        if not 1 <= self.episodes <= 10_000:
            raise ValueError(f"episodes must be in [1, 10000], got {self.episodes}")
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {OBJECTIVES}, got {self.objective!r}")
        if not 1 <= self.validation_episodes <= MAX_VALIDATION_EPISODES:
            allowed = f"[1, {MAX_VALIDATION_EPISODES}]"
            raise ValueError(f"validation_episodes must be in {allowed}, got {self.validation_episodes}")

    def describe(self) -> str:
        """``<trials> trials × <episodes> episodes (seeds a..b), TPE seed <s>, <objective>``."""
        last = TRAIN_SEED_BASE + self.episodes - 1
        return (
            f"{self.trials} trials × {self.episodes} episodes (seeds {TRAIN_SEED_BASE}..{last}), "
            f"TPE seed {self.sampler_seed}, {self.objective}"
        )


def adopt(before: float, after: float) -> bool:
    """The replacement rule: the re-tuned gains (validation score ``after``) replace the gains in use
    (``before``) only if strictly better (lower); a non-finite ``after`` never wins."""
    return bool(np.isfinite(after) and (not np.isfinite(before) or after < before))


def family_gains(env_id: str, name: str) -> dict:
    """The settings of entry ``name`` that ``env_id`` uses without gains of its own (its family's)."""
    return load_tuned(path=tuned_file(env_id), env_id=env_id)[name]


def validation_summary(env_id: str, name: str, params: dict, budget: Budget) -> dict:
    """Means over the validation episodes of entry ``name`` with ``params`` on ``env_id``: ``score``
    (the budget's objective), ``rmse``, ``energy_J``, ``time_over_limit_s``, ``peak_temperature_K``."""
    env = make_env({}, env_id=env_id)
    ctrl = build_controller(name, env, tuned={name: params})
    limit, dt = env_temperature_limit(env), float(env.control_period)
    rows = []
    for i in range(budget.validation_episodes):
        traj = run_episode(env, ctrl, seed=VALIDATION_SEED_BASE + i)
        m = episode_metrics(traj, temperature_limit=limit, dt=dt)
        rows.append({"score": episode_score(env, traj, budget.objective), **m})
    env.close()
    keys = ("score", "rmse_deg", "energy_J", "time_over_limit_s", "peak_temperature_K")
    out = {k: round(float(np.mean([r[k] for r in rows])), 4) for k in keys}
    out["rmse"] = out.pop("rmse_deg")  # deg, mm for the chain's tip position
    return out


def retune_one(env_id: str, name: str, budget: Budget, *, verbose: bool = False) -> dict:
    """Re-tune entry ``name`` on ``env_id`` under ``budget`` and compare with its family's gains on
    validation episodes (module docstring); returns the record (nothing is written)."""
    if name not in tunable_for(env_id):
        raise ValueError(f"name must be one of {sorted(tunable_for(env_id))} on {env_id}, got {name!r}")
    rec = tune(
        name, n_trials=budget.trials, n_episodes=budget.episodes, seed=budget.sampler_seed,
        env_id=env_id, objective=budget.objective, verbose=verbose,
    )  # fmt: skip
    old = family_gains(env_id, name)
    before = validation_summary(env_id, name, old, budget)
    after = validation_summary(env_id, name, rec["params"], budget)
    return {
        "env_id": env_id,
        "controller": name,
        "params": rec["params"],
        "previous_params": old,
        "budget": {**asdict(budget), "episode_seeds": rec["episode_seeds"], "text": budget.describe()},
        "train_score": rec.get("train_score", rec.get("train_rmse_deg")),
        "validation": {
            "seeds": f"{VALIDATION_SEED_BASE}..{VALIDATION_SEED_BASE + budget.validation_episodes - 1}",
            "before": before,
            "after": after,
        },
        "adopted": adopt(before["score"], after["score"]),
        "tuning_wall_time_s": rec["wall_time_s"],
    }


ROW_FIELDS = (
    "env_id", "controller", "budget", "adopted",
    "score_before", "score_after", "rmse_before", "rmse_after", "energy_J_before", "energy_J_after",
    "over_limit_s_before", "over_limit_s_after", "tuning_wall_time_s",
)  # fmt: skip


def record_row(rec: dict) -> dict:
    """One table row (:data:`ROW_FIELDS`) of a :func:`retune_one` record."""
    b, a = rec["validation"]["before"], rec["validation"]["after"]
    return {
        "env_id": rec["env_id"],
        "controller": rec["controller"],
        "budget": f"{rec['budget']['trials']} × {rec['budget']['episodes']}",
        "adopted": "yes" if rec["adopted"] else "no (family gains kept)",
        "score_before": b["score"],
        "score_after": a["score"],
        "rmse_before": b["rmse"],
        "rmse_after": a["rmse"],
        "energy_J_before": b["energy_J"],
        "energy_J_after": a["energy_J"],
        "over_limit_s_before": b["time_over_limit_s"],
        "over_limit_s_after": a["time_over_limit_s"],
        "tuning_wall_time_s": rec["tuning_wall_time_s"],
    }


def write_id_gains(rec: dict, path: Path | None = None) -> Path | None:
    """Store an adopted record's gains, budget and validation scores in the id's own file (its other
    entries kept); a rejected record writes nothing (None). ``path``: another file (tests)."""
    if not rec["adopted"]:
        return None
    path = Path(path) if path else id_tuned_file(rec["env_id"])
    data = (yaml.safe_load(path.read_text()) or {}) if path.exists() else {}
    data[rec["controller"]] = {
        "params": rec["params"],
        "env_id": rec["env_id"],
        "objective": rec["budget"]["objective"],
        "n_trials": rec["budget"]["trials"],
        "n_episodes": rec["budget"]["episodes"],
        "episode_seeds": rec["budget"]["episode_seeds"],
        "sampler_seed": rec["budget"]["sampler_seed"],
        "validation": rec["validation"],
        "replaces": rec["previous_params"],
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(HEADER + yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
    return path
