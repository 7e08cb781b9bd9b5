"""The shared runtime of the agents CLIs (no CLI here): envs, controllers, policies, episodes.

* :func:`make_env` — a plain env (``SmaSpine-v0`` or a spatial id); :func:`env_temperature_limit`,
  :func:`env_id_of`, :func:`tracking_keys`.
* :func:`build_controller` — any :data:`spine_gym.controllers.registry.REGISTRY` entry configured for an env
  (its v_max, control period, temperature guard, tuned settings from :func:`load_tuned`).
* :class:`SavedPolicy`, :func:`load_policy` — a trained model plus its ``VecNormalize``
  statistics behind SB3's ``predict`` interface (a residual model comes back as
  :class:`spine_gym.agents.residual.ResidualPolicy`, one trained with the integral-of-error observation
  wrapped in :class:`spine_gym.agents.observations.IntegralObsPolicy`, one with the frame history in
  :class:`spine_gym.agents.observations.HistoryObsPolicy`), so the evaluation treats it like any controller.
* :func:`run_episode` — one episode of a controller in an env, as a :class:`Trajectory`;
  :func:`validation_scores` — mean RMSE and energy over the validation episodes.

:mod:`spine_gym.agents.evaluate`, :mod:`spine_gym.agents.tune`, :mod:`spine_gym.agents.train` and :mod:`spine_gym.agents.selection` import
from here; this module imports no CLI.
"""

from __future__ import annotations

import pickle
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import spine_gym  # noqa: F401 - registers the env
from spine_gym.controllers import PRIVILEGED_MODES, MPPIConfig, MPPIController
from spine_gym.controllers.registry import GUARD_MARGIN_K, REGISTRY, controller_kwargs, get_spec, load_tuned
from spine_gym.envs import config_of

from .metrics import Trajectory, episode_metrics
from .observations import feature_policy, specs_from_meta
from .policy_files import policy_files, policy_meta
from .residual import ResidualPolicy
from .scenarios import EVAL_SEED_BASE, Scenario
from .zoo_config import ALGOS, ENV_ID, algo_class

__all__ = [
    "make_env",
    "env_id_of",
    "tracking_keys",
    "env_temperature_limit",
    "env_thermal_cutoff",
    "ENVELOPE_COLUMNS",
    "envelope_of",
    "controller_cutoff",
    "build_controller",
    "controller_for",
    "energy_weighted_oracle",
    "ORACLE_NAMES",
    "run_episode",
    "SavedPolicy",
    "load_policy",
    "wrap_policy",
    "vecnormalize_candidates",
    "load_tuned",
    "GUARD_MARGIN_K",
    "OBSERVATION_KWARGS",
    "TASK_KWARGS",
    "evaluation_env_kwargs",
    "policy_env_kwargs",
    "VALIDATION_SEED_BASE",
    "validation_scores",
    "validation_metrics",
]


# the planar registry's privileged MPPI entries (the env's true state): energy_weighted_oracle builds them
ORACLE_NAMES = tuple(
    name
    for name, spec in REGISTRY.items()
    if spec.cls is MPPIController and spec.kwargs.get("mode") in PRIVILEGED_MODES
)


def make_env(env_kwargs: dict | None = None, env_id: str = ENV_ID):
    """A plain ``env_id`` env (no time-limit surprises: the episode length is the env's)."""
    return gym.make(env_id, **(env_kwargs or {})).unwrapped


def env_id_of(env) -> str:
    """The registered id of an env made by :func:`make_env` (``SmaSpine-v0`` if it has no spec)."""
    spec = getattr(getattr(env, "unwrapped", env), "spec", None)
    return spec.id if spec is not None else ENV_ID


def tracking_keys(env) -> tuple[str, str]:
    """The info keys (tracked quantity, its target) of an env: the task and target entries of its
    declarative table (``angle_deg``, ``target_deg`` for ``SmaSpine-v0``)."""
    table = getattr(env, "unwrapped", env).config.table()
    target = [e.key for e in table.entries if e.source == "target"]
    return table.task.key, target[0]


def run_episode(
    env, policy, scenario: Scenario | None = None, deterministic: bool = True, *, seed: int | None = None
) -> Trajectory:
    """Roll ``policy`` through one scenario and return its :class:`Trajectory`.

    The env is reset with ``scenario.seed`` and ``scenario.reset_options()``, or, without a
    scenario, with ``seed`` alone (an episode drawn by the env's own samplers); the policy's
    memory is restarted through ``episode_start`` (and ``reset()`` if it has one).
    """
    if (scenario is None) == (seed is None):
        raise ValueError("give either a scenario or a seed")
    if hasattr(policy, "bind"):  # controllers that plan on the env (MPC) follow it
        policy.bind(env)
    if hasattr(policy, "reset"):
        policy.reset()
    if scenario is not None:
        obs, _ = env.reset(seed=scenario.seed, options=scenario.reset_options())
    else:
        obs, _ = env.reset(seed=seed)
    state = None
    start = np.ones((1,), dtype=bool)
    infos, actions, rewards = [], [], []
    shape = env.action_space.shape
    while True:
        action, state = policy.predict(
            obs[None, :], state=state, episode_start=start, deterministic=deterministic
        )
        action = np.asarray(action, dtype=np.float32).reshape(shape)
        start = np.zeros((1,), dtype=bool)
        obs, reward, terminated, truncated, info = env.step(action)
        infos.append(info)
        actions.append(action)
        rewards.append(reward)
        if terminated or truncated:
            break
    return Trajectory.from_infos(infos, actions, rewards, keys=tracking_keys(env))


# env kwargs that change what a controller observes, not the task: a reference PID runs without them
OBSERVATION_KWARGS = ("target_preview",)
# env kwargs that only shape the training distribution of episodes; the evaluation suite sets the
# episode itself (targets, loads, plant), so a policy is evaluated without them
TASK_KWARGS = (
    "episode_duration",
    "target_range",
    "target_kinds",
    "sine_period_range",
    "tip_force_range",
    "tip_force_count",
    "tip_force_duration",
    "payload_range",
    "domain_randomization",
)


def evaluation_env_kwargs(policy_env_kwargs: dict) -> dict:
    """A policy's training env kwargs without :data:`TASK_KWARGS` (what the suite's env keeps)."""
    return {k: v for k, v in policy_env_kwargs.items() if k not in TASK_KWARGS}


def policy_env_kwargs(own: dict, given: dict | None = None) -> dict:
    """The one rule for the env a saved policy runs in: the caller's ``given`` env kwargs (the
    distribution to run on) with what the suite keeps of the policy's training kwargs ``own``
    (:func:`evaluation_env_kwargs`: what it observes, its voltage ceiling, its reward weights) on
    top: a policy always sees the observation it was trained on, whatever the distribution."""
    return {**(given or {}), **evaluation_env_kwargs(own)}


VALIDATION_SEED_BASE = 500_000  # < EVAL_SEED_BASE (900 000), > training/tuning seeds
MAX_VALIDATION_EPISODES = EVAL_SEED_BASE - VALIDATION_SEED_BASE  # the seeds stay below the suite's


def validation_metrics(
    policy, n_episodes: int, env_kwargs: dict | None = None, env_id: str = ENV_ID, *, progress: str = ""
) -> list[dict]:
    """:func:`spine_gym.agents.metrics.episode_metrics` of ``policy`` on each of the ``n_episodes`` validation
    episodes of ``env_id`` (the env's own samplers, reset seeds ``VALIDATION_SEED_BASE + i``);
    ``progress``: the description of a progress bar over the episodes (none if empty)."""
    if not 1 <= n_episodes <= MAX_VALIDATION_EPISODES:
        raise ValueError(f"n_episodes must be in [1, {MAX_VALIDATION_EPISODES}], got {n_episodes}")
    env = make_env(env_kwargs or {}, env_id=env_id)
    limit, dt = env_temperature_limit(env), float(env.control_period)
    episodes = tqdm(range(n_episodes), desc=progress, unit="episode", leave=False, disable=not progress)
    rows = [
        episode_metrics(
            run_episode(env, policy, seed=VALIDATION_SEED_BASE + i), temperature_limit=limit, dt=dt
        )
        for i in episodes
    ]
    env.close()
    return rows


def validation_scores(
    policy, n_episodes: int, env_kwargs: dict | None = None, env_id: str = ENV_ID
) -> tuple[float, float]:
    """Mean RMSE (the env's unit: deg, mm for the chain) and mean energy [J] of ``policy`` over the
    validation episodes of ``env_id``."""
    rows = validation_metrics(policy, n_episodes, env_kwargs, env_id)
    return float(np.mean([r["rmse_deg"] for r in rows])), float(np.mean([r["energy_J"] for r in rows]))


def env_temperature_limit(env) -> float:
    """The env's wire-temperature limit [K] (the threshold of ``info['cost']``)."""
    for attr in ("temperature_limit", "T_limit", "temp_limit"):
        if hasattr(env, attr):
            return float(getattr(env, attr))
    raise AttributeError("the env exposes no temperature_limit attribute")


def env_thermal_cutoff(env) -> float | None:
    """The env's driver cut-off [K] (``-v2`` ids), ``None`` if its plant has none."""
    for e in (env, getattr(env, "unwrapped", env)):
        if hasattr(e, "thermal_cutoff"):
            return e.thermal_cutoff
    return None


#: the keys of :func:`envelope_of`: the envelope columns of the evaluation and benchmark tables
ENVELOPE_COLUMNS = ("v_max_V", "cutoff_K", "guard")


def envelope_of(env, controller_cutoff: float | None = None) -> dict:
    """The actuator envelope a controller meets on ``env``: ``v_max_V`` (the env's ``v_max``: the
    voltage of action +1 on a full-length wire; the chain's shorter wires get ``v_max`` × their
    length / L0, ``config.volt_coef``),
    ``cutoff_K`` (the plant's thermal cut-off, ``None`` if it has none) and ``guard``, who cuts a hot
    wire and where: ``"plant 418 K"`` (the env's driver, the same for every controller),
    ``"controller 418 K"`` (the controller's own guard at ``controller_cutoff`` [K], on its observed
    temperature) or ``"none"``."""
    cutoff = env_thermal_cutoff(env)
    if cutoff is not None:
        guard = f"plant {cutoff:g} K"
    elif controller_cutoff is not None:
        guard = f"controller {float(controller_cutoff):g} K"
    else:
        guard = "none"
    v_max = float(getattr(env, "unwrapped", env).config.v_max)
    return {"v_max_V": v_max, "cutoff_K": None if cutoff is None else float(cutoff), "guard": guard}


def controller_cutoff(controller) -> float | None:
    """The temperature [K] at which ``controller``'s own guard cuts a wire (a registry controller's
    ``temperature_limit``), ``None`` if it has none (a learned policy, a controller without guard)."""
    limit = getattr(controller, "temperature_limit", None)
    return None if limit is None else float(limit)


def build_controller(name: str, env, tuned: dict | None = None):
    """Registered controller ``name`` of the env's registry (:func:`spine_gym.controllers.registry.registry_for`)
    configured for ``env``.

    ``tuned`` overrides the tuned settings of :func:`load_tuned` (``{name: {...}}``).
    """
    env_id = env_id_of(env)
    spec = get_spec(name, env_id)
    kwargs = controller_kwargs(name, env_id, tuned, env_temperature_limit(env), env_thermal_cutoff(env))
    if spec.from_env:
        return spec.cls.from_env(env, **kwargs)
    if spec.plans_on_env:
        return spec.cls(env.unwrapped.config, env=env, **kwargs)
    return spec.cls(v_max=float(env.v_max), dt=float(env.control_period), **kwargs)


def controller_for(
    name: str, env_id: str = ENV_ID, env_kwargs: dict | None = None, tuned: dict | None = None
):
    """:func:`build_controller` for an env of ``env_id`` made with ``env_kwargs``, read from its
    configuration (:func:`spine_gym.envs.config_of`) without making the env; only a planner that
    plans on the env itself (the MPC entries) gets a probe env."""
    spec = get_spec(name, env_id)
    if spec.plans_on_env or not hasattr(spec.cls, "from_config") and spec.from_env:
        probe = make_env(env_kwargs, env_id=env_id)
        ctrl = build_controller(name, probe, tuned)
        probe.close()
        return ctrl
    cfg = config_of(env_id, **(env_kwargs or {}))
    kwargs = controller_kwargs(name, env_id, tuned, cfg.temperature_limit, cfg.thermal_cutoff)
    if spec.from_env:
        return spec.cls.from_config(cfg, **kwargs)
    return spec.cls(v_max=float(cfg.v_max), dt=float(cfg.control_period), **kwargs)


# --------------------------------------------------------------------------- saved policies
class SavedPolicy:
    """A trained SB3 model and its observation normalisation, as a ``predict``-able controller.

    Args:
        model: the loaded SB3 algorithm (``PPO``/``SAC``/``TD3``).
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


def energy_weighted_oracle(env, w_energy: float, name: str = "mpc_oracle") -> MPPIController:
    """The registry's privileged MPC ``name`` (one of :data:`ORACLE_NAMES`: ``mpc_oracle``,
    ``mpc_oracle_causal``) for the planar ``env`` with the energy weight ``w_energy`` [1/J] of its
    cost (the other settings its defaults): the expert of ``scripts/studies/distill.py`` and the trade-off
    sweep of ``scripts/studies/ceiling.py``; its guard the registry's, :func:`controller_kwargs`)."""
    if name not in ORACLE_NAMES:
        raise ValueError(f"name must be one of {ORACLE_NAMES}, got {name!r}")
    kwargs = controller_kwargs(name, env_id_of(env), None, env_temperature_limit(env), env_thermal_cutoff(env))
    return MPPIController(env.config, env=env, settings=MPPIConfig(w_energy=float(w_energy)), **kwargs)


def vecnormalize_candidates(model_path: Path) -> list[Path]:
    """Where :mod:`spine_gym.agents.train` puts the ``VecNormalize`` statistics of ``model_path``, best first.

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
    """Load a model saved by :mod:`spine_gym.agents.train` (a run folder, a shipped folder or a ``.zip``).

    A folder must hold ``model.zip`` (or ``best_model.zip``/``<env id>.zip``), optionally
    ``vecnormalize.pkl`` and ``meta.json``. For a ``.zip`` file the ``VecNormalize`` statistics
    are looked up beside it (``vecnormalize.pkl`` or the checkpoint's ``*_vecnormalize_*``), and
    a checkpoint in a run's ``checkpoints/`` reads the run's ``meta.json``.
    """
    _, model_path = policy_files(path)
    path = Path(path)
    meta = policy_meta(path)
    algo = str(meta.get("algo", "")).lower()
    if algo not in ALGOS:
        # guess from the file (SAC has critic weights)
        with zipfile.ZipFile(model_path) as zf:
            data = zf.read("data").decode()
        algo = "sac" if "ent_coef" in data and "target_entropy" in data else "ppo"
    model = algo_class(algo).load(model_path, device=device)
    obs_rms, clip_obs, eps = None, 10.0, 1e-8
    for c in vecnormalize_candidates(model_path):
        if c.exists():
            with open(c, "rb") as f:
                vn = pickle.load(f)
            obs_rms, clip_obs, eps = vn.obs_rms, vn.clip_obs, vn.epsilon
            break
    meta.setdefault("algo", algo)
    return wrap_policy(SavedPolicy(model, obs_rms, clip_obs, eps, meta=meta, name=name or path.stem))


def wrap_policy(policy: SavedPolicy):
    """``policy`` inside the observation wrappers its ``meta`` names (residual baseline, integral of
    the error, frame history), so it sees what it was trained on."""
    meta = policy.meta
    # the model sees [obs, residual's base action, integral, frame history] (the training env's order)
    policy = feature_policy(policy, specs_from_meta(meta))
    if meta.get("residual"):
        return ResidualPolicy(policy, meta["residual"], name=policy.name)
    return policy
