"""Training envs for Stable-Baselines3: the native vector env behind SB3's ``VecEnv`` interface.

``kind="native"`` builds the env's native vector env (all sub-envs stepped by one parallel numba call)
through the adapter :class:`spine_gym.envs.sb3.SmaSpineSB3VecEnv`; ``kind="dummy"`` builds SB3's ``DummyVecEnv``
of single ``SmaSpineEnv`` s (one Python step per sub-env; used for the evaluation callback).
Both are wrapped in ``VecMonitor`` so episode returns and lengths reach the logger.
"""

from __future__ import annotations

from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv, VecMonitor

import spine_gym  # noqa: F401 - registers SmaSpine-v0

from .zoo_config import ENV_ID, ENV_IDS


def _native(env_id: str, n_envs: int, seed: int, env_kwargs: dict) -> VecEnv:
    from spine_gym.envs.sb3 import SmaSpineSB3VecEnv

    if env_id not in ENV_IDS:
        raise ValueError(f"the native vector envs are {ENV_IDS}; use kind='dummy' for {env_id!r}")
    return SmaSpineSB3VecEnv(n_envs, seed=seed, env_id=env_id, **env_kwargs)


def make_vec_env(
    env_id: str = ENV_ID,
    n_envs: int = 1,
    *,
    seed: int = 0,
    env_kwargs: dict | None = None,
    kind: str = "native",
) -> VecEnv:
    """An SB3 ``VecEnv`` of ``n_envs`` sub-envs seeded ``seed + i``, wrapped in ``VecMonitor``.

    Args:
        env_id: registered env id.
        n_envs: number of sub-envs, >= 1.
        seed: base seed.
        env_kwargs: ``SmaSpineEnv`` keyword arguments.
        kind: ``"native"`` (vector env + adapter) or ``"dummy"`` (SB3 ``DummyVecEnv``).
    """
    import gymnasium as gym

    env_kwargs = dict(env_kwargs or {})
    if n_envs < 1:
        raise ValueError(f"n_envs must be >= 1, got {n_envs}")
    if kind == "native":
        venv = _native(env_id, n_envs, seed, env_kwargs)
    elif kind == "dummy":

        def factory(i):
            def _make():
                env = gym.make(env_id, **env_kwargs).unwrapped  # the env truncates on its own
                env.reset(seed=seed + i)
                return env

            return _make

        venv = DummyVecEnv([factory(i) for i in range(n_envs)])
        venv.seed(seed)
    else:
        raise ValueError(f"kind must be 'native' or 'dummy', got {kind!r}")
    return VecMonitor(venv)
