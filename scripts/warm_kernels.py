"""Compile the numba kernels of one geometry into the on-disk cache before the test suite runs.

Every kernel is compiled with ``cache=True`` (``spine_gym/physics/_jit.py``): the first process that
calls one compiles it and writes it to ``__pycache__``, every later one loads it. On a fresh clone
nothing is cached, and the test processes that start together (pytest-xdist's workers, each with its
own CLI subprocesses) would each compile the same kernels at once; a cold spatial env step alone
compiles for minutes. ``scripts/test.sh`` runs this once per geometry, the two side by side, so the
suite starts with what nearly every test calls already compiled (a kernel missed here is compiled by
the first test that calls it, as before). With a warm cache it only loads the kernels.

usage: python scripts/warm_kernels.py planar|spatial
"""

from __future__ import annotations

import sys

import gymnasium as gym
import numpy as np

import spine_gym  # noqa: F401 - registers the env ids
from spine_gym.agents.runtime import build_controller, make_env
from spine_gym.controllers.registry import registry_for
from spine_gym.layout import SpineLayout
from spine_gym.simulate import simulate

# the env ids whose kernels a geometry warms (-v2: the plant's thermal cut-off; the same kernels as -v0/-v1)
IDS = {"planar": ("SmaSpine-v2",), "spatial": ("SmaSpine3D-v2", "SmaSpineChain-v2")}


def warm_env(env_id: str) -> None:
    """Step the single env, the serial and the parallel vector env, and every registered controller once."""
    env = make_env({"episode_duration": 3.0}, env_id=env_id)
    obs, _ = env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape, np.float32))
    for name in registry_for(env_id):  # the MPC entries roll their plans out on the env's own core
        ctrl = build_controller(name, env)
        ctrl.reset()
        ctrl(obs)
    env.close()
    for parallel in (False, True):
        venv = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", parallel=parallel)
        venv.reset(seed=0)
        venv.step(np.zeros(venv.action_space.shape, np.float32))
        venv.close()


def main(argv: list[str]) -> int:
    if len(argv) != 1 or argv[0] not in IDS:
        print(f"usage: python scripts/warm_kernels.py {'|'.join(IDS)}", file=sys.stderr)
        return 2
    geometry = argv[0]
    for env_id in IDS[geometry]:
        warm_env(env_id)
    if geometry == "planar":  # the recorded runs (spine_gym.simulate) of the same core
        simulate(1.0, 3.0, 0.0, dt=0.1)
    else:
        for layout in (SpineLayout.seed(), SpineLayout.chain()):
            simulate(1.0, np.full(layout.n_wires, 3.0), layout=layout, dt=0.1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
