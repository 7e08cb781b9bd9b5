"""Compile the numba kernels most tests call into the on-disk cache before the test suite runs.

Every kernel is compiled with ``cache=True`` (``spine_gym/physics/_jit.py``): the first process that
calls one compiles it and writes it to ``__pycache__``, every later one loads it. On a fresh clone
nothing is cached, and the test processes that start together (pytest-xdist's workers, each with its
own CLI subprocesses) would each compile the same kernels at once: a cold spatial env step alone
compiles for minutes. ``scripts/test.sh`` runs this once per geometry, the two side by side, before
the tests. ``spatial`` compiles the env step of the four-wire module and of the chain (one set of
kernels), the longest compile; ``planar``, which takes less, also the planar controllers (the MPC's
rollouts, serial and ``prange``), the vector env's two loops and the recorded run. What neither
compiles (the spatial MPC's rollouts, the spatial vector loops...) is compiled by the first test that
calls it, while the other worker runs other tests. With a warm cache this only loads the kernels.

usage: python scripts/warm_kernels.py planar|spatial
"""

from __future__ import annotations

import sys
from dataclasses import replace

import gymnasium as gym
import numpy as np

import spine_gym  # noqa: F401 - registers the env ids
from spine_gym.agents.runtime import build_controller, make_env
from spine_gym.controllers.mpc import MPPIController
from spine_gym.controllers.registry import registry_for
from spine_gym.simulate import simulate

PLANAR_ID = "SmaSpine-v2"  # -v2: the plant's thermal cut-off; the kernels of -v0/-v1 are the same
SPATIAL_IDS = ("SmaSpine3D-v2", "SmaSpineChain-v2")


def step_env(env_id: str):
    """A reset and one step of ``env_id``; returns the env and its first observation."""
    env = make_env({"episode_duration": 3.0}, env_id=env_id)
    obs, _ = env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape, np.float32))
    return env, obs


def warm_planar() -> None:
    env, obs = step_env(PLANAR_ID)
    for name in registry_for(PLANAR_ID):  # the MPC entries roll their plans out on the env's own core
        ctrl = build_controller(name, env)
        ctrl.reset()
        ctrl(obs)
    settings = replace(build_controller("mpc_oracle", env).settings, parallel=True)  # the prange twin
    oracle = MPPIController(env.config, "oracle", env=env, settings=settings)
    oracle.reset()
    oracle(obs)
    env.close()
    for parallel in (False, True):
        venv = gym.make_vec(PLANAR_ID, num_envs=2, vectorization_mode="vector_entry_point", parallel=parallel)
        venv.reset(seed=0)
        venv.step(np.zeros(venv.action_space.shape, np.float32))
        venv.close()
    simulate(1.0, 3.0, 0.0, dt=0.1)


def warm_spatial() -> None:
    for env_id in SPATIAL_IDS:
        step_env(env_id)[0].close()


GEOMETRIES = {"planar": warm_planar, "spatial": warm_spatial}


def main(argv: list[str]) -> int:
    if len(argv) != 1 or argv[0] not in GEOMETRIES:
        print(f"usage: python scripts/warm_kernels.py {'|'.join(GEOMETRIES)}", file=sys.stderr)
        return 2
    GEOMETRIES[argv[0]]()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
