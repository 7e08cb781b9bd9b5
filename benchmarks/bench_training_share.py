"""Benchmark: the environment's share of PPO training, and where the env's time goes (issue 11).

Three figures, each printed beside the issue's target:

1. **Env share of PPO training** (target ≤ 10 %). The shipped PPO configuration
   (``agents/hyperparams/ppo.yml``: 8 native envs, ``n_steps`` 256, 10 epochs of minibatch 256,
   ``VecNormalize`` of the observations), torch on 1 thread, built as :mod:`agents.train` builds it;
   ``PPO.learn`` for ``--rollouts`` rollouts after one untimed warm-up rollout. Timed by wrapping
   (no change to the library): the outermost ``step_wait`` that PPO calls (``VecNormalize`` →
   ``VecMonitor`` → adapter), the adapter's ``step_wait`` (:class:`spine_gym.envs.sb3.SmaSpineSB3VecEnv`),
   the vector env's ``step`` and the jitted kernel call inside it
   (:func:`spine_gym.physics.env_kernels.step_many`), plus PPO's ``collect_rollouts`` and ``train``.
   The env share is the outermost ``step_wait`` time over the wall time of ``learn``; the nested
   timers say where inside the env the time goes (physics kernel, vector-env Python, SB3 adapter,
   wrappers). Run twice, interleaved: numba on every thread (the shipped default,
   ``parallel=True`` for 8 envs) and on 1 thread.
2. **Native vector env per core vs the kernel alone** (target: within 10 %). N = 8 and N = 256
   environments, numba on 1 thread: env steps/s of ``gym.make_vec("SmaSpine-v0")`` against
   ``env_kernels.step_many`` stepping the same states without Python (``bench_env.time_kernel``),
   from the warm regime (``--warm`` untimed steps), best of ``--repeats`` interleaved runs.
3. **Scaling from 1 to 2 numba threads** (target: near-linear, ≥ 1.8×). The native env at N = 8 and
   N = 256 with ``numba.set_num_threads(1)`` and ``(2)``, interleaved run by run.

The machine this was written on has 2 cores shared with other jobs: every time is an upper bound
of the time on a quiet machine (every rate a lower bound), and the 1 → 2 thread scaling cannot show
more than the second core's idle share, so it is a figure of this machine's load, not of the code.
The load average at start and end is recorded. Writes ``benchmarks/results/training_share.json`` and ``.png``.

    .venv/bin/python benchmarks/bench_training_share.py [--rollouts 4] [--warm 50] [--steps 50] [--repeats 3]
    .venv/bin/python benchmarks/bench_training_share.py --omp-passive --tag _passive
"""

from __future__ import annotations

import os
import sys

if "--omp-passive" in sys.argv:  # before numba's OpenMP runtime starts (as bench_env.py)
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"

import argparse
import json
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling bench_env (also as a module)

from bench_env import _actions, machine, time_kernel, time_vector  # noqa: E402

import spine_gym  # noqa: E402, F401 - registers SmaSpine-v0
from spine_gym.physics import env_kernels  # noqa: E402

OUT = Path(__file__).resolve().parent / "results"
TARGET_SHARE = 0.10  # env share of PPO wall time
TARGET_NATIVE_OVER_KERNEL = 0.90  # native env rate per core / kernel-only rate
TARGET_SCALING = 1.8  # 2 threads / 1 thread ("near-linear")


class Timer:
    """Accumulated wall time of a wrapped callable."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.calls = 0

    def wrap(self, fn):
        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - t0
                self.calls += 1

        return timed


def _build_ppo(seed: int = 0):
    """(model, vec env) of the shipped PPO configuration, as ``agents.train`` builds them."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.common import ENV_ID, load_hyperparams, preprocess_hyperparams
    from agents.envs import make_vec_env

    hp, special = preprocess_hyperparams(load_hyperparams("ppo", ENV_ID))
    env = make_vec_env(ENV_ID, int(special["n_envs"]), seed=seed, env_kwargs=special["env_kwargs"])
    if special["normalize"] is not None:
        env = VecNormalize(env, gamma=hp.get("gamma", 0.99), **special["normalize"])
    model = PPO(special["policy"], env, seed=seed, device="cpu", verbose=0, **hp)
    return model, env


def _innermost(env):
    """The SB3 adapter under the VecEnv wrappers."""
    from spine_gym.envs.sb3 import SmaSpineSB3VecEnv

    while not isinstance(env, SmaSpineSB3VecEnv):
        env = env.venv
    return env


def ppo_share(rollouts: int, threads: int) -> dict:
    """Time one PPO.learn of ``rollouts`` rollouts (after a warm-up rollout) with nested timers."""
    numba.set_num_threads(threads)
    model, env = _build_ppo()
    per_rollout = model.n_steps * model.n_envs
    model.learn(per_rollout)  # warm-up: numba cache, torch, the env's first episodes
    timers = {k: Timer() for k in ("outer", "adapter", "vector_env", "kernel", "collect", "train")}
    adapter = _innermost(env)
    env.step_wait = timers["outer"].wrap(env.step_wait)
    adapter.step_wait = timers["adapter"].wrap(adapter.step_wait)
    adapter.venv.step = timers["vector_env"].wrap(adapter.venv.step)
    model.collect_rollouts = timers["collect"].wrap(model.collect_rollouts)
    model.train = timers["train"].wrap(model.train)
    kernels = (env_kernels.step_many, env_kernels.step_many_serial)
    env_kernels.step_many = timers["kernel"].wrap(kernels[0])
    env_kernels.step_many_serial = timers["kernel"].wrap(kernels[1])
    try:
        t0 = time.perf_counter()
        model.learn(rollouts * per_rollout, reset_num_timesteps=False)
        wall = time.perf_counter() - t0
    finally:
        env_kernels.step_many, env_kernels.step_many_serial = kernels
        env.close()
    sec = {k: t.seconds for k, t in timers.items()}
    return {
        "numba_threads": threads,
        "parallel_kernel": bool(adapter.venv.parallel),
        "rollouts": rollouts,
        "env_steps": rollouts * per_rollout,
        "wall_s": wall,
        "seconds": sec,
        "calls": {k: t.calls for k, t in timers.items()},
        "env_share": sec["outer"] / wall,
        "breakdown_share_of_wall": {
            "physics kernel": sec["kernel"] / wall,
            "vector env Python": (sec["vector_env"] - sec["kernel"]) / wall,
            "SB3 adapter (info dicts)": (sec["adapter"] - sec["vector_env"]) / wall,
            "VecNormalize + VecMonitor": (sec["outer"] - sec["adapter"]) / wall,
            "rollout: policy, buffer, callbacks": (sec["collect"] - sec["outer"]) / wall,
            "train (SGD epochs)": sec["train"] / wall,
            "other": (wall - sec["collect"] - sec["train"]) / wall,
        },
        "us_per_vector_step": {
            k: 1e6 * sec[k] / max(1, timers["outer"].calls) for k in ("outer", "vector_env", "kernel")
        },
    }


def native_vs_kernel(n: int, warm: int, steps: int, repeats: int) -> dict:
    """Env steps/s of the native env and of the kernel alone, numba on 1 thread, best of repeats."""
    import gymnasium as gym

    numba.set_num_threads(1)
    acts = _actions(warm + steps, n)
    venv = gym.make_vec("SmaSpine-v0", num_envs=n)
    best = {"native": np.inf, "kernel": np.inf}
    for _ in range(repeats):  # interleaved
        best["native"] = min(best["native"], time_vector(venv, acts, warm))
        best["kernel"] = min(best["kernel"], time_kernel(n, acts, warm))
    venv.close()
    rate = {k: n * steps / t for k, t in best.items()}
    return {**rate, "native_over_kernel": rate["native"] / rate["kernel"]}


def thread_scaling(n: int, warm: int, steps: int, repeats: int, n_threads: int) -> dict:
    """Env steps/s of the native env with 1 and ``n_threads`` numba threads (interleaved)."""
    import gymnasium as gym

    acts = _actions(warm + steps, n)
    venv = gym.make_vec("SmaSpine-v0", num_envs=n)
    best = {1: np.inf, n_threads: np.inf}
    for _ in range(repeats):
        for k in best:
            numba.set_num_threads(k)
            best[k] = min(best[k], time_vector(venv, acts, warm))
    numba.set_num_threads(n_threads)
    venv.close()
    rate = {k: n * steps / t for k, t in best.items()}
    return {"1": rate[1], str(n_threads): rate[n_threads], "speedup": rate[n_threads] / rate[1]}


def plot(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 5.2))
    runs = res["ppo"]
    labels = list(runs[0]["breakdown_share_of_wall"])
    left = np.zeros(len(runs))
    for lab in labels:
        vals = np.array([100 * r["breakdown_share_of_wall"][lab] for r in runs])
        ax.barh(range(len(runs)), vals, left=left, label=lab)
        left += vals
    ax.axvline(100 * TARGET_SHARE, color="k", ls="--", lw=1)
    ax.text(100 * TARGET_SHARE, -0.5, " env target 10 %", fontsize=8, va="bottom")
    ax.set_yticks(range(len(runs)))
    ax.set_yticklabels(
        [f"{r['numba_threads']} numba thread(s)\nenv share {100 * r['env_share']:.1f} %" for r in runs]
    )
    ax.set_xlabel("share of PPO.learn wall time [%] (the first four bars are the env's step_wait)")
    ax.set_title("PPO (shipped config, 8 native envs, torch 1 thread)")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3)
    names, vals, cols = [], [], []
    for n, r in res["native_vs_kernel"].items():
        names += [f"N={n}\nkernel", f"N={n}\nnative"]
        vals += [r["kernel"], r["native"]]
        cols += ["0.6", "tab:blue"]
    for n, r in res["threads"].items():
        k = [key for key in r if key not in ("1", "speedup")][0]
        names += [f"N={n}\nnative {k} thr"]
        vals += [r[k]]
        cols += ["tab:green"]
    ax2.bar(range(len(vals)), vals, color=cols)
    ax2.set_xticks(range(len(vals)))
    ax2.set_xticklabels(names, fontsize=8)
    ax2.set_ylabel("env steps per second")
    ax2.set_title("kernel alone vs native env (1 numba thread), native env on 2")
    for i, v in enumerate(vals):
        ax2.annotate(f"{v:,.0f}", (i, v), textcoords="offset points", xytext=(0, 3), ha="center", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rollouts", type=int, default=4, help="timed PPO rollouts (2048 env steps each)")
    ap.add_argument("--warm", type=int, default=50, help="untimed env steps before the rate timings")
    ap.add_argument("--steps", type=int, default=50, help="timed control periods per env (rates)")
    ap.add_argument("--repeats", type=int, default=3, help="best-of repeats of the rate timings")
    ap.add_argument("--sizes", type=int, nargs="+", default=[8, 256], help="env counts of the rate timings")
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--omp-passive", action="store_true", help="OMP_WAIT_POLICY=PASSIVE (see bench_env.py)")
    ap.add_argument("--tag", default="", help="suffix of the output file names")
    args = ap.parse_args(argv)
    for name in ("rollouts", "steps", "repeats"):
        if getattr(args, name) < 1:
            ap.error(f"--{name} must be >= 1, got {getattr(args, name)}")
    import torch

    torch.set_num_threads(1)
    info = machine()
    n_threads = numba.config.NUMBA_NUM_THREADS
    res: dict = {"ppo": [], "native_vs_kernel": {}, "threads": {}}
    t_start = time.perf_counter()
    for threads in (n_threads, 1):
        print(f"PPO, {args.rollouts} rollouts, numba threads {threads} ...", flush=True)
        res["ppo"].append(ppo_share(args.rollouts, threads))
    numba.set_num_threads(n_threads)
    time_kernel(2, _actions(2, 2))  # compile (or load) the kernel's signature for contiguous voltages
    for n in args.sizes:
        print(f"rates at N = {n} ...", flush=True)
        res["native_vs_kernel"][str(n)] = native_vs_kernel(n, args.warm, args.steps, args.repeats)
        res["threads"][str(n)] = thread_scaling(n, args.warm, args.steps, args.repeats, n_threads)
    info["load_average_end"] = os.getloadavg()
    info["torch_threads"] = torch.get_num_threads()
    info["wall_time_s"] = time.perf_counter() - t_start
    args.out.mkdir(parents=True, exist_ok=True)
    js, png = args.out / f"training_share{args.tag}.json", args.out / f"training_share{args.tag}.png"
    js.write_text(json.dumps({"machine": info, "results": res}, indent=2, default=float))
    plot(res, png)

    print(f"\nload average start {info['load_average_start'][0]:.1f}, end {info['load_average_end'][0]:.1f}")
    print("1. env share of PPO training (target <= 10 %):")
    for r in res["ppo"]:
        ok = "met" if r["env_share"] <= TARGET_SHARE else "NOT met"
        print(
            f"   numba threads {r['numba_threads']}: {100 * r['env_share']:5.1f} % of {r['wall_s']:.1f} s"
            f" ({ok});"
            f" per vector step {r['us_per_vector_step']['outer']:.0f} us, of which kernel"
            f" {r['us_per_vector_step']['kernel']:.0f} us"
        )
        for k, v in r["breakdown_share_of_wall"].items():
            print(f"      {k:<36} {100 * v:5.1f} %")
    print("2. native vector env per core vs kernel alone (target: within 10 %):")
    for n, r in res["native_vs_kernel"].items():
        ok = "met" if r["native_over_kernel"] >= TARGET_NATIVE_OVER_KERNEL else "NOT met"
        print(
            f"   N={n:4s} native {r['native']:8.0f}  kernel {r['kernel']:8.0f} steps/s"
            f"  native/kernel {r['native_over_kernel']:.2f} ({ok})"
        )
    print(
        f"3. scaling 1 -> {n_threads} numba threads (target: near-linear, >= {TARGET_SCALING}x; on a loaded"
        " machine the second thread gets only the second core's idle share: read as measured here)"
    )
    for n, r in res["threads"].items():
        ok = "met" if r["speedup"] >= TARGET_SCALING else "NOT met"
        print(
            f"   N={n:4s} 1 thread {r['1']:8.0f}  {n_threads} threads {r[str(n_threads)]:8.0f} steps/s"
            f"  {r['speedup']:.2f}x ({ok})"
        )
    print(f"wrote {js} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
