"""Benchmark: environment steps per second of SmaSpine-v0, its vector forms and a peer, in one run.

Measured in one process after a warm-up (numba's cache loaded, every code path run once):

* ``single``   — ``gym.make("SmaSpine-v0")`` (with Gymnasium's default wrappers), one env;
* ``pendulum`` — ``gym.make("Pendulum-v1")``, the classic-control peer (pure NumPy dynamics);
* ``sync``     — ``gymnasium.vector.SyncVectorEnv`` of N single envs (Python loop over envs);
* ``native``   — ``gym.make_vec("SmaSpine-v0", num_envs=N)``: one numba call per step (the default
  kernel choice: serial below ``PARALLEL_MIN_ENVS`` = 64 envs, parallel from there);

for N = 1, 16, 256, 1024, plus two diagnostics: the native env at N = 256 and 1024 with numba
limited to 1 thread vs all threads (core scaling), and the jitted kernel alone (the physics share
of a step: ``spine_loops.step_many`` over N spines, no Python bookkeeping). The SB3 adapter over
the native env is timed at N = 256 as well.

Work is identical across configurations: environment i starts from ``reset(seed=base + i)``, runs
``--warm`` untimed control periods (default 50 = 5 s: the wires warm up to where the phase
transformations, and hence the model's adaptive sub-stepping, set in; before that a step costs
~5 µs of physics, after it ~100 µs), then ``--steps`` timed ones (default 50), all with its own
fixed uniform random actions in [-1, 1] (the single env runs the episodes of environments
0..15); steps/s = N × steps / wall time of the timed steps; each figure is the best of
``--repeats`` runs, the configurations of one N interleaved run by run (best-of: the machine is
shared, the minimum is the least disturbed; SyncVectorEnv at N = 1024 runs once, ~20 s). The
Pendulum peer (torque = 2 × the first action entry) runs 20 000 steps. Writes
``benchmarks/results/env_speed.json`` and ``benchmarks/results/env_speed.png``.

    .venv/bin/python benchmarks/bench_env.py [--warm 50] [--steps 50] [--repeats 3] [--sizes 1 16 256 1024]
    .venv/bin/python benchmarks/bench_env.py --omp-passive --tag _passive

numba's parallel loop uses GNU OpenMP here; by default its idle worker threads spin for a while
after each parallel region. On a machine whose cores are busy with other processes that spinning
competes with the main thread's Python work between steps and the native env can drop below the
serial loop; ``--omp-passive`` runs the same benchmark with ``OMP_WAIT_POLICY=PASSIVE`` (workers
sleep at once) to show the difference. The load average at start and end is recorded.
"""

from __future__ import annotations

import os
import sys

if "--omp-passive" in sys.argv:  # must be set before numba's OpenMP runtime starts
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"

import argparse
import json
import platform
import subprocess
import time
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np
from spine_loops import step_many  # the sibling module

import spine_gym
from spine_gym.envs.planar import PlanarBatch

OUT = Path(__file__).resolve().parent / "results"
SEED = 1000


def _best(fn, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        best = min(best, fn())
    return best


def _env_actions(steps: int, i: int) -> np.ndarray:
    """(steps, 2) uniform actions of environment i (the same for every configuration)."""
    return np.random.default_rng(i).uniform(-1.0, 1.0, size=(steps, 2)).astype(np.float32)


def _actions(steps: int, n: int) -> np.ndarray:
    """(steps, n, 2): column i is :func:`_env_actions` of environment i."""
    return np.stack([_env_actions(steps, i) for i in range(n)], axis=1)


def time_single(env_id: str, steps: int, episodes: int = 1, warm: int = 0) -> float:
    """Seconds for ``episodes`` × ``steps`` timed steps of one gym.make env; episode e starts from
    ``reset(seed=SEED + e)`` and ``warm`` untimed steps, as row e of the vector configurations."""
    env = gym.make(env_id)
    total = 0.0
    for e in range(episodes):
        acts = _env_actions(warm + steps, e)
        if env_id != "SmaSpine-v0":
            acts = acts[:, :1] * 2.0  # Pendulum-v1: one torque in [-2, 2]
        env.reset(seed=SEED + e)
        for a in acts[:warm]:
            env.step(a)
        t0 = time.perf_counter()
        for a in acts[warm:]:
            _, _, term, trunc, _ = env.step(a)
            if term or trunc:
                env.reset()
        total += time.perf_counter() - t0
    env.close()
    return total


def time_vector(venv, acts: np.ndarray, warm: int = 0) -> float:
    """Seconds for the steps ``acts[warm:]`` after ``reset(seed=SEED)`` and ``warm`` untimed steps."""
    venv.reset(seed=SEED)
    for a in acts[:warm]:
        venv.step(a)
    t0 = time.perf_counter()
    for a in acts[warm:]:
        venv.step(a)
    return time.perf_counter() - t0


def make_sync(n: int):
    return gym.vector.SyncVectorEnv([lambda: gym.make("SmaSpine-v0") for _ in range(n)])


def time_sb3(n: int, acts: np.ndarray, warm: int = 0) -> float:
    from spine_gym.envs.sb3 import SmaSpineSB3VecEnv

    env = SmaSpineSB3VecEnv(n, seed=SEED)
    env.reset()
    for a in acts[:warm]:
        env.step_async(a)
        env.step_wait()
    t0 = time.perf_counter()
    for a in acts[warm:]:
        env.step_async(a)
        env.step_wait()
    return time.perf_counter() - t0


def time_kernel(n: int, acts: np.ndarray, warm: int = 0) -> float:
    """The jitted per-period loop alone, from the states the native env reaches after ``warm`` steps."""
    venv = gym.make_vec("SmaSpine-v0", num_envs=n)
    venv.reset(seed=SEED)
    for a in acts[:warm]:
        venv.step(a)
    acts = acts[warm:]
    core: PlanarBatch = venv.unwrapped._core
    cfg = core.cfg
    resolve = np.zeros(n, dtype=np.bool_)
    active = np.ones(n, dtype=np.bool_)
    t0 = time.perf_counter()
    for a in acts:
        volts = (np.clip(a.astype(np.float64), -1, 1) + 1.0) * 0.5 * cfg.v_max
        step_many(
            core.states,
            core.backup,
            core.kps,
            core.ks,
            volts[:, 0].copy(),
            volts[:, 1].copy(),
            core.loads,
            resolve,
            active,
            cfg.physics_dt,
            cfg.n_sub,
            core.status,
            core.meas,
        )
    return time.perf_counter() - t0


def machine() -> dict:
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True
        ).stdout.strip()
    except OSError:
        commit = "unknown"
    return {
        "cpu_count": os.cpu_count(),
        "numba_threads": numba.config.NUMBA_NUM_THREADS,
        "load_average_start": os.getloadavg(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "gymnasium": gym.__version__,
        "OMP_WAIT_POLICY": os.environ.get("OMP_WAIT_POLICY", "(unset: GNU OpenMP spins, then sleeps)"),
        "spine_gym": spine_gym.__version__,
        "git_commit": commit,
    }


def plot(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = res["sizes"]
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax.loglog(
        sizes, [res["native"][str(n)] for n in sizes], "o-", label="native vector env (numba, default kernel)"
    )
    ax.loglog(sizes, [res["sync"][str(n)] for n in sizes], "s-", label="SyncVectorEnv of gym.make")
    ax.loglog(
        sizes, [res["kernel"][str(n)] for n in sizes], ":", color="0.5", label="jitted kernel alone (physics)"
    )
    ax.axhline(res["single"], color="tab:green", ls="--", label="gym.make('SmaSpine-v0')")
    ax.axhline(res["pendulum"], color="tab:red", ls="--", label="gym.make('Pendulum-v1')")
    ax.set_xlabel("number of environments N")
    ax.set_ylabel("environment steps per second")
    ax.set_title("SmaSpine-v0 throughput")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ratio = [res["native"][str(n)] / res["sync"][str(n)] for n in sizes]
    ax2.semilogx(sizes, ratio, "o-", label="native / SyncVectorEnv")
    ax2.axhline(20.0, color="tab:red", ls="--", label="target 20x at N = 256")
    for n, r in zip(sizes, ratio, strict=True):
        ax2.annotate(f"{r:.1f}x", (n, r), textcoords="offset points", xytext=(0, 6), ha="center", fontsize=8)
    ax2.set_xlabel("number of environments N")
    ax2.set_ylabel("speed-up")
    ax2.set_title("native vector env over SyncVectorEnv (same run)")
    ax2.set_ylim(0, max(22.0, max(ratio) * 1.2))
    ax2.legend(fontsize=8)
    ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--warm", type=int, default=50, help="untimed steps after reset (default 50 = 5 s)")
    ap.add_argument(
        "--steps", type=int, default=50, help="timed control periods per environment (default 50)"
    )
    ap.add_argument("--repeats", type=int, default=3, help="best-of repeats (default 3)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 16, 256, 1024])
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument(
        "--omp-passive",
        action="store_true",
        help="OMP_WAIT_POLICY=PASSIVE: idle OpenMP workers sleep instead of spinning (see the module doc)",
    )
    ap.add_argument("--tag", default="", help="suffix of the output file names (env_speed<tag>.json/.png)")
    args = ap.parse_args(argv)
    steps, reps, sizes, w = args.steps, args.repeats, sorted(args.sizes), args.warm
    info = machine()
    n_threads = numba.config.NUMBA_NUM_THREADS

    # warm-up: load numba's cache and run every path once
    time_single("SmaSpine-v0", 20, 2)
    time_vector(gym.make_vec("SmaSpine-v0", num_envs=2), _actions(3, 2))
    time_vector(make_sync(2), _actions(3, 2))
    time_kernel(2, _actions(2, 2))
    time_single("Pendulum-v1", 100)

    t_start = time.perf_counter()
    res: dict = {"sizes": sizes, "steps_per_env": steps, "warm_steps": w, "repeats": reps}
    res["single"] = steps * 16 / _best(lambda: time_single("SmaSpine-v0", steps, 16, w), reps)
    res["pendulum"] = 20000 / _best(lambda: time_single("Pendulum-v1", 20000), reps)
    print(f"single {res['single']:9.0f} steps/s   Pendulum-v1 {res['pendulum']:9.0f} steps/s", flush=True)
    for key in ("native", "sync", "kernel"):
        res[key] = {}
    for n in sizes:
        acts = _actions(w + steps, n)
        native = gym.make_vec("SmaSpine-v0", num_envs=n)
        sync = make_sync(n)
        r_sync = 1 if n >= 1024 else reps  # ~20 s per run at N = 1024
        best = {"native": np.inf, "sync": np.inf, "kernel": np.inf}
        for r in range(reps):  # interleaved, so that a burst of machine load hits all three alike
            best["native"] = min(best["native"], time_vector(native, acts, w))
            if r < r_sync:
                best["sync"] = min(best["sync"], time_vector(sync, acts, w))
            best["kernel"] = min(best["kernel"], time_kernel(n, acts, w))
        for key, t in best.items():
            res[key][str(n)] = n * steps / t
        native.close()
        sync.close()
        nat, syn, ker = res["native"][str(n)], res["sync"][str(n)], res["kernel"][str(n)]
        print(
            f"N={n:5d}  native {nat:9.0f}  sync {syn:9.0f}  kernel {ker:9.0f} steps/s  ratio {nat / syn:5.1f}"
        )
    # core scaling of the native env
    res["threads"] = {}
    for n in [s for s in sizes if s >= 256]:
        acts = _actions(w + steps, n)
        venv = gym.make_vec("SmaSpine-v0", num_envs=n)
        per = {"1": np.inf, str(n_threads): np.inf}
        for _ in range(reps):  # interleaved
            for k in (1, n_threads):
                numba.set_num_threads(k)
                per[str(k)] = min(per[str(k)], time_vector(venv, acts, w))
        per = {k: n * steps / t for k, t in per.items()}
        numba.set_num_threads(n_threads)
        res["threads"][str(n)] = {**per, "speedup": per[str(n_threads)] / per["1"]}
        print(
            f"N={n:5d}  1 thread {per['1']:9.0f}  {n_threads} threads {per[str(n_threads)]:9.0f} steps/s",
            flush=True,
        )
    if 256 in sizes:
        acts = _actions(w + steps, 256)
        res["sb3_adapter_256"] = 256 * steps / _best(lambda: time_sb3(256, acts, w), reps)
    # where the single env's time goes: physics (kernel at N=1) vs Python (the rest)
    t_env = 1.0 / res["single"]
    t_phys = 1.0 / res["kernel"][str(min(sizes))] if min(sizes) == 1 else float("nan")
    ref_n = 256 if 256 in sizes else sizes[-1]
    summary = {
        "native_over_sync": {str(n): res["native"][str(n)] / res["sync"][str(n)] for n in sizes},
        "native_over_sync_at_256": res["native"].get("256", float("nan"))
        / res["sync"].get("256", float("nan")),
        "target_20x_at_256_met": bool(res["native"].get("256", 0) >= 20 * res["sync"].get("256", np.inf)),
        "thread_speedup": {n: v["speedup"] for n, v in res["threads"].items()},
        "single_over_pendulum": res["single"] / res["pendulum"],
        "single_env_us_per_step": 1e6 * t_env,
        "physics_us_per_step_N1": 1e6 * t_phys,
        "python_share_of_single_step": 1.0 - t_phys / t_env,
        # bound on native/sync if the native env had no Python cost at all: (t_env) / (t_phys / cores)
        "ratio_bound_from_physics": t_env / (1.0 / res["kernel"][str(ref_n)]),
        "wall_time_s": time.perf_counter() - t_start,
    }
    info["load_average_end"] = os.getloadavg()
    info["numba_threading_layer"] = numba.threading_layer()
    out = {"machine": info, "results": res, "summary": summary}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"env_speed{args.tag}.json").write_text(json.dumps(out, indent=2, default=float))
    plot(res, args.out / f"env_speed{args.tag}.png")
    print(json.dumps(summary, indent=2, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
