"""Stable-Baselines3 ``VecEnv`` over the native vector env (imports stable_baselines3).

SB3 algorithms take a ``VecEnv`` whose ``step_wait`` returns ``(obs, rewards, dones, infos)`` with
a list of per-env info dicts, resets finished environments in the same step and puts the last
observation of the finished episode in ``infos[i]["terminal_observation"]`` and
``infos[i]["TimeLimit.truncated"]`` (``truncated and not terminated``), exactly as SB3's own
``DummyVecEnv`` does. :class:`SmaSpineSB3VecEnv` gives that over
:class:`~spine_gym.envs.planar_env.SmaSpineVectorEnv` run in ``AutoresetMode.SAME_STEP``, so the
physics of all environments stays one numba call per step, and the per-env info dicts come
straight from the vector env's table rows (:meth:`~spine_gym.envs.spine_vector_env.SpineVectorEnv.step_arrays`,
no Gymnasium info dict in between); they fill themselves on first use
(:class:`spine_gym.envs._infos.RowInfo`: SB3's algorithms and wrappers read only a few keys of
most of them, so most are never filled). It composes with
``VecMonitor`` and ``VecNormalize``::

    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize
    from spine_gym.envs.sb3 import SmaSpineSB3VecEnv

    venv = VecNormalize(VecMonitor(SmaSpineSB3VecEnv(16, seed=0)))
    PPO("MlpPolicy", venv).learn(100_000)

(:func:`make_sb3_vec_env` builds that stack.) The plain route also works:
``stable_baselines3.common.env_util.make_vec_env("SmaSpine-v0", n_envs=8)`` (a ``DummyVecEnv`` of
single envs; slower, same numbers).

Per-env infos hold the single env's keys (``status_text`` too, on a failed step); for a finished
episode they are the infos of its last step (plus ``terminal_observation``), and the reset info of
the new episode is in ``reset_infos[i]`` (SB3's convention).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvStepReturn

from . import ENV_ID
from .config import RESET_OPTION_KEYS
from .ids import ENV_SPECS
from .planar_env import SmaSpineVectorEnv
from .spatial_env import SmaSpine3DVectorEnv, SmaSpineChainVectorEnv

__all__ = ["SmaSpineSB3VecEnv", "make_sb3_vec_env", "VECTOR_ENVS"]

VECTOR_ENVS = {  # family -> its vector env class (an id adds its registration's keyword arguments)
    "SmaSpine": SmaSpineVectorEnv,
    "SmaSpine3D": SmaSpine3DVectorEnv,
    "SmaSpineChain": SmaSpineChainVectorEnv,
}


class SmaSpineSB3VecEnv(VecEnv):
    """SB3 ``VecEnv`` of ``num_envs`` environments of ``env_id`` stepped by the native vector env.

    Args:
        num_envs: number of environments.
        seed: seed of the first reset (env i gets ``seed + i``); ``VecEnv.seed`` works as usual.
        env_id: a registered id (:data:`spine_gym.envs.ENV_SPECS`; default ``"SmaSpine-v0"``); its
            registration's keyword arguments apply, as in ``gym.make_vec``.
        **env_kwargs: arguments of the env, over the registration's (e.g. :class:`~spine_gym.envs.SmaSpineEnv`; and
            ``parallel``, ``max_episode_steps`` of the vector env).
    """

    def __init__(self, num_envs: int = 1, seed: int | None = None, env_id: str = ENV_ID, **env_kwargs):
        if env_id not in ENV_SPECS:
            raise ValueError(f"env_id must be one of {sorted(ENV_SPECS)}, got {env_id!r}")
        spec = ENV_SPECS[env_id]
        kwargs = {**spec.kwargs, **env_kwargs}
        self.venv = VECTOR_ENVS[spec.family](num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
        super().__init__(num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self.metadata = {**self.metadata, "render_fps": self.venv.metadata["render_fps"]}
        if seed is not None:
            self.seed(seed)
        self._actions: np.ndarray | None = None

    # ------------------------------------------------------------------ VecEnv API
    def reset(self):
        """Reset every env with the seeds/options set by ``seed()``/``set_options()`` (used once)."""
        options: dict[str, list] = {}
        for i, opt in enumerate(self._options):
            for key, value in (opt or {}).items():
                if key not in RESET_OPTION_KEYS:
                    raise ValueError(f"unknown reset option {key!r}; valid keys: {RESET_OPTION_KEYS}")
                options.setdefault(key, [None] * self.num_envs)[i] = value
        obs, _ = self.venv.reset(seed=list(self._seeds), options=options)
        self.reset_infos = self.venv.row_infos()
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        """One step of every env: the vector env's fresh arrays and per-env dicts that fill
        themselves from its table rows on first use (:class:`spine_gym.envs._infos.RowInfo`)."""
        if self._actions is None:
            raise RuntimeError("step_async() must be called before step_wait()")
        out = self.venv.step_arrays(self._actions)
        self._actions = None
        truncated = (out.truncated & ~out.terminated).tolist()
        infos = self.venv.row_infos(out.rows, out.status, truncated)
        if out.final is not None:
            f = out.final
            done = f.env_ids.tolist()
            finals = self.venv.row_infos(f.rows, f.status, [truncated[i] for i in done])
            for d, i, obs, reset_info in zip(
                finals,
                done,
                f.obs,
                self.venv.row_infos(out.rows[f.env_ids], out.status[f.env_ids]),
                strict=True,
            ):
                self.reset_infos[i] = reset_info
                d["terminal_observation"] = obs
                infos[i] = d
        return out.obs, out.reward.astype(np.float32), out.terminated | out.truncated, infos

    def close(self) -> None:
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.render_mode != "rgb_array":
            return [None] * self.num_envs
        return list(self.venv.render())

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        return list(self._get_indices(indices))

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """Each environment's value of an attribute, as ``DummyVecEnv`` asks each single env:
        per-env spaces, generators, seeds, states and episodes, the shared configuration
        otherwise (:meth:`~spine_gym.envs.spine_vector_env.SpineVectorEnv.get_attr`)."""
        values = self.venv.get_attr(attr_name)
        return [values[i] for i in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the underlying vector env (shared by all environments)."""
        if indices is not None and sorted(self._indices(indices)) != list(range(self.num_envs)):
            raise ValueError("the environments share one configuration: set_attr applies to all of them")
        setattr(self.venv, attr_name, value)

    def env_method(
        self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs
    ) -> list:
        """Call a method of the underlying vector env once; its result is repeated per index."""
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices: VecEnvIndices = None) -> list[bool]:
        """No sub-env is wrapped (there are no per-env Gymnasium objects)."""
        return [False for _ in self._indices(indices)]


def make_sb3_vec_env(
    num_envs: int = 1,
    seed: int | None = None,
    *,
    monitor: bool = True,
    normalize: bool | dict = False,
    env_kwargs: dict | None = None,
    env_id: str = ENV_ID,
) -> VecEnv:
    """:class:`SmaSpineSB3VecEnv`, optionally wrapped in ``VecMonitor`` and ``VecNormalize``.

    Args:
        num_envs: number of environments.
        seed: seed of the first reset (env i gets ``seed + i``).
        monitor: wrap in ``VecMonitor`` (episode return/length in ``info["episode"]``).
        normalize: ``True`` or a dict of ``VecNormalize`` keyword arguments.
        env_kwargs: arguments of the env (:class:`~spine_gym.envs.SmaSpineEnv` by default).
        env_id: which env (see :class:`SmaSpineSB3VecEnv`).
    """
    env: VecEnv = SmaSpineSB3VecEnv(num_envs, seed=seed, env_id=env_id, **(env_kwargs or {}))
    if monitor:
        env = VecMonitor(env)
    if normalize:
        env = VecNormalize(env, **(normalize if isinstance(normalize, dict) else {}))
    return env
