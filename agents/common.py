"""Shared pieces of the training and evaluation CLIs.

* Hyperparameter files in RL Zoo's format (``agents/hyperparams/{algo}.yml`` keyed by env id):
  :func:`load_hyperparams` (with ``lin_<x>`` schedules, ``normalize`` as bool or dict string and
  ``policy_kwargs`` as a ``dict(...)`` string, as RL Zoo writes them).
* ``--env-kwargs``/``--hyperparams`` ``key:value`` parsing (:class:`StoreDict`).
* :class:`SavedPolicy` — a trained model plus its ``VecNormalize`` statistics behind SB3's
  ``predict`` interface, so the evaluation treats it like any baseline controller.
"""

from __future__ import annotations

import argparse
import ast
import json
from pathlib import Path
from typing import Any

import numpy as np
import yaml

HYPERPARAMS_DIR = Path(__file__).parent / "hyperparams"
POLICIES_DIR = Path(__file__).parent / "policies"
ENV_ID = "SmaSpine-v0"
ALGOS = ("ppo", "sac")

# keys of a hyperparameter entry that are not constructor arguments of the algorithm
SPECIAL_KEYS = ("n_envs", "n_timesteps", "policy", "normalize", "env_kwargs", "vec_env", "residual", "residual_scale")


def parse_value(text: str) -> Any:
    """A ``key:value`` value: a Python literal if it parses as one, else the string itself."""
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


class StoreDict(argparse.Action):
    """argparse action that turns ``key1:value1 key2:value2`` into a dict (RL Zoo's syntax)."""

    def __call__(self, parser, namespace, values, option_string=None):
        out = {}
        for item in values:
            if ":" not in item:
                raise argparse.ArgumentError(self, f"expected key:value, got {item!r}")
            key, value = item.split(":", 1)
            out[key] = parse_value(value)
        setattr(namespace, self.dest, out)


def linear_schedule(initial: float):
    """``progress_remaining -> progress_remaining * initial`` (SB3 schedules run from 1 to 0)."""
    initial = float(initial)

    def schedule(progress_remaining: float) -> float:
        return progress_remaining * initial

    schedule.initial = initial  # for logging
    return schedule


def _eval_policy_kwargs(text: str) -> dict:
    """Evaluate a ``dict(...)`` string with only ``dict`` and ``torch.nn`` in scope."""
    import torch.nn as nn

    value = eval(text, {"__builtins__": {}}, {"dict": dict, "nn": nn, "list": list})  # noqa: S307 - own file
    if not isinstance(value, dict):
        raise ValueError(f"policy_kwargs must evaluate to a dict, got {type(value).__name__}")
    return value


def load_hyperparams(algo: str, env_id: str = ENV_ID, path: Path | None = None) -> dict:
    """The raw hyperparameter entry of ``env_id`` in ``hyperparams/{algo}.yml`` (a dict copy)."""
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {ALGOS}, got {algo!r}")
    path = Path(path) if path else HYPERPARAMS_DIR / f"{algo}.yml"
    with open(path) as f:
        table = yaml.safe_load(f)
    if env_id not in table:
        raise ValueError(f"no hyperparameters for env {env_id!r} in {path}; entries: {sorted(table)}")
    return dict(table[env_id])


def preprocess_hyperparams(hp: dict) -> tuple[dict, dict]:
    """Split a hyperparameter entry into (algorithm kwargs, special settings).

    Turns ``lin_<x>`` strings into linear schedules, ``policy_kwargs`` strings into dicts and
    ``normalize`` (bool or dict string) into ``VecNormalize`` kwargs (``None``: no normalisation).
    """
    hp = dict(hp)
    special = {k: hp.pop(k) for k in SPECIAL_KEYS if k in hp}
    for key in ("learning_rate", "clip_range"):
        v = hp.get(key)
        if isinstance(v, str) and v.startswith("lin_"):
            hp[key] = linear_schedule(float(v[4:]))
    if isinstance(hp.get("policy_kwargs"), str):
        hp["policy_kwargs"] = _eval_policy_kwargs(hp["policy_kwargs"])
    for key in ("train_freq",):
        if isinstance(hp.get(key), list):
            hp[key] = tuple(hp[key])
    norm = special.get("normalize", False)
    if isinstance(norm, str):
        norm = ast.literal_eval(norm)
    if norm is True:
        norm = {}
    special["normalize"] = norm if isinstance(norm, dict) else None
    special.setdefault("policy", "MlpPolicy")
    special.setdefault("env_kwargs", {})
    special.setdefault("residual", None)
    special.setdefault("residual_scale", 1.0)
    if special["residual"] in (None, "none", "None", False):
        special["residual"] = None
    return hp, special


# --------------------------------------------------------------------------- saved policies
class SavedPolicy:
    """A trained SB3 model and its observation normalisation, as a ``predict``-able controller.

    Args:
        model: the loaded SB3 algorithm (``PPO``/``SAC``).
        obs_rms: ``VecNormalize`` running mean/var of the observations (``None``: raw obs).
        clip_obs, epsilon: ``VecNormalize`` settings used in training.
        meta: the run's metadata (algo, env kwargs, command…).
        name: display name.
    """

    def __init__(
        self, model, obs_rms=None, clip_obs: float = 10.0, epsilon: float = 1e-8, meta=None, name="policy"
    ):
        self.model = model
        self.obs_rms = obs_rms
        self.clip_obs = float(clip_obs)
        self.epsilon = float(epsilon)
        self.meta = dict(meta or {})
        self.name = name
        self.env_kwargs = dict(self.meta.get("env_kwargs", {}))

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """Apply the training-time observation normalisation (as ``VecNormalize.normalize_obs``)."""
        if self.obs_rms is None:
            return np.asarray(obs, dtype=np.float32)
        o = (np.asarray(obs, dtype=np.float64) - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon)
        return np.clip(o, -self.clip_obs, self.clip_obs).astype(np.float32)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        """SB3 ``predict`` on the normalised observation (see ``BaseAlgorithm.predict``)."""
        obs = np.asarray(observation)
        if obs.ndim not in (1, 2) or not np.issubdtype(obs.dtype, np.number):
            raise ValueError(
                f"observation must be a numeric array (d,) or (n_envs, d), got shape {obs.shape}"
            )
        if not np.all(np.isfinite(obs)):
            raise ValueError("observation must be finite, got NaN or inf")
        return self.model.predict(self.normalize(obs), state, episode_start, deterministic)

    def reset(self) -> None:
        """Stateless (feed-forward policies); present for the controller interface."""

    def __repr__(self) -> str:
        return f"SavedPolicy({self.name}, algo={self.meta.get('algo')})"


def vecnormalize_candidates(model_path: Path) -> list[Path]:
    """Where :mod:`agents.train` puts the ``VecNormalize`` statistics of ``model_path``, best first.

    A checkpoint ``rl_model_<n>_steps.zip`` has ``rl_model_vecnormalize_<n>_steps.pkl``,
    ``best_model.zip`` has ``best_vecnormalize.pkl``; every model falls back to the run's final
    ``vecnormalize.pkl`` beside it, then to RL Zoo's ``<env id>/vecnormalize.pkl`` in its folder.
    """
    model_path = Path(model_path)
    out = []
    if model_path.stem.startswith("rl_model_"):
        steps = model_path.stem.split("_")[-2]
        out.append(model_path.with_name(f"rl_model_vecnormalize_{steps}_steps.pkl"))
    if model_path.name == "best_model.zip":
        out.append(model_path.with_name("best_vecnormalize.pkl"))
    out.append(model_path.with_name("vecnormalize.pkl"))
    out.append(model_path.parent / ENV_ID / "vecnormalize.pkl")  # an RL Zoo run folder
    return out


def load_policy(path: str | Path, name: str | None = None, device: str = "cpu") -> SavedPolicy:
    """Load a model saved by :mod:`agents.train` (a run folder, a shipped folder or a ``.zip``).

    A folder must hold ``model.zip`` (or ``best_model.zip``/``<env id>.zip``), optionally
    ``vecnormalize.pkl`` and ``meta.json``. For a ``.zip`` file the ``VecNormalize`` statistics
    are looked up beside it (``vecnormalize.pkl`` or the checkpoint's ``*_vecnormalize_*``).
    """
    import pickle

    from stable_baselines3 import PPO, SAC

    path = Path(path)
    if not path.exists():
        raise ValueError(f"policy path {path} does not exist")
    if path.is_dir():
        folder = path
        zips = [folder / n for n in ("model.zip", "best_model.zip", f"{ENV_ID}.zip")]
        zips = [z for z in zips if z.exists()]
        if not zips:
            raise ValueError(f"no model.zip / best_model.zip / {ENV_ID}.zip in {folder}")
        model_path = zips[0]
    else:
        folder = path.parent
        model_path = path
    meta = {}
    if (folder / "meta.json").exists():
        meta = json.loads((folder / "meta.json").read_text())
    elif (folder / "args.yml").exists():
        meta = yaml.safe_load((folder / "args.yml").read_text()) or {}
    algo = str(meta.get("algo", "")).lower()
    classes = {"ppo": PPO, "sac": SAC}
    if algo not in classes:
        # guess from the file (SAC has critic weights)
        import zipfile

        with zipfile.ZipFile(model_path) as zf:
            data = zf.read("data").decode()
        algo = "sac" if "ent_coef" in data and "target_entropy" in data else "ppo"
    model = classes[algo].load(model_path, device=device)
    obs_rms, clip_obs, eps = None, 10.0, 1e-8
    for c in vecnormalize_candidates(model_path):
        if c.exists():
            with open(c, "rb") as f:
                vn = pickle.load(f)
            obs_rms, clip_obs, eps = vn.obs_rms, vn.clip_obs, vn.epsilon
            break
    meta.setdefault("algo", algo)
    policy = SavedPolicy(model, obs_rms, clip_obs, eps, meta=meta, name=name or path.stem)
    if meta.get("residual"):
        from .residual import ResidualPolicy

        return ResidualPolicy(policy, meta["residual"], name=policy.name)
    return policy
