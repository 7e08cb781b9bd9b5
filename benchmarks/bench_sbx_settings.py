"""Benchmark: one run of a JAX learner's entry with overrides, on a tuning seed, as the benchmark runs it.

Trains ``algo`` on ``env_id`` with the YAML entry and the ``key=value`` overrides given (``n_envs``
among them), seed ``--seed`` (default 100, a tuning seed; the benchmark's are 0-4), the step budget
``-n``, validation every ``--eval-freq`` env steps on the benchmark's validation episodes
(:func:`spine_gym.agents.benchmark_run.run_one`, so the CPU time is measured as the benchmark's:
training only, JAX's compilation included), and prints the training CPU per 60 k steps, the final and
best validation RMSE. Run it through a 1-thread launcher::

    OMP_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_sbx_settings.py sbx_sac SmaSpineChainEasy-v2 \\
        n_envs=16 gradient_steps=16 -o /tmp/sbx_settings/n16

What it measured is in ``benchmarks/results/sbx_learners/chain_profile.txt``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import yaml

from spine_gym.agents.benchmark_run import RunSpec, read_curve, run_one


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("algo")
    p.add_argument("env_id")
    p.add_argument("overrides", nargs="*", help="key=value over the YAML entry (n_envs too)")
    p.add_argument("--seed", type=int, default=100)
    p.add_argument("-n", "--n-timesteps", type=int, default=60000)
    p.add_argument("--eval-freq", type=int, default=5000)
    p.add_argument("--val-episodes", type=int, default=10)
    p.add_argument("-o", "--out", type=Path, required=True, help="output folder (its run is reused if finished)")
    a = p.parse_args()
    hp = {}
    for item in a.overrides:
        key, value = item.split("=", 1)
        hp[key] = value if key == "policy_kwargs" else yaml.safe_load(value)
    n_envs = int(hp.pop("n_envs", -1))
    spec = RunSpec(a.algo, a.env_id, a.seed, a.n_timesteps, n_envs, a.eval_freq, a.val_episodes, hyperparams=hp)
    record = run_one(spec, a.out)
    curve = read_curve(a.out / spec.folder / "curve.csv")
    best = int(curve["rmse"].argmin())
    print(
        f"{spec.label} n_envs={n_envs if n_envs > 0 else 'entry'} {hp}: {record['steps']} steps, "
        f"CPU {record['cpu_s']:.1f} s = {record['cpu_s'] / record['steps'] * 60000:.0f} s per 60 k steps "
        f"(wall {record['wall_s']:.0f} s); final RMSE {record['final_rmse']:.2f}, best "
        f"{curve['rmse'][best]:.2f} at {int(curve['step'][best])} steps"
    )


if __name__ == "__main__":
    main()
