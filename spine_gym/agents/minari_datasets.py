"""Demonstration datasets in Minari's format, recorded and read: the library behind ``spine-gym
datasets`` (:mod:`spine_gym.agents.datasets`) and what :mod:`spine_gym.agents.behaviour_cloning` loads.

One dataset per env id, recorded through :class:`minari.DataCollector` (observations, actions,
rewards, terminations, truncations and, unless ``--no-infos``, the env's ``info`` dicts), named
``spine_gym/<env id>/<controller>-v<version>`` (Minari's ``namespace/env/name-vN``): the
controller is a registry name (:func:`spine_gym.agents.registry.registry_for`: ``pid``, ``mpc_oracle``,
``mpc_estimated``, …) or a policy folder (:func:`spine_gym.agents.runtime.load_policy`; the dataset is
named after the folder). Each episode is one :func:`spine_gym.agents.runtime.run_episode` of the
controller with reset seed ``seed_base + i`` (Minari keeps each episode's seed):
:data:`DATASET_SEED_BASE` and above, below :data:`spine_gym.agents.runtime.VALIDATION_SEED_BASE` — disjoint
from the training and tuning seeds, the validation seeds and the evaluation suite's.

Besides what Minari stores (the env spec with its keyword arguments, the spaces, the algorithm
name, the evaluation env spec) the dataset's metadata holds ``spine_gym`` (:func:`load_metadata`):
env id, tier, env kwargs, the actuator envelope (:func:`spine_gym.agents.runtime.envelope_of`: the
voltage ceiling, the plant's thermal cut-off, who cuts a hot wire), controller name and settings,
the spine_gym version and git commit, the seeds and each episode's RMSE and energy.

Datasets go to Minari's data directory (``MINARI_DATASETS_PATH``, else ``~/.minari/datasets``) or
``--data-path``. :func:`plan` refuses an existing dataset id unless ``overwrite`` (it is replaced
once the new recording has finished). Load one with ``minari.load_dataset(id)``; :func:`transitions` gives
its (observation, action) pairs, what :mod:`spine_gym.agents.behaviour_cloning` fits.
"""

from __future__ import annotations

import contextlib
import os
import re
import subprocess
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import minari
import numpy as np
from tqdm import tqdm

import spine_gym
from spine_gym.controllers.registry import GUARD_MARGIN_K, get_spec, load_tuned, registry_for
from spine_gym.envs import ENV_SPECS, tier_of

from . import runtime
from .metrics import episode_metrics

__all__ = [
    "DATASET_SEED_BASE",
    "MAX_DATASET_EPISODES",
    "NAMESPACE",
    "DatasetPlan",
    "dataset_id",
    "data_dir",
    "dataset_dir",
    "datasets_path",
    "plan",
    "record",
    "load_metadata",
    "transitions",
]

DATASET_SEED_BASE = 300_000  # reset seeds of dataset episodes: above DAgger's (200 000 …), below validation's
# the seeds stay below VALIDATION_SEED_BASE (500 000), itself below the suite's EVAL_SEED_BASE (900 000)
MAX_DATASET_EPISODES = runtime.VALIDATION_SEED_BASE - DATASET_SEED_BASE
NAMESPACE = "spine_gym"
METADATA_KEY = "spine_gym"  # the dataset-metadata entry this module writes
REPO_ROOT = Path(__file__).resolve().parents[2]


@dataclass
class DatasetPlan:
    """One dataset to record, checked: everything :func:`record` needs, built before any file is written."""

    env_id: str
    controller: str
    episodes: int
    seed_base: int
    env_kwargs: dict
    dataset_id: str
    settings: dict
    policy: object = field(repr=False)
    env: object = field(repr=False)

    @property
    def seeds(self) -> list[int]:
        return [self.seed_base + i for i in range(self.episodes)]


def _safe_name(controller: str) -> str:
    """The dataset name of a controller: the registry name, or a policy folder's name (``[-\\w]``)."""
    name = Path(controller).name if _is_path(controller) else controller
    return re.sub(r"[^-\w]", "_", name) or "policy"


def _is_path(controller: str) -> bool:
    return os.sep in controller or Path(controller).exists()


def dataset_id(env_id: str, controller: str, version: int = 0) -> str:
    """``spine_gym/<env id>/<controller>-v<version>`` (a policy folder: its folder name)."""
    return f"{NAMESPACE}/{env_id}/{_safe_name(controller)}-v{int(version)}"


def data_dir() -> Path:
    """Minari's data directory: ``MINARI_DATASETS_PATH``, else ``~/.minari/datasets`` (not created here)."""
    path = os.environ.get("MINARI_DATASETS_PATH")
    return Path(path) if path else Path.home() / ".minari" / "datasets"


def dataset_dir(did: str) -> Path:
    """Where Minari keeps dataset ``did``."""
    return data_dir() / did


def _check_int(name: str, value, low: int, high: int) -> None:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or not low <= value <= high:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")


def _make(env_id: str, env_kwargs: dict):
    try:
        return runtime.make_env(env_kwargs, env_id=env_id)
    except TypeError as e:  # an unknown keyword argument of the env class
        raise ValueError(f"env_kwargs {env_kwargs} do not fit {env_id}: {e}") from None


def _controller(controller: str, env_id: str, env_kwargs: dict):
    """(env, its kwargs, controller, settings) of a registry name or a policy folder (the env gets
    the policy's observation kwargs too); ValueError otherwise."""
    if controller in registry_for(env_id):
        env = _make(env_id, env_kwargs)
        spec = get_spec(controller, env_id)
        settings = {
            "kind": "registry",
            "class": spec.cls.__name__,
            "description": spec.description,
            "kwargs": dict(spec.kwargs),
            "tuned": load_tuned(env_id=env_id)[controller] if spec.tuned else None,
        }
        ctrl = runtime.build_controller(controller, env)  # no guard of its own where the plant cuts
        settings["temperature_guard_margin_K"] = GUARD_MARGIN_K if runtime.controller_cutoff(ctrl) else None
        return env, env_kwargs, ctrl, settings
    if not _is_path(controller):
        raise ValueError(
            f"controller must be one of {sorted(registry_for(env_id))} for {env_id} or a policy folder, "
            f"got {controller!r}"
        )
    policy = runtime.load_policy(controller)
    # what the policy observes
    env_kwargs = runtime.policy_env_kwargs(policy.env_kwargs, env_kwargs)
    env = _make(env_id, env_kwargs)
    obs, _ = env.reset(seed=DATASET_SEED_BASE)
    try:
        policy.predict(obs[None, :], None, np.ones((1,), dtype=bool), True)
    except Exception as e:  # noqa: BLE001 - any failure means the policy does not fit this env
        raise ValueError(f"policy {controller} does not fit {env_id}'s observation: {e}") from None
    settings = {"kind": "policy", "path": str(Path(controller).resolve()), "meta": policy.meta}
    return env, env_kwargs, policy, settings


def plan(
    env_id: str,
    controller: str,
    episodes: int,
    *,
    env_kwargs: dict | None = None,
    seed_base: int = DATASET_SEED_BASE,
    version: int = 0,
    overwrite: bool = False,
) -> DatasetPlan:
    """Check every argument and build the env and the controller (no file is written); ValueError
    naming the argument otherwise, also if the dataset id exists in the data directory and not
    ``overwrite``."""
    if env_id not in ENV_SPECS:
        raise ValueError(f"env_id must be a registered spine_gym id {sorted(ENV_SPECS)}, got {env_id!r}")
    _check_int("episodes", episodes, 1, MAX_DATASET_EPISODES)
    _check_int("seed_base", seed_base, DATASET_SEED_BASE, runtime.VALIDATION_SEED_BASE - episodes)
    _check_int("version", version, 0, 10**6)
    env_kwargs = dict(env_kwargs or {})
    did = dataset_id(env_id, controller, version)
    if dataset_dir(did).exists() and not overwrite:
        raise ValueError(f"dataset {did} exists in {data_dir()}; pass overwrite (--overwrite) to replace it")
    env, env_kwargs, policy, settings = _controller(controller, env_id, env_kwargs)
    return DatasetPlan(
        env_id, controller, int(episodes), int(seed_base), env_kwargs, did, settings, policy, env
    )


def _git_commit() -> str | None:
    """The checkout's commit (``+dirty`` with uncommitted changes), None outside a git checkout."""
    try:
        head = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "rev-parse", "HEAD"], capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True, text=True, check=True,
        ).stdout.strip()  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + ("+dirty" if dirty else "")


def _metadata(p: DatasetPlan, rows: list[dict], command: str) -> dict:
    return {
        "env_id": p.env_id,
        "tier": tier_of(p.env_id),
        "env_kwargs": p.env_kwargs,
        "envelope": runtime.envelope_of(p.env, runtime.controller_cutoff(p.policy)),
        "controller": p.controller,
        "controller_settings": p.settings,
        "spine_gym_version": spine_gym.__version__,
        "git_commit": _git_commit(),
        "seed_base": p.seed_base,
        "seeds": p.seeds,
        "command": command,
        "episodes": rows,
        "mean_rmse": float(np.mean([r["rmse"] for r in rows])),
        "mean_energy_J": float(np.mean([r["energy_J"] for r in rows])),
    }


def record(p: DatasetPlan, *, record_infos: bool = True, progress: bool = True, command: str = ""):
    """Record the planned episodes and write the dataset; returns the :class:`minari.MinariDataset`.

    An existing dataset of the same id (a plan made with ``overwrite``) is deleted only after the
    recording has finished."""
    collector = minari.DataCollector(p.env, record_infos=record_infos)
    limit, dt = runtime.env_temperature_limit(p.env), float(p.env.control_period)
    rows = []
    try:
        for seed in tqdm(p.seeds, desc=p.dataset_id, unit="episode", disable=not progress):
            traj = runtime.run_episode(collector, p.policy, seed=seed)
            m = episode_metrics(traj, temperature_limit=limit, dt=dt)
            rows.append({"seed": seed, "rmse": m["rmse_deg"], "energy_J": m["energy_J"]})
        if dataset_dir(p.dataset_id).exists():
            minari.delete_dataset(p.dataset_id)
        with warnings.catch_warnings():  # no e-mail address to give
            warnings.filterwarnings("ignore", message="`author_email` is set to None")
            dataset = collector.create_dataset(
                dataset_id=p.dataset_id,
                eval_env=p.env.spec,
                algorithm_name=p.controller if p.settings["kind"] == "registry" else f"policy:{p.controller}",
                author="spine_gym spine_gym.agents.datasets",
                code_permalink=f"spine_gym {spine_gym.__version__} @ {_git_commit() or 'unknown commit'}",
                description=_description(p),
                requirements=[f"spine_gym=={spine_gym.__version__}"],
            )
        dataset.storage.update_metadata({METADATA_KEY: _metadata(p, rows, command)})
    finally:
        collector.close()
    return dataset


def _description(p: DatasetPlan) -> str:
    return (
        f"{p.episodes} episodes of the {p.controller!r} controller on {p.env_id} (tier {tier_of(p.env_id)}, "
        f"env kwargs {p.env_kwargs}), reset seeds {p.seed_base}..{p.seed_base + p.episodes - 1}; "
        f"recorded by python -m spine_gym.agents.datasets."
    )


def load_metadata(dataset) -> dict:
    """The ``spine_gym`` metadata of a dataset this module recorded (a dataset or its id)."""
    if isinstance(dataset, str):
        dataset = minari.load_dataset(dataset)
    meta = dataset.storage.metadata
    if METADATA_KEY not in meta:
        raise ValueError(f"dataset {meta.get('dataset_id')} was not recorded by spine_gym.agents.datasets")
    return meta[METADATA_KEY]


def transitions(dataset) -> tuple[np.ndarray, np.ndarray]:
    """Every (observation, action) pair of a dataset: ``(n, obs dim)`` and ``(n, action dim)`` arrays
    (an episode's observation before each of its actions)."""
    obs, act = [], []
    for ep in dataset.iterate_episodes():
        obs.append(np.asarray(ep.observations)[:-1])
        act.append(np.asarray(ep.actions))
    return np.concatenate(obs), np.concatenate(act)


@contextlib.contextmanager
def datasets_path(path: str | Path | None):
    """Point Minari at ``path`` (``MINARI_DATASETS_PATH``) inside the block; None: leave it."""
    if path is None:
        yield
        return
    old = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(Path(path).resolve())
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = old
