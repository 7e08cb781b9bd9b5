"""Residual learning on top of a baseline controller (residual RL).

The learned policy does not drive the wires alone: the applied action is

    a = clip(a_base + scale · clip(a_res, -1, 1), -1, 1)

where ``a_base`` is the action of a classical controller (the tuned PID of
``spine_gym/controllers/tuned/baselines.yml``) and ``a_res`` the policy's output. The policy observes the
env's observation with ``a_base`` appended (one more entry per wire, in [-1, 1]), so it knows what the
baseline is about to do. The baseline keeps its integral action (precise holding, ramps); the
policy learns what the PID cannot do from the error alone — anticipating target moves from the
preview, pre-heating the wire that will be needed, shaping the heating pulse of a step.

* :class:`ResidualVecEnv` — an SB3 ``VecEnvWrapper`` for training; it sits between ``VecMonitor``
  and ``VecNormalize`` (so the baseline sees raw observations and the policy normalised ones).
  The baseline's memory is carried per sub-env and restarted when an episode ends; terminal
  observations in ``infos`` are augmented the same way (SB3 bootstraps truncated episodes from
  them).
* :class:`ResidualPolicy` — a saved residual model plus its baseline behind SB3's ``predict``,
  for the evaluation.
* :func:`build_base` — the baseline controller from a JSON-able spec (stored in the run's
  ``meta.json``), so the evaluation rebuilds exactly the controller the policy was trained with.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from spine_gym.controllers.registry import controller_kwargs, get_spec
from spine_gym.envs import base_id, config_of

from .zoo_config import ENV_ID

__all__ = ["ResidualVecEnv", "ResidualPolicy", "build_base", "base_spec", "combine"]

BASES = ("pid",)  # registry entries a residual may sit on (tuned, plain v_max/dt constructors)


def base_spec(
    kind: str,
    *,
    v_max: float,
    dt: float,
    temperature_limit: float,
    scale: float,
    env_id: str = ENV_ID,
    env_kwargs: dict | None = None,
    thermal_cutoff: float | None = None,
) -> dict:
    """JSON-able description of the baseline (tuned settings included) and the residual scale.

    The baseline's guard follows the registry's one rule
    (:func:`spine_gym.controllers.registry.controller_kwargs`): below ``temperature_limit`` [K], none
    (``None``) where the plant cuts hot wires itself at ``thermal_cutoff`` [K] (the ``-v2`` ids). For a
    spatial env (``env_id`` other than ``SmaSpine-v0``) the spec also holds the env id and kwargs: its
    controller is built from that env's layout and observation table."""
    if kind not in BASES:
        raise ValueError(f"residual base must be one of {BASES}, got {kind!r}")
    scale = float(scale)
    if not 0.0 < scale <= 2.0:
        raise ValueError(f"residual_scale must be in (0, 2], got {scale}")
    params = controller_kwargs(kind, env_id, None, temperature_limit, thermal_cutoff)
    guard = params.pop("temperature_limit", None)
    extra = {} if base_id(env_id) == ENV_ID else {"env_id": env_id, "env_kwargs": dict(env_kwargs or {})}
    return extra | {
        "kind": kind,
        "params": params,
        "v_max": float(v_max),
        "dt": float(dt),
        "temperature_limit": guard,  # as the evaluated baseline
        "scale": scale,
    }


def build_base(spec: dict):
    """The baseline controller of ``spec`` (see :func:`base_spec`), built from the registry."""
    if spec.get("kind") not in BASES:
        raise ValueError(f"residual base must be one of {BASES}, got {spec.get('kind')!r}")
    env_id = spec.get("env_id", ENV_ID)
    cls = get_spec(spec["kind"], env_id).cls
    if base_id(env_id) != ENV_ID:  # a spatial controller reads the env's layout and observation table
        cfg = config_of(env_id, **spec["env_kwargs"])
        return cls.from_config(cfg, **spec["params"], temperature_limit=spec["temperature_limit"])
    return cls(
        **spec["params"], v_max=spec["v_max"], dt=spec["dt"], temperature_limit=spec["temperature_limit"]
    )


def combine(base_action: np.ndarray, residual: np.ndarray, scale: float) -> np.ndarray:
    """``clip(base + scale · clip(residual, -1, 1), -1, 1)`` as float32."""
    res = np.clip(np.asarray(residual, dtype=np.float64), -1.0, 1.0)
    return np.clip(np.asarray(base_action, dtype=np.float64) + scale * res, -1.0, 1.0).astype(np.float32)


class ResidualVecEnv(VecEnvWrapper):
    """Baseline + residual action; observation = env observation ++ baseline action.

    Args:
        venv: the vector env (raw observations; e.g. ``VecMonitor`` over the native env).
        spec: the baseline spec of :func:`base_spec`.
    """

    def __init__(self, venv: VecEnv, spec: dict):
        self.spec = dict(spec)
        self.scale = float(spec["scale"])
        self.base = build_base(spec)
        self.n_act = int(np.prod(venv.action_space.shape))
        low = np.concatenate([venv.observation_space.low, -np.ones(self.n_act)]).astype(np.float32)
        high = np.concatenate([venv.observation_space.high, np.ones(self.n_act)]).astype(np.float32)
        super().__init__(venv, observation_space=spaces.Box(low, high, dtype=np.float32))
        self._mem = None
        self._base_action = np.zeros((self.num_envs, self.n_act), dtype=np.float32)

    def _augment(self, obs: np.ndarray, episode_start: np.ndarray) -> np.ndarray:
        a, self._mem = self.base.predict(obs, state=self._mem, episode_start=episode_start)
        self._base_action = np.asarray(a, dtype=np.float32).reshape(self.num_envs, self.n_act)
        return np.concatenate([obs, self._base_action], axis=1).astype(np.float32)

    def reset(self) -> np.ndarray:
        obs = self.venv.reset()
        self._mem = None
        return self._augment(obs, np.ones(self.num_envs, dtype=bool))

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(combine(self._base_action, actions, self.scale))

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        for i in np.flatnonzero(dones):
            term = infos[i].get("terminal_observation")
            if term is not None:  # the baseline's action on the last state, its memory continued
                a, _ = self.base.predict(term[None, :], state=self._mem[i : i + 1].copy())
                infos[i]["terminal_observation"] = np.concatenate([term, a.reshape(self.n_act)]).astype(
                    np.float32
                )
        return self._augment(obs, np.asarray(dones, dtype=bool)), rewards, dones, infos


class ResidualPolicy:
    """A residual model (a :class:`spine_gym.agents.zoo_config.SavedPolicy`) and its baseline, as one controller.

    ``predict`` takes the env's observation, computes the baseline action (the baseline keeps its
    memory internally; ``episode_start`` restarts it), appends it, asks the model for the residual
    and returns the combined action. Its ``state`` is always ``None``.
    """

    def __init__(self, model, spec: dict, name: str = "policy"):
        self.model = model
        self.spec = dict(spec)
        self.scale = float(spec["scale"])
        self.base = build_base(spec)
        self.name = name
        self.meta = getattr(model, "meta", {})
        self.env_kwargs = getattr(model, "env_kwargs", {})

    def reset(self) -> None:
        self.base.reset()
        if hasattr(self.model, "reset"):
            self.model.reset()

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        # the baseline checks shape and type, the model (SavedPolicy) that every entry is finite
        base_a, _ = self.base.predict(observation, episode_start=episode_start)
        single = np.ndim(observation) == 1
        obs2 = np.atleast_2d(np.asarray(observation, dtype=np.float32))
        base_a = np.asarray(base_a, dtype=np.float32).reshape(obs2.shape[0], -1)
        res, _ = self.model.predict(np.concatenate([obs2, base_a], axis=1), None, episode_start, deterministic)
        action = combine(base_a, np.asarray(res).reshape(base_a.shape), self.scale)
        return (action[0] if single else action), None

    def __repr__(self) -> str:
        return f"ResidualPolicy({self.name}, base={self.spec['kind']}, scale={self.scale})"
