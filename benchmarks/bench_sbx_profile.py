"""Benchmark: where the CPU of a JAX learner's training run goes (cProfile, by part).

Builds the algorithm of ``algo`` on ``env_id`` as :mod:`spine_gym.agents.benchmark` does (its YAML
entry with the ``key=value`` overrides given; seed 100, a tuning seed), trains ``--steps`` env steps
under cProfile (no validation callback: the benchmark's CPU excludes it) and prints the time of each
part of the run, scaled to 60 k steps:

* env: the native vector env's step (numba physics, the per-env infos), then SB3's ``VecMonitor``
  and ``VecNormalize`` on top of it;
* act: the policy's action (one jit call per vector step, SB3's ``predict`` around it);
* buffer: storing the transitions (``_store_transition``);
* update: ``train`` (the replay sample, the jit-compiled gradient steps, SB3's logging); its
  first call (JAX's compilation) separately;
* other: the rest of SB3's loop (``collect_rollouts``' bookkeeping, callbacks, logging).

Run it through a 1-thread launcher (JAX on one thread: :mod:`spine_gym.agents.jax_algos`)::

    OMP_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_sbx_profile.py sbx_sac SmaSpineChainEasy-v2 \\
        --steps 20000 train_freq=8 gradient_steps=16

cProfile's own overhead falls on the Python-heavy parts (SB3's loop, the info dicts), so the split is
an upper bound there (the profiled total is above a plain run's CPU). The env's numba functions are
compiled (or loaded from numba's cache) by a first env step before the profile starts.
What it measured is in ``benchmarks/results/sbx_learners/chain_profile.txt``.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

import numpy as np
import yaml

from spine_gym.agents.training import build_envs, build_model, resolve_config

SEED = 100

#: part -> (file suffix, function name) whose cumulative time it is
PARTS = {
    "native vector env step": ("spine_gym/envs/sb3.py", "step_wait"),
    "VecMonitor (incl. env)": ("vec_monitor.py", "step_wait"),
    "VecNormalize (incl. monitor, env)": ("vec_normalize.py", "step_wait"),
    "act (_sample_action)": ("off_policy_algorithm.py", "_sample_action"),
    "buffer (_store_transition)": ("off_policy_algorithm.py", "_store_transition"),
    "update (train)": ("sbx/sac/sac.py", "train"),
    "  replay sample": ("buffers.py", "_get_samples"),
    "collect_rollouts": ("off_policy_algorithm.py", "collect_rollouts"),
    "learn": ("off_policy_algorithm.py", "learn"),
}


def _build(algo: str, env_id: str, steps: int, hp: dict):
    cfg = resolve_config(algo, env_id, n_timesteps=steps, hyperparams=hp)
    warm = build_envs(cfg, SEED + 1).env  # numba's compilation (or cache load) out of the profile
    warm.reset()
    warm.step(np.zeros((cfg.n_envs, *warm.action_space.shape), dtype=np.float32))
    warm.close()
    return cfg, build_model(cfg, build_envs(cfg, SEED).env, SEED)


def cumulative(stats: pstats.Stats, suffix: str, name: str) -> float:
    """The cumulative time of the function ``name`` of a file ending in ``suffix`` (0 if not called)."""
    return sum(
        v[3] for (file, _, func), v in stats.stats.items() if file.endswith(suffix) and func == name
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("algo")
    p.add_argument("env_id")
    p.add_argument("overrides", nargs="*", help="key=value over the YAML entry")
    p.add_argument("--steps", type=int, default=20000, help="env steps of the run (default 20000)")
    p.add_argument("--top", type=int, default=0, help="also list the N functions of most cumulative time")
    a = p.parse_args()
    hp = {}
    for item in a.overrides:
        key, value = item.split("=", 1)
        hp[key] = value if key == "policy_kwargs" else yaml.safe_load(value)

    cfg, model = _build(a.algo, a.env_id, a.steps, hp)
    first = {}
    train = model.train

    def timed_train(*args, **kwargs):  # the first call compiles
        if not first:
            t = time.process_time()
            train(*args, **kwargs)
            first["s"] = time.process_time() - t
        else:
            train(*args, **kwargs)

    model.train = timed_train
    prof = cProfile.Profile()
    prof.enable()
    model.learn(a.steps)
    prof.disable()
    stats = pstats.Stats(prof)
    total = cumulative(stats, *PARTS["learn"])
    scale = 60000 / a.steps
    print(
        f"{a.algo} {a.env_id} {hp} (entry: train_freq {cfg.hp.get('train_freq')}, gradient_steps "
        f"{cfg.hp.get('gradient_steps')}, n_envs {cfg.n_envs}, batch {cfg.hp.get('batch_size')}), "
        f"{a.steps} steps, seed {SEED}"
    )
    print(f"  profiled learn(): {total:.1f} s; per 60 k steps (first update, JAX's compilation, once):")
    for part, key in PARTS.items():
        if part == "learn":
            continue
        t = cumulative(stats, *key)
        if part == "update (train)":
            t -= first.get("s", 0.0)
            print(f"  {'  first update (compilation)':40s} {first.get('s', 0.0):6.1f} s")
        print(f"  {part:40s} {t * scale:6.1f} s  ({100 * t / total:4.1f} %)")
    if a.top:
        stats.sort_stats("cumulative").print_stats(a.top)


if __name__ == "__main__":
    main()
