"""Checkpoints of :mod:`spine_gym.agents.train` that a run resumes from after an interruption (``kill -9``).

A checkpoint ``<run>/checkpoints/rl_model_<n>_steps.zip`` (the model: weights, optimiser state,
``num_timesteps``) comes with ``rl_model_vecnormalize_<n>_steps.pkl`` (the ``VecNormalize``
statistics; with ``normalize``) and ``rl_model_lagrangian_<n>_steps.json`` (the Lagrange multiplier
and the finished-episode energies of its window; with ``energy_budget``), the names of SB3's
``CheckpointCallback`` plus the multiplier. :class:`RunCheckpointCallback` writes the three into
``checkpoints/.partial/`` and moves them into place with ``os.replace``, the model last, so a
checkpoint whose ``.zip`` exists is complete however the process was stopped; a resume
(:func:`latest_checkpoint`) takes the newest such checkpoint.

The run's final ``model.zip`` has ``vecnormalize.pkl`` and ``lagrangian.json`` beside it.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EvalCallback

from .lagrangian import EnergyBudgetVecEnv

__all__ = [
    "PREFIX",
    "RunCheckpointCallback",
    "checkpoint_steps",
    "lagrangian_candidates",
    "latest_checkpoint",
    "load_lagrangian",
    "restore_eval_history",
    "save_lagrangian",
]

PREFIX = "rl_model"
_MODEL = re.compile(rf"^{PREFIX}_(\d+)_steps\.zip$")


def checkpoint_steps(model_path: Path) -> int | None:
    """``n`` of a checkpoint ``rl_model_<n>_steps.zip`` (None for any other file name)."""
    m = _MODEL.match(Path(model_path).name)
    return int(m.group(1)) if m else None


def _companion(folder: Path, kind: str, steps: int, ext: str) -> Path:
    return folder / f"{PREFIX}_{kind}_{steps}_steps.{ext}"


def lagrangian_candidates(model_path: Path) -> list[Path]:
    """Where the multiplier's state of ``model_path`` is, best first: a checkpoint's own
    ``rl_model_lagrangian_<n>_steps.json``, then ``lagrangian.json`` beside the model."""
    model_path = Path(model_path)
    steps = checkpoint_steps(model_path)
    out = [] if steps is None else [_companion(model_path.parent, "lagrangian", steps, "json")]
    return [*out, model_path.with_name("lagrangian.json")]


def save_lagrangian(budget_env: EnergyBudgetVecEnv, path: Path) -> None:
    Path(path).write_text(json.dumps(budget_env.state_dict()) + "\n")


def load_lagrangian(budget_env: EnergyBudgetVecEnv, model_path: Path) -> Path:
    """Restore the multiplier saved with ``model_path`` into ``budget_env``; returns the file read."""
    for c in lagrangian_candidates(model_path):
        if c.exists():
            budget_env.load_state_dict(json.loads(c.read_text()))
            return c
    raise SystemExit(
        f"no Lagrange multiplier saved beside {model_path} (looked for "
        f"{[str(c) for c in lagrangian_candidates(model_path)]})"
    )


class RunCheckpointCallback(BaseCallback):
    """Every ``save_freq`` vector steps of the run: model, ``VecNormalize`` and multiplier, atomically.

    Args:
        save_path: the run's ``checkpoints/`` folder.
        save_freq: vector steps (calls) between checkpoints, counted from ``start_timesteps``, so a
            resumed run writes its checkpoints at the steps of the uninterrupted one.
        start_timesteps: ``num_timesteps`` of the model when the run (not the resume) started.
        budget_env: the run's :class:`EnergyBudgetVecEnv` (None: no multiplier to save).
    """

    def __init__(
        self,
        save_path: Path,
        save_freq: int,
        start_timesteps: int = 0,
        budget_env: EnergyBudgetVecEnv | None = None,
        verbose: int = 0,
    ):
        if save_freq < 1:
            raise ValueError(f"save_freq must be >= 1 vector step, got {save_freq}")
        super().__init__(verbose)
        self.save_path = Path(save_path)
        self.save_freq = int(save_freq)
        self.start_timesteps = int(start_timesteps)
        self.budget_env = budget_env

    def _on_step(self) -> bool:
        calls = (self.num_timesteps - self.start_timesteps) // self.training_env.num_envs
        if calls > 0 and calls % self.save_freq == 0:
            self.save(self.num_timesteps)
        return True

    def save(self, steps: int) -> Path:
        """Write the checkpoint of ``steps``; returns the model's path."""
        partial = self.save_path / ".partial"
        partial.mkdir(parents=True, exist_ok=True)
        final = {}
        vecnorm = self.model.get_vec_normalize_env()
        if vecnorm is not None:
            final["vecnormalize"] = _companion(self.save_path, "vecnormalize", steps, "pkl")
            vecnorm.save(str(partial / final["vecnormalize"].name))
        if self.budget_env is not None:
            final["lagrangian"] = _companion(self.save_path, "lagrangian", steps, "json")
            save_lagrangian(self.budget_env, partial / final["lagrangian"].name)
        final["model"] = self.save_path / f"{PREFIX}_{steps}_steps.zip"
        self.model.save(partial / final["model"].name)
        for path in final.values():  # the model last: its presence marks a complete checkpoint
            os.replace(partial / path.name, path)
        if self.verbose >= 2:
            print(f"checkpoint {final['model']}", flush=True)
        return final["model"]


def latest_checkpoint(run: Path) -> Path | None:
    """The newest complete checkpoint ``<run>/checkpoints/rl_model_<n>_steps.zip`` (None: none)."""
    folder = Path(run) / "checkpoints"
    found = [(checkpoint_steps(p), p) for p in folder.glob(f"{PREFIX}_*_steps.zip")]
    found = [(n, p) for n, p in found if n is not None]
    return max(found)[1] if found else None


def restore_eval_history(callback: EvalCallback, run: Path, up_to: int) -> int:
    """Load the run's ``evaluations.npz`` into ``callback`` up to step ``up_to`` (the checkpoint
    resumed from), so the file keeps the earlier evaluations and ``best_model.zip`` is replaced only
    by a better mean return; returns how many evaluations were restored."""
    path = Path(run) / "evaluations.npz"
    if not path.exists():
        return 0
    with np.load(path) as data:
        keep = data["timesteps"] <= up_to
        callback.evaluations_timesteps = data["timesteps"][keep].tolist()
        callback.evaluations_results = data["results"][keep].tolist()
        callback.evaluations_length = data["ep_lengths"][keep].tolist()
    if callback.evaluations_results:
        callback.best_mean_reward = float(max(np.mean(r) for r in callback.evaluations_results))
    return len(callback.evaluations_timesteps)
