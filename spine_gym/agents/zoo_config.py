"""The RL-Zoo-style configuration of the agents: env ids, algorithms and their hyperparameter files.

* Hyperparameter files in RL Zoo's format (``spine_gym/agents/hyperparams/{algo}.yml`` keyed by env id):
  :func:`load_hyperparams`, :func:`preprocess_hyperparams` (with ``lin_<x>`` schedules, ``normalize``
  as bool or dict string and ``policy_kwargs`` as a ``dict(...)`` string, as RL Zoo writes them);
  :data:`SPECIAL_KEYS`, the keys of an entry that are not arguments of the algorithm.
* The algorithms (:data:`ALGOS`, :func:`algo_class`) and env ids (:data:`ENV_IDS`, :data:`ENV_ID`, ...).
* ``--env-kwargs``/``--hyperparams`` ``key=value`` (or RL Zoo's ``key:value``) parsing (:class:`StoreDict`,
  :class:`spine_gym.cli_conventions.KeyValues`).

Loading saved policies, building controllers and running episodes live in :mod:`spine_gym.agents.runtime`.
"""

from __future__ import annotations

import ast
from collections.abc import Callable
from pathlib import Path

import yaml

from spine_gym.cli_conventions import KeyValues
from spine_gym.envs import ENV_SPECS

from .jax_algos import jax_algo_class

HYPERPARAMS_DIR = Path(__file__).parent / "hyperparams"
POLICIES_DIR = Path(__file__).parent / "policies"
ENV_ID = "SmaSpine-v0"  # the planar family's base id (its controller table, tuned file, shipped policies)
DEFAULT_ENV_ID = "SmaSpine-v2"  # what train, evaluate and tune run on without --env: the newest planar id
SPATIAL_ENV_ID = "SmaSpine3D-v0"  # one four-wire module
CHAIN_ENV_ID = "SmaSpineChain-v0"  # chained four-wire modules
ENV_IDS = tuple(ENV_SPECS)  # every registered id: -v0, and -v1/-v2 with their tiers, of the three families
SB3_ALGOS = ("ppo", "sac", "td3", "tqc")  # Stable-Baselines3 on torch (tqc: sb3-contrib)
#: Stable-Baselines3's JAX edition (``sbx-rl``, the ``jax`` extra; :mod:`spine_gym.agents.jax_algos`)
JAX_ALGOS = ("crossq", "droq", "sbx_sac", "sbx_tqc", "sbx_mbpo")
ALGOS = SB3_ALGOS + JAX_ALGOS
OFF_POLICY = ("sac", "td3", "tqc", *JAX_ALGOS)  # the algorithms with a replay buffer

# keys of a hyperparameter entry that are not constructor arguments of the algorithm
SPECIAL_KEYS = (
    "n_envs",
    "n_timesteps",
    "policy",
    "normalize",
    "env_kwargs",
    "vec_env",
    "residual",
    "residual_scale",
    "energy_budget",
    "lagrangian_init",
    "lagrangian_lr",
    "budget_episodes",
    "budget_window",
    "budget_scale",
    "budget_relabel",
    "obs_integral",
    "obs_integral_limit",
    "obs_history",
    "noise_type",
    "noise_std",
)


def algo_class(algo: str) -> type:
    """The Stable-Baselines3 (``tqc``: sb3-contrib; :data:`JAX_ALGOS`: ``sbx``) class of ``algo``.

    Imported here rather than at module level: this module is also the hyperparameter parser of
    tools that never build a model, and SB3 pulls in torch (``sbx`` JAX).
    """
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {ALGOS}, got {algo!r}")
    if algo in JAX_ALGOS:
        return jax_algo_class(algo)
    if algo == "tqc":
        from sb3_contrib import TQC

        return TQC
    import stable_baselines3

    return getattr(stable_baselines3, algo.upper())


#: the ``key=value``/``key:value`` argparse action (its older name)
StoreDict = KeyValues


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


def checked_number(value, ok: Callable[[float], bool], message: str) -> float:
    """``float(value)`` if ``value`` reads as a number for which ``ok`` holds; ValueError ``message``
    otherwise (a hyperparameter's value, checked)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(message) from None
    if not ok(number):
        raise ValueError(message)
    return number


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
    special.setdefault("energy_budget", None)  # "pid" or a number [J]: Lagrangian energy budget
    special.setdefault("lagrangian_init", 0.5)
    special.setdefault("lagrangian_lr", 0.5)
    special.setdefault("budget_episodes", 16)
    special.setdefault("budget_window", 32)  # finished episodes the dual step's mean energy is over
    special.setdefault("budget_scale", 1.0)  # the budget is this fraction of energy_budget's joules
    special.setdefault("budget_relabel", False)  # off-policy: replay rewards with the current multiplier
    special.setdefault("obs_integral", None)  # leak time constant [s] (or "inf") of spine_gym.agents.observations
    special.setdefault("obs_integral_limit", 300.0)  # its clip [deg s]
    special.setdefault("obs_history", None)  # k earlier frames of angle and action (spine_gym.agents.observations)
    special.setdefault("noise_type", None)  # "normal" or "ornstein-uhlenbeck": TD3's action noise
    special.setdefault("noise_std", 0.1)  # its standard deviation, in units of the action range [-1, 1]
    if special["residual"] in (None, "none", "None", False):
        special["residual"] = None
    if special["obs_integral"] in (None, "none", "None", False):
        special["obs_integral"] = None
    if special["obs_history"] in (None, "none", "None", False, 0):
        special["obs_history"] = None
    return hp, special
