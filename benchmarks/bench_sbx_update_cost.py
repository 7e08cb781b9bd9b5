"""Benchmark: the training CPU cost of a JAX learner's configuration, without a full run.

Builds the algorithm of ``algo`` on ``env_id`` as :mod:`spine_gym.agents.train` does (its YAML
entry, ``learning_starts`` 1000, the ``key=value`` overrides given), trains 2 000 steps untimed
(JAX's compilation), then 4 000 timed steps, and prints the CPU time scaled to 60 k env steps and
per gradient step. Run it through a 1-thread launcher (JAX on one thread:
:mod:`spine_gym.agents.jax_algos`)::

    OMP_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_sbx_update_cost.py crossq SmaSpineEasy-v2 \\
        'policy_kwargs=dict(net_arch=dict(pi=[256, 256], qf=[512, 512]))'

What it measured is in ``benchmarks/results/sbx_learners/update_cost.txt``.
"""

from __future__ import annotations

import sys
import time

import yaml

from spine_gym.agents.training import build_envs, build_model, resolve_config


def main(argv: list[str]) -> None:
    algo, env_id = argv[0], argv[1]
    hp = {}
    for item in argv[2:]:
        key, value = item.split("=", 1)
        hp[key] = value if key == "policy_kwargs" else yaml.safe_load(value)
    cfg = resolve_config(algo, env_id, n_timesteps=6000, hyperparams={"learning_starts": 1000, **hp})
    model = build_model(cfg, build_envs(cfg, 0).env, 0)
    t0 = time.process_time()
    model.learn(2000)
    t1 = time.process_time()
    model.learn(4000, reset_num_timesteps=False)
    t2 = time.process_time()
    n_updates = 4000 // cfg.n_envs * cfg.hp["gradient_steps"]
    print(
        f"{algo} {env_id} {hp}: warm-up (JIT) {t1 - t0:.1f} s CPU; 4000 steps {t2 - t1:.2f} s CPU = "
        f"{(t2 - t1) / 4000 * 60000:.0f} s CPU per 60 k steps; {1000 * (t2 - t1) / n_updates:.2f} ms per gradient step (env steps included)"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
