"""Benchmark: RLlib env-runner sampling of SmaSpine-v0, native vector env vs RLlib's default, in one run.

Four PPO algorithms of :func:`spine_gym.agents.rllib_ppo.build_config` are built on one local Ray cluster:

* ``native`` — each env runner steps one ``SmaSpineVectorEnv`` (``gym_env_vectorize_mode=
  "vector_entry_point"``, the registration's vector entry point, numba loop serial per runner);
* ``sync``   — RLlib's default: each runner steps a ``gymnasium.vector.SyncVectorEnv`` of
  ``gym.make("SmaSpine-v0")`` single envs;

each with 1 and with 2 remote env runners, ``--envs-per-runner`` sub-envs per runner (default 8).
A measurement is one ``EnvRunner.sample(num_timesteps=--steps)`` on every runner at once (RLlib's
sampling: env-to-module connectors, the module's exploration pass, the env step; no learning); env
steps/s = steps sampled by all runners / wall time. The four configurations run round-robin,
``--repeats`` rounds after one untimed warm-up round (numba cache loaded, wires warmed up); each figure
is the median of the rounds, and ratios are taken round by round against ``sync`` with the same
number of runners. Only one configuration samples at a time; the cluster gets ``--num-cpus``
logical CPUs (default 16) so that all four can be built at once on a 2-core machine.

    .venv-rllib/bin/python benchmarks/bench_rllib.py [--envs-per-runner 8] [--steps 1024] [--repeats 5] [--condition busy]

Needs ray[rllib] (the ``.venv-rllib`` of ``.ci/run``). Writes the entry ``--condition`` of
``benchmarks/results/rllib_speed.json`` (one entry per measured condition; the others are kept).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
from pathlib import Path

import gymnasium as gym
import numpy as np
import ray

import spine_gym
from spine_gym.agents.rllib_ppo import build_config, runner_env_classes, sample_throughput

OUT = Path(__file__).resolve().parent / "results"
CONFIGS = [("native", 1), ("sync", 1), ("native", 2), ("sync", 2)]


def machine() -> dict:
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout
    return {
        "cpu_count": os.cpu_count(),
        "load_average_start": os.getloadavg(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "ray": ray.__version__,
        "gymnasium": gym.__version__,
        "numpy": np.__version__,
        "spine_gym": spine_gym.__version__,
        "git_commit": commit.strip() or "unknown",
    }


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs-per-runner", type=int, default=8)
    ap.add_argument("--steps", type=int, default=1024, help="env steps per runner per measurement")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--num-cpus", type=int, default=16, help="logical CPUs of the local Ray cluster")
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument(
        "--condition", default="busy", help="the entry of rllib_speed.json to write (idle, load, busy, ...)"
    )
    args = ap.parse_args(argv)
    if args.repeats < 1 or args.steps < args.envs_per_runner:
        raise SystemExit("--repeats must be >= 1 and --steps >= --envs-per-runner")
    info = machine()
    ray.init(num_cpus=args.num_cpus, include_dashboard=False)
    try:
        algos = {}
        for vec, k in CONFIGS:
            cfg = build_config(env_runners=k, envs_per_runner=args.envs_per_runner, vectorize=vec, seed=0)
            algos[(vec, k)] = cfg.build_algo()
        envs = {f"{v}_{k}": sorted(set(runner_env_classes(a))) for (v, k), a in algos.items()}
        print("runner envs:", envs)
        rates: dict[tuple[str, int], list[float]] = {c: [] for c in CONFIGS}
        loads = []  # 1-min load average after each round: what shared the cores with the runners
        for rnd in range(args.repeats + 1):  # round 0: warm-up
            for c in CONFIGS:
                r = sample_throughput(algos[c], args.steps)
                if rnd:
                    rates[c].append(r)
            loads.append(os.getloadavg()[0])
            print(f"round {rnd}: " + ", ".join(f"{v}x{k} {rates[(v, k)][-1]:.0f}" for v, k in CONFIGS if rnd))
        for a in algos.values():
            a.stop()
    finally:
        ray.shutdown()
    info["load_average_end"] = os.getloadavg()
    info["load_average_1min_after_each_round"] = loads
    results = {}
    for vec, k in CONFIGS:
        med = float(np.median(rates[(vec, k)]))
        row = {"steps_per_s": med, "runs": rates[(vec, k)], "runner_env": envs[f"{vec}_{k}"]}
        if vec == "native":
            ratio = np.array(rates[(vec, k)]) / np.array(rates[("sync", k)])
            row["ratio_vs_sync_same_runners"] = float(np.median(ratio))
        results[f"{vec}_{k}_runner{'s' if k > 1 else ''}"] = row
    for vec in ("native", "sync"):
        scale = np.array(rates[(vec, 2)]) / np.array(rates[(vec, 1)])
        results[f"{vec}_2_runners"]["ratio_vs_1_runner"] = float(np.median(scale))
    out = {
        "settings": {
            "envs_per_runner": args.envs_per_runner,
            "steps_per_runner": args.steps,
            "repeats": args.repeats,
            "num_cpus_logical": args.num_cpus,
        },
        "results": results,
        "machine": info,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "rllib_speed.json"
    merged = json.loads(path.read_text()) if path.exists() else {}
    merged[args.condition] = out
    path.write_text(json.dumps(merged, indent=2, default=float) + "\n")
    print(json.dumps(results, indent=2, default=float))
    return out


if __name__ == "__main__":
    main()
