"""The files of a saved policy and the env it was trained on, read without loading the model.

* :func:`policy_files` — the model ``.zip`` of a run folder, shipped folder or ``.zip`` path, and the
  folder whose ``meta.json`` describes it (a checkpoint's run folder);
* :func:`policy_meta` — that ``meta.json`` (or RL Zoo's ``args.yml``);
* :func:`trained_env_id` — the env id recorded there;
* :func:`check_policy_env` — the check a command runs before any work: a one-line ``ValueError``
  unless the policy fits ``--env`` (its recorded env, else the observation and action spaces stored
  in the model file).
"""

from __future__ import annotations

import json
import warnings
import zipfile
from pathlib import Path

import gymnasium as gym
import yaml

from .zoo_config import ENV_ID

__all__ = ["MODEL_NAMES", "policy_files", "policy_meta", "trained_env_id", "check_policy_env"]

#: the model files a policy folder may hold, first found wins (the last: RL Zoo's name)
MODEL_NAMES = ("model.zip", "best_model.zip", f"{ENV_ID}.zip")


def policy_files(path: str | Path) -> tuple[Path, Path]:
    """(folder of its ``meta.json``, model ``.zip``) of a run folder, shipped folder or ``.zip``;
    ValueError if there is no model."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"policy path {path} does not exist")
    if path.is_dir():
        zips = [path / n for n in MODEL_NAMES if (path / n).exists()]
        if not zips:
            raise ValueError(f"no {' / '.join(MODEL_NAMES)} in {path}")
        folder, model = path, zips[0]
    else:
        folder, model = path.parent, path
    if folder.name == "checkpoints" and not (folder / "meta.json").exists():
        folder = folder.parent  # a checkpoint of spine_gym.agents.train: the run's meta.json is there
    return folder, model


def policy_meta(path: str | Path) -> dict:
    """The ``meta.json`` of a policy (RL Zoo's ``args.yml`` without one; ``{}`` without either)."""
    folder, _ = policy_files(path)
    if (folder / "meta.json").exists():
        return json.loads((folder / "meta.json").read_text())
    if (folder / "args.yml").exists():
        return yaml.safe_load((folder / "args.yml").read_text()) or {}
    return {}


def trained_env_id(path: str | Path) -> str | None:
    """The env id a policy was trained on, as its ``meta.json`` (or ``args.yml``) records it; None
    if neither does."""
    meta = policy_meta(path)
    env = meta.get("env_id", meta.get("env"))
    return str(env) if env else None


def _env_spaces(env_id: str, env_kwargs: dict | None = None) -> tuple[gym.Space, gym.Space]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gymnasium's note that a -v0 id has a newer version
        env = gym.make(env_id, **(env_kwargs or {}))
    spaces = env.observation_space, env.action_space
    env.close()
    return spaces


def _model_spaces(model: Path) -> tuple[gym.Space, gym.Space]:
    """The observation and action spaces stored in an SB3 model file."""
    from stable_baselines3.common.save_util import json_to_data

    with zipfile.ZipFile(model) as zf:
        data = json_to_data(zf.read("data").decode())
    return data["observation_space"], data["action_space"]


def _shapes(spaces: tuple[gym.Space, gym.Space]) -> str:
    return f"observation {spaces[0].shape}, action {spaces[1].shape}"


def check_policy_env(path: str | Path, env_id: str, flag: str, env_kwargs: dict | None = None) -> None:
    """ValueError (one line) unless the policy at ``path`` can run on ``env_id``: its recorded env is
    ``env_id`` or has the same observation and action spaces (a tier of it); a policy without a
    record is compared by the spaces stored in its model file."""
    trained = trained_env_id(path)
    env = _env_spaces(env_id, env_kwargs)
    if trained == env_id:
        return
    if trained is not None:
        if trained in gym.envs.registry and _same(_env_spaces(trained), env):
            return
        raise ValueError(
            f"{flag}: {path} was trained on {trained}, not on {env_id} (pass --env {trained})"
        )
    try:
        model = _model_spaces(policy_files(path)[1])
    except (KeyError, zipfile.BadZipFile, ValueError) as e:
        raise ValueError(f"{flag}: {path} is not a saved SB3 model ({e})") from None
    if not _same(model, env):
        raise ValueError(f"{flag}: {path} has {_shapes(model)}; {env_id} has {_shapes(env)}")


def _same(a: tuple[gym.Space, gym.Space], b: tuple[gym.Space, gym.Space]) -> bool:
    return a[0].shape == b[0].shape and a[1].shape == b[1].shape
