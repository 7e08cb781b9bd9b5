"""Benchmark: steps per second of SmaSpine3D-v0 and SmaSpineChain-v0 against SmaSpine-v0, in one run.

The spatial envs run the wire- and module-generic core (SPATIAL.md) instead of the planar kernel;
this measures what that costs per environment step, as ratios to ``SmaSpine-v0`` measured in the
same process (the peer). Per id:

* ``single`` — ``gym.make(id)``: ``--episodes`` episodes, each ``reset(seed=SEED + e)``, ``--warm``
  untimed control periods (the wires warm up until the phase transformations, and with them the
  adaptive sub-stepping, set in), then ``--steps`` timed ones;
* ``native`` — ``gym.make_vec(id, num_envs=N)`` with the same per-env work (N = ``--n``).

Actions: per environment fixed uniform random numbers in [-1, 1] (the same stream for every id,
cut to its action size). Each figure is the best of ``--repeats`` runs, the ids interleaved run by
run (the machine is shared: the minimum is the least disturbed). Writes
``benchmarks/results/env_spatial_speed.json`` and ``.png``.

    .venv/bin/python benchmarks/bench_env_spatial.py [--warm 50] [--steps 50] [--episodes 4] [--n 16]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from matplotlib.figure import Figure

import spine_gym  # noqa: F401  (registers the ids)

OUT = Path(__file__).resolve().parent / "results"
SEED = 1000
IDS = ("SmaSpine-v0", "SmaSpine3D-v0", "SmaSpineChain-v0")


def _acts(steps: int, n: int, width: int) -> np.ndarray:
    """(steps, n, width) actions; environment i's stream is the same for every id."""
    return np.stack(
        [np.random.default_rng(i).uniform(-1.0, 1.0, (steps, 8))[:, :width] for i in range(n)], axis=1
    ).astype(np.float32)


def time_single(env_id: str, episodes: int, warm: int, steps: int) -> float:
    env = gym.make(env_id)
    width = env.action_space.shape[0]
    total = 0.0
    for e in range(episodes):
        acts = _acts(warm + steps, e + 1, width)[:, e]
        env.reset(seed=SEED + e)
        for a in acts[:warm]:
            env.step(a)
        t0 = time.perf_counter()
        for a in acts[warm:]:
            env.step(a)
        total += time.perf_counter() - t0
    env.close()
    return episodes * steps / total


def time_native(env_id: str, n: int, warm: int, steps: int) -> float:
    venv = gym.make_vec(env_id, num_envs=n)
    acts = _acts(warm + steps, n, venv.single_action_space.shape[0])
    venv.reset(seed=SEED)
    for a in acts[:warm]:
        venv.step(a)
    t0 = time.perf_counter()
    for a in acts[warm:]:
        venv.step(a)
    dt = time.perf_counter() - t0
    venv.close()
    return n * steps / dt


def plot(res: dict, path: Path) -> None:
    fig = Figure(figsize=(7, 4))
    ax = fig.add_subplot()
    x = np.arange(len(IDS))
    for k, key in enumerate(("single", "native")):
        vals = [res[i][key] for i in IDS]
        ax.bar(x + 0.38 * (k - 0.5), vals, 0.36, label=key)
    ax.set_xticks(x, IDS)
    ax.set_yscale("log")
    ax.set_ylabel("environment steps / s (best of repeats)")
    ax.set_title("spatial ids vs SmaSpine-v0, one run (loaded machine)", fontsize=10)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--warm", type=int, default=50)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--episodes", type=int, default=4)
    ap.add_argument("--n", type=int, default=16)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    for env_id in IDS:  # warm-up: numba's cache, every path once
        time_single(env_id, 1, 2, 2)
        time_native(env_id, 2, 2, 2)
    load_start = os.getloadavg()
    res = {i: {"single": 0.0, "native": 0.0} for i in IDS}
    for _ in range(args.repeats):
        for env_id in IDS:
            r = res[env_id]
            r["single"] = max(r["single"], time_single(env_id, args.episodes, args.warm, args.steps))
            r["native"] = max(r["native"], time_native(env_id, args.n, args.warm, args.steps))
    for env_id in IDS:
        for key in ("single", "native"):
            res[env_id][f"{key}_over_planar"] = res[env_id][key] / res["SmaSpine-v0"][key]
        print(env_id, {k: round(v, 3) for k, v in res[env_id].items()})
    out = {
        "settings": {k: v for k, v in vars(args).items() if k != "out"},
        "load_average_start": load_start,
        "load_average_end": os.getloadavg(),
        "results": res,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "env_spatial_speed.json").write_text(json.dumps(out, indent=2))
    plot(res, args.out / "env_spatial_speed.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
