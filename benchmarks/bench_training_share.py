"""Benchmark: the environment's share of PPO training, the env layer's cost over the bare kernel,
and 1 → 2 numba threads. One command prints all three against their targets.

1. **Env share of PPO training** (target ≤ 10 %). The shipped PPO configuration
   (``spine_gym/agents/hyperparams/ppo.yml``: 8 native envs, ``n_steps`` 256, 10 epochs of minibatch 256,
   ``VecNormalize`` of the observations), torch on 1 thread, built as :mod:`spine_gym.agents.train` builds it;
   ``PPO.learn`` for ``--rollouts`` rollouts after one untimed warm-up rollout. Timed by wrapping
   (no change to the library): the outermost ``step_wait`` that PPO calls (``VecNormalize`` →
   ``VecMonitor`` → adapter), the adapter's ``step_wait`` (:class:`spine_gym.envs.sb3.SmaSpineSB3VecEnv`),
   the vector env's ``step_arrays`` and the one jitted call of a step inside it (physics and
   bookkeeping, :mod:`spine_gym.envs.step_kernels`), plus PPO's ``collect_rollouts`` and
   ``train``. **The env share the target means is the adapter's ``step_wait`` over the wall time
   of ``learn``** (the env's own step: physics, bookkeeping, the
   per-env info dicts); the share including SB3's ``VecMonitor`` and ``VecNormalize`` (their
   running statistics are SB3 code) is printed beside it. Two runs: the default kernel choice
   (``parallel=None``: serial below ``PARALLEL_MIN_ENVS`` envs, so serial at 8) and
   ``parallel=True`` on all numba threads.
2. **Native vector env per core vs the kernel alone** (target: within 10 %, native rate ≥ 0.9 ×
   kernel rate), for every env id: ``gym.make_vec(env_id, num_envs=N, parallel=False)`` with numba
   on 1 thread, from the warm regime (``--warm`` untimed steps), ``--steps`` timed steps; the
   kernel alone is the physics alone (``spine_loops.step_many_serial`` or its spatial twin)
   replaying the steps the native env made (the voltages, loads and resolve flags its calls
   computed, on the same start states, checked bit for bit at the end): same states, same
   steps, no bookkeeping and no Python in between. Best of ``--repeats`` interleaved runs.
3. **Scaling from 1 to 2 numba threads** (target: near-linear, ≥ 1.8×): the native env with the
   parallel kernel (``parallel=True``) on 1 and 2 threads, and the serial kernel, at each of
   ``--scaling-sizes``, interleaved run by run. The same sweep gives the threshold of the default
   kernel choice: the smallest N from which the parallel kernel on 2 threads beats the serial one.
   Two peers in the same run say where a shortfall comes from: the **kernel alone** (the recorded
   physics calls of item 2 replayed through the parallel kernel on 1 and 2 threads: no Python,
   the envs' uneven sub-step counts and the threads' start-up remain; also with numba's own fixed
   blocks of rows per thread instead of rows dealt out one at a time, the kernel before
   ``spine_gym.physics._deal``) and the **machine's ceiling**
   (a compute-bound ``prange`` loop of equal iterations, no memory traffic: what a second thread
   can give on this machine at all).

The machine this was written on has 2 cores shared with other jobs: every time is an upper bound
of the time on a quiet machine (every rate a lower bound), and the 1 → 2 thread scaling cannot show
more than the second core's idle share, so it is a figure of this machine's load, not of the code.
The load average at start and end is recorded. Writes ``benchmarks/results/training_share.json`` and ``.png``.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_training_share.py --rollouts 6   # ~5-10 min loaded
    .venv/bin/python benchmarks/bench_training_share.py --omp-passive --tag _passive
    .venv/bin/python benchmarks/bench_training_share.py --plot-only   # the .png from the recorded .json
"""

from __future__ import annotations

import os
import sys

if "--omp-passive" in sys.argv:  # before numba's OpenMP runtime starts (as bench_env.py)
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"

import argparse
import json
import math
import time
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling bench_env (also as a module)

from bench_env import SEED, machine  # noqa: E402
from spine_loops import step_many, step_many_serial, step_many_spatial_serial  # noqa: E402

import spine_gym  # noqa: E402, F401 - registers the env ids
from spine_gym.envs import readout as ro  # noqa: E402
from spine_gym.envs import step_kernels as sk  # noqa: E402
from spine_gym.envs.spine_vector_env import PARALLEL_MIN_ENVS  # noqa: E402
from spine_gym.physics.planar.control import step_spine  # noqa: E402

OUT = Path(__file__).resolve().parent / "results"
IDS = ("SmaSpine-v0", "SmaSpine3D-v0", "SmaSpineChain-v0")
SHORT = dict(zip(IDS, ("planar", "3D", "chain"), strict=True))
KERNELS = ("planar_step", "planar_step_serial", "spatial_step", "spatial_step_serial")  # the env's one call
PLANAR_KERNELS = (sk.planar_step, sk.planar_step_serial)  # the originals (Patch replaces the attributes)
TARGET_SHARE = 0.10  # env share of PPO wall time (the adapter's step_wait)
TARGET_NATIVE_OVER_KERNEL = 0.90  # native env rate per core / kernel-only rate
TARGET_SCALING = 1.8  # 2 threads / 1 thread ("near-linear")


class Timer:
    """Accumulated wall time and CPU time of the calling thread of a wrapped callable."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.cpu = 0.0
        self.calls = 0

    def wrap(self, fn):
        def timed(*args, **kwargs):
            t0, c0 = time.perf_counter(), time.thread_time()
            try:
                return fn(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - t0
                self.cpu += time.thread_time() - c0
                self.calls += 1

        return timed


def _breakdown(sec: dict, total: float) -> dict:
    """Shares of ``total`` of the nested timers (the env's step split into its layers)."""
    return {
        "jitted step (physics + bookkeeping)": sec["kernel"] / total,
        "vector env Python": (sec["vector_env"] - sec["kernel"]) / total,
        "SB3 adapter (info dicts)": (sec["adapter"] - sec["vector_env"]) / total,
        "VecNormalize + VecMonitor (SB3)": (sec["outer"] - sec["adapter"]) / total,
        "rollout: policy, buffer, callbacks": (sec["collect"] - sec["outer"]) / total,
        "train (SGD epochs)": sec["train"] / total,
        "other": (total - sec["collect"] - sec["train"]) / total,
    }


class Patch:
    """Replace the env's step kernels (``step_kernels`` attributes, looked up at call time) by
    ``wrap(kernel)``."""

    def __init__(self, wrap) -> None:
        self.wrap = wrap

    def __enter__(self):
        self.orig = {name: getattr(sk, name) for name in KERNELS}
        for name, fn in self.orig.items():
            setattr(sk, name, self.wrap(fn))
        return self

    def __exit__(self, *exc) -> None:
        for name, fn in self.orig.items():
            setattr(sk, name, fn)


# ---------------------------------------------------------------- 1. PPO
def _build_ppo(parallel: bool | None, seed: int = 0):
    """(model, vec env) of the shipped PPO configuration, as ``spine_gym.agents.train`` builds them."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from spine_gym.agents.vec_env import make_vec_env
    from spine_gym.agents.zoo_config import ENV_ID, load_hyperparams, preprocess_hyperparams

    hp, special = preprocess_hyperparams(load_hyperparams("ppo", ENV_ID))
    kwargs = {**special["env_kwargs"], "parallel": parallel}
    env = make_vec_env(ENV_ID, int(special["n_envs"]), seed=seed, env_kwargs=kwargs)
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


def ppo_share(rollouts: int, parallel: bool | None, threads: int) -> dict:
    """Time one PPO.learn of ``rollouts`` rollouts (after a warm-up rollout) with nested timers."""
    numba.set_num_threads(threads)
    model, env = _build_ppo(parallel)
    per_rollout = model.n_steps * model.n_envs
    model.learn(per_rollout)  # warm-up: numba cache, torch, the env's first episodes
    timers = {k: Timer() for k in ("outer", "adapter", "vector_env", "kernel", "collect", "train")}
    adapter = _innermost(env)
    env.step_wait = timers["outer"].wrap(env.step_wait)
    adapter.step_wait = timers["adapter"].wrap(adapter.step_wait)
    adapter.venv.step_arrays = timers["vector_env"].wrap(adapter.venv.step_arrays)
    model.collect_rollouts = timers["collect"].wrap(model.collect_rollouts)
    model.train = timers["train"].wrap(model.train)
    with Patch(timers["kernel"].wrap):
        t0, c0 = time.perf_counter(), time.thread_time()
        model.learn(rollouts * per_rollout, reset_num_timesteps=False)
        wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    env.close()
    sec = {k: t.seconds for k, t in timers.items()}
    cpu_sec = {k: t.cpu for k, t in timers.items()}
    steps = max(1, timers["outer"].calls)
    kernel = "parallel" if adapter.venv.parallel else "serial"
    return {
        "label": f"parallel={parallel} ({kernel} kernel), {threads} numba threads",
        "parallel_arg": parallel,
        "parallel_kernel": bool(adapter.venv.parallel),
        "numba_threads": threads,
        "rollouts": rollouts,
        "env_steps": rollouts * per_rollout,
        "wall_s": wall,
        "main_thread_cpu_s": cpu,
        "seconds": sec,
        "cpu_seconds": cpu_sec,
        "calls": {k: t.calls for k, t in timers.items()},
        "env_share": sec["adapter"] / wall,
        "env_share_with_wrappers": sec["outer"] / wall,
        "env_share_cpu": cpu_sec["adapter"] / cpu,
        "env_share_with_wrappers_cpu": cpu_sec["outer"] / cpu,
        "breakdown_share_of_wall": _breakdown(sec, wall),
        "breakdown_share_of_main_thread_cpu": _breakdown(cpu_sec, cpu),
        "us_per_vector_step": {k: 1e6 * sec[k] / steps for k in ("outer", "adapter", "vector_env", "kernel")},
    }


# ---------------------------------------------------------------- 2. native env vs kernel alone
def env_actions(env_id: str, steps: int, n: int) -> np.ndarray:
    """(steps, n, W) uniform actions in [-1, 1]; column i from generator i (the same for every run)."""
    w = gym.make_vec(env_id, num_envs=1).single_action_space.shape[0]
    return np.stack(
        [np.random.default_rng(i).uniform(-1.0, 1.0, size=(steps, w)) for i in range(n)], axis=1
    ).astype(np.float32)


def time_native(venv, acts: np.ndarray, warm: int) -> tuple[float, float]:
    """Wall and CPU seconds (calling thread) of ``venv.step`` over ``acts[warm:]`` after
    ``reset(seed=SEED)`` and ``warm`` untimed steps."""
    venv.reset(seed=SEED)
    for a in acts[:warm]:
        venv.step(a)
    t0, c0 = time.perf_counter(), time.thread_time()
    for a in acts[warm:]:
        venv.step(a)
    return time.perf_counter() - t0, time.thread_time() - c0


def physics_call(fn, args) -> tuple:
    """The physics alone of one step kernel call ``fn(*args)`` made by the env (after it returned):
    ``spine_loops.step_many_serial`` (or its spatial twin) with the voltages, loads and resolve
    flags that call computed, on the same arrays; per-call inputs copied."""
    rows, _, drive, plant, step, _, _, _ = args
    st = ro.Step(*step)
    active = np.zeros(st.status.shape[0], dtype=np.bool_)
    active[rows] = True
    resolve = drive[3].copy()
    if fn in PLANAR_KERNELS:
        p = sk.PlanarPlant(*plant)
        volts = (st.volts[:, 0].copy(), st.volts[:, 1].copy())
        kernel, head = step_many_serial, (p.kps, p.ks)
    else:
        p = sk.SpatialPlant(*plant)
        volts = (st.volts.copy(),)
        kernel, head = step_many_spatial_serial, (p.kps, p.ks, p.kws, p.kms)
    tail = (st.loads.copy(), resolve, active, p.physics_dt, p.n_sub, st.status, p.meas)
    return kernel, (p.states, p.backup, *head, *volts, *tail)


def record_kernel_calls(venv, acts: np.ndarray, warm: int) -> tuple[list, np.ndarray, np.ndarray]:
    """The physics-only calls (:func:`physics_call`) of the timed steps, the states before the
    first and the states after the last."""
    calls = []

    def recorder(fn):
        def rec(*args):
            ok = fn(*args)
            calls.append(physics_call(fn, args))
            return ok

        return rec

    venv.reset(seed=SEED)
    for a in acts[:warm]:
        venv.step(a)
    start = venv.unwrapped._core.states.copy()
    with Patch(recorder):
        for a in acts[warm:]:
            venv.step(a)
    return calls, start, venv.unwrapped._core.states.copy()


def time_replay(calls: list, start: np.ndarray, final_states: np.ndarray) -> tuple[float, float]:
    """Seconds of the recorded physics calls back to back from the recorded start states (the
    replay's own copy; checked to end on the native env's states bit for bit), with the per-call
    inputs (voltages, loads, flags) as recorded and the env's scratch and output arrays (the
    native runs rewrite them from their reset on)."""
    states = start.copy()
    prepared = [(fn, (states, *args[1:])) for fn, args in calls]
    t0, c0 = time.perf_counter(), time.thread_time()
    for fn, args in prepared:
        fn(*args)
    elapsed = time.perf_counter() - t0, time.thread_time() - c0
    if not np.array_equal(states, final_states):
        raise RuntimeError("the kernel replay did not reproduce the native env's states")
    return elapsed


def native_vs_kernel(env_id: str, n: int, warm: int, steps: int, repeats: int) -> dict:
    """Env steps/s of the native env (serial kernel, 1 numba thread) and of its kernel calls alone."""
    numba.set_num_threads(1)
    acts = env_actions(env_id, warm + steps, n)
    venv = gym.make_vec(env_id, num_envs=n, parallel=False)
    calls, start, final = record_kernel_calls(venv, acts, warm)
    time_replay(calls, start, final)  # untimed: compiles the replay's (contiguous) specialisation
    best = {k: np.array([np.inf, np.inf]) for k in ("native", "kernel")}  # (wall, CPU)
    for _ in range(repeats):  # interleaved
        best["native"] = np.minimum(best["native"], time_native(venv, acts, warm))
        best["kernel"] = np.minimum(best["kernel"], time_replay(calls, start, final))
    venv.close()
    out = {}
    for k, (wall, cpu) in best.items():
        out[k] = n * steps / wall  # env steps per wall second
        out[f"{k}_per_cpu_s"] = n * steps / cpu  # env steps per CPU second of the (one) thread
        out[f"{k}_us_per_vector_step"] = 1e6 * wall / steps
    out["native_over_kernel"] = out["native"] / out["kernel"]
    out["native_over_kernel_cpu"] = out["native_per_cpu_s"] / out["kernel_per_cpu_s"]
    return out


# ---------------------------------------------------------------- 3. threads
def thread_scaling(sizes: list[int], warm: int, steps: int, repeats: int, n_threads: int) -> dict:
    """Env steps/s of SmaSpine-v0's native env: serial kernel, parallel kernel on 1 and on
    ``n_threads`` threads, per N (interleaved run by run)."""
    out = {}
    for n in sizes:
        acts = env_actions("SmaSpine-v0", warm + steps, n)
        serial = gym.make_vec("SmaSpine-v0", num_envs=n, parallel=False)
        par = gym.make_vec("SmaSpine-v0", num_envs=n, parallel=True)
        configs = {
            "serial": (serial, n_threads),
            "parallel_1": (par, 1),
            f"parallel_{n_threads}": (par, n_threads),
        }
        best = dict.fromkeys(configs, np.inf)
        for _ in range(repeats):
            for key, (venv, k) in configs.items():
                numba.set_num_threads(k)
                best[key] = min(best[key], time_native(venv, acts, warm)[0])
        numba.set_num_threads(n_threads)
        serial.close()
        par.close()
        rate = {k: n * steps / t for k, t in best.items()}
        out[str(n)] = {
            **rate,
            "speedup": rate[f"parallel_{n_threads}"] / rate["parallel_1"],
            "parallel_over_serial": rate[f"parallel_{n_threads}"] / rate["serial"],
            "default_kernel": "parallel" if n >= PARALLEL_MIN_ENVS else "serial",
        }
        print(f"   N={n}: {', '.join(f'{k} {v:,.0f}' for k, v in rate.items())} steps/s", flush=True)
    return out


@numba.njit(parallel=True)
def _fixed_blocks(states, backup, kps, ks, v_r, v_l, loads, resolve, active, dt, n_sub, status, meas):
    """``spine_loops.step_many`` as it was before its rows were dealt out (``physics._deal``): numba's
    own ``prange`` schedule, one fixed block of rows per thread (the peer of item 3)."""
    for i in numba.prange(states.shape[0]):
        if active[i]:
            status[i] = step_spine(
                states[i], backup[i], kps[i], ks, v_r[i], v_l[i], loads[i], resolve[i], dt, n_sub, meas[i]
            )


def kernel_scaling(n: int, warm: int, steps: int, repeats: int, n_threads: int) -> dict:
    """Env steps/s of SmaSpine-v0's physics alone (item 2's recorded calls, replayed through the
    parallel kernel ``spine_loops.step_many``, rows dealt out one at a time) on 1 and ``n_threads``
    numba threads, and the same with fixed blocks of rows per thread (:func:`_fixed_blocks`),
    interleaved."""
    numba.set_num_threads(1)
    acts = env_actions("SmaSpine-v0", warm + steps, n)
    venv = gym.make_vec("SmaSpine-v0", num_envs=n, parallel=False)
    calls, start, final = record_kernel_calls(venv, acts, warm)
    venv.close()
    kernels = {"dealt": step_many, "blocks": _fixed_blocks}
    replays = {key: [(fn, args) for _, args in calls] for key, fn in kernels.items()}
    for key in replays:
        time_replay(replays[key], start, final)  # untimed: compiles the parallel replay
    best = {(key, k): np.inf for key in replays for k in (1, n_threads)}
    for _ in range(repeats):
        for key, k in best:
            numba.set_num_threads(k)
            best[key, k] = min(best[key, k], time_replay(replays[key], start, final)[0])
    numba.set_num_threads(n_threads)
    rate = {f"threads_{k}": n * steps / best["dealt", k] for k in (1, n_threads)}
    blocks = {f"blocks_threads_{k}": n * steps / best["blocks", k] for k in (1, n_threads)}
    return {
        **rate,
        **blocks,
        "speedup": rate[f"threads_{n_threads}"] / rate["threads_1"],
        "blocks_speedup": blocks[f"blocks_threads_{n_threads}"] / blocks["blocks_threads_1"],
    }


@numba.njit(parallel=True)
def _busy(out, work):
    """A compute-bound prange loop of equal iterations (no memory traffic)."""
    for i in numba.prange(out.shape[0]):
        x = 0.0
        for k in range(work):
            x += math.sin(x + 1e-3 * k)
        out[i] = x


def machine_ceiling(n_threads: int, repeats: int, iterations: int = 256, work: int = 20_000) -> dict:
    """Speed-up of :func:`_busy` from 1 to ``n_threads`` numba threads (best of ``repeats``)."""
    out = np.empty(iterations)
    _busy(out, 10)  # compile
    best = {1: np.inf, n_threads: np.inf}
    for _ in range(repeats):
        for k in best:
            numba.set_num_threads(k)
            t0 = time.perf_counter()
            _busy(out, work)
            best[k] = min(best[k], time.perf_counter() - t0)
    numba.set_num_threads(n_threads)
    speedup = best[1] / best[n_threads]
    return {"seconds_1": best[1], f"seconds_{n_threads}": best[n_threads], "speedup": speedup}


# ---------------------------------------------------------------- report
def plot(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2, ax3) = plt.subplots(1, 3, figsize=(18, 5.4))
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
        [
            f"{r['label']}\nenv {100 * r['env_share']:.1f} %"
            f" (+SB3 wrappers {100 * r['env_share_with_wrappers']:.1f} %)"
            for r in runs
        ],
        fontsize=8,
    )
    ax.set_xlabel("share of PPO.learn wall time [%] (the first three bars are the env's step)")
    ax.set_title("PPO (shipped config, 8 native envs, torch 1 thread)")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3)
    names, vals = [], []
    for key, r in res["native_vs_kernel"].items():
        env_id, size = key.split(" ")
        names.append(f"{SHORT[env_id]}\n{size}")
        vals.append(r["native_over_kernel"])
    ax2.bar(range(len(vals)), vals, color="tab:blue")
    ax2.axhline(TARGET_NATIVE_OVER_KERNEL, color="k", ls="--", lw=1, label="target 0.9")
    ax2.set_xticks(range(len(vals)))
    ax2.set_xticklabels(names, fontsize=8)
    ax2.set_ylim(0, 1.1)
    ax2.set_ylabel("native env rate / kernel-alone rate (1 thread)")
    ax2.set_title("env layer cost per core (planar, 3D, chain)")
    for i, v in enumerate(vals):
        ax2.annotate(f"{v:.2f}", (i, v), textcoords="offset points", xytext=(0, 3), ha="center", fontsize=8)
    ax2.legend(fontsize=8)
    sizes = [int(n) for n in res["threads"]]
    for key, style in (("serial", "s-"), ("parallel_1", "o--")):
        ax3.semilogx(
            sizes,
            [res["threads"][str(n)][key] for n in sizes],
            style,
            label=key.replace("_", ", ") + " thread",
        )
    k = [key for key in res["threads"][str(sizes[0])] if key.startswith("parallel_") and key != "parallel_1"][
        0
    ]
    ax3.semilogx(
        sizes, [res["threads"][str(n)][k] for n in sizes], "o-", label=k.replace("_", ", ") + " threads"
    )
    ax3.axvline(PARALLEL_MIN_ENVS, color="k", ls=":", lw=1)
    ax3.text(
        PARALLEL_MIN_ENVS,
        ax3.get_ylim()[0],
        " default: parallel from here",
        fontsize=8,
        rotation=90,
        va="bottom",
    )
    ax3.set_xlabel("number of environments N")
    ax3.set_ylabel("env steps per second (SmaSpine-v0)")
    ax3.set_title("serial vs parallel kernel, 1 and 2 numba threads")
    ax3.legend(fontsize=8)
    ax3.grid(True, which="both", alpha=0.3)
    fig.suptitle(f"the env's share of PPO training and its speed ({res['machine']['cpu_count']} cores)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def report(res: dict, n_threads: int) -> None:
    info = res["machine"]
    print(f"\nload average start {info['load_average_start'][0]:.1f}, end {info['load_average_end'][0]:.1f}")
    print("1. env share of PPO training (target <= 10 %; the adapter's step_wait, i.e. the env's own step;")
    print("   by wall time, and by the main thread's CPU time, which a loaded machine distorts less):")
    for r in res["ppo"]:
        ok = " and ".join(
            ("met" if r[k] <= TARGET_SHARE else "NOT met") + f" ({c})"
            for k, c in (("env_share", "wall"), ("env_share_cpu", "CPU"))
        )
        us = r["us_per_vector_step"]
        print(
            f"   {r['label']}: env {100 * r['env_share']:.1f} % of wall,"
            f" {100 * r['env_share_cpu']:.1f} % of CPU"
            f" -> {ok}; with VecMonitor + VecNormalize {100 * r['env_share_with_wrappers']:.1f} % /"
            f" {100 * r['env_share_with_wrappers_cpu']:.1f} %; {r['wall_s']:.1f} s wall;"
            f" per vector step {us['adapter']:.0f} us, jitted step {us['kernel']:.0f} us"
        )
        cpu = r["breakdown_share_of_main_thread_cpu"]
        for k, v in r["breakdown_share_of_wall"].items():
            print(f"      {k:<36} {100 * v:5.1f} % wall  {100 * cpu[k]:5.1f} % CPU")
    print("2. native vector env per core vs the kernel alone (target: native/kernel >= 0.9; per wall and")
    print("   per CPU second of the one thread):")
    for key, r in res["native_vs_kernel"].items():
        ok = ", ".join(
            f"{r[k]:.2f} " + ("met" if r[k] >= TARGET_NATIVE_OVER_KERNEL else "NOT met") + f" ({c})"
            for k, c in (("native_over_kernel", "wall"), ("native_over_kernel_cpu", "CPU"))
        )
        print(
            f"   {key:<24} native {r['native']:7.0f}  kernel {r['kernel']:7.0f} steps/s;"
            f" per CPU s {r['native_per_cpu_s']:7.0f} / {r['kernel_per_cpu_s']:7.0f}; native/kernel {ok}"
        )
    print(
        f"3. scaling 1 -> {n_threads} numba threads, parallel kernel"
        f" (target: near-linear, >= {TARGET_SCALING}x;"
        " on a loaded machine the second thread gets only the second core's idle share)"
    )
    for n, r in res["threads"].items():
        ok = "met" if r["speedup"] >= TARGET_SCALING else "NOT met"
        print(
            f"   N={n:5s} parallel 1 thread {r['parallel_1']:8.0f}  {n_threads} threads"
            f" {r[f'parallel_{n_threads}']:8.0f}  serial {r['serial']:8.0f} steps/s"
            f"  scaling {r['speedup']:.2f}x"
            f" ({ok}); parallel/serial {r['parallel_over_serial']:.2f} (default: {r['default_kernel']})"
        )
    for n, r in res["kernel_threads"].items():
        print(
            f"   kernel alone N={n:5s} 1 thread {r['threads_1']:8.0f}  {n_threads} threads"
            f" {r[f'threads_{n_threads}']:8.0f} steps/s  scaling {r['speedup']:.2f}x"
            f" (rows dealt out; fixed blocks of rows: {r['blocks_speedup']:.2f}x)"
        )
    print(f"   machine ceiling (compute-bound prange loop): {res['machine_ceiling']['speedup']:.2f}x")
    wins = [int(n) for n, r in res["threads"].items() if r["parallel_over_serial"] > 1.0]
    print(
        f"   default threshold PARALLEL_MIN_ENVS = {PARALLEL_MIN_ENVS};"
        " the parallel kernel beat the serial one"
        f" here at N = {wins or 'none'}"
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rollouts", type=int, default=4, help="timed PPO rollouts (2048 env steps each)")
    ap.add_argument("--warm", type=int, default=50, help="untimed env steps before the rate timings")
    ap.add_argument("--steps", type=int, default=50, help="timed control periods per env (rates)")
    ap.add_argument("--repeats", type=int, default=3, help="best-of repeats of the rate timings")
    ap.add_argument("--sizes", type=int, nargs="+", default=[8, 256], help="env counts of item 2 (planar)")
    ap.add_argument(
        "--spatial-sizes", type=int, nargs="+", default=[8, 64], help="env counts of item 2 (3D, chain)"
    )
    ap.add_argument(
        "--scaling-sizes", type=int, nargs="+", default=[8, 16, 32, 64, 128, 256], help="env counts of item 3"
    )
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--omp-passive", action="store_true", help="OMP_WAIT_POLICY=PASSIVE (see bench_env.py)")
    ap.add_argument("--tag", default="", help="suffix of the output file names")
    ap.add_argument(
        "--plot-only", action="store_true", help="redraw the .png from the recorded .json; measure nothing"
    )
    args = ap.parse_args(argv)
    if args.plot_only:
        js, png = args.out / f"training_share{args.tag}.json", args.out / f"training_share{args.tag}.png"
        plot(json.loads(js.read_text()), png)
        print(f"wrote {png} from {js}")
        return 0
    for name in ("rollouts", "steps", "repeats", "warm"):
        if getattr(args, name) < (0 if name == "warm" else 1):
            ap.error(f"--{name} must be >= {0 if name == 'warm' else 1}, got {getattr(args, name)}")
    import torch

    torch.set_num_threads(1)
    info = machine()
    n_threads = numba.config.NUMBA_NUM_THREADS
    res: dict = {k: {} for k in ("native_vs_kernel", "threads", "kernel_threads", "machine_ceiling")}
    res["ppo"] = []
    t_start = time.perf_counter()
    for parallel in (None, True):
        print(f"1. PPO, {args.rollouts} rollouts, parallel={parallel} ...", flush=True)
        res["ppo"].append(ppo_share(args.rollouts, parallel, n_threads))
    for env_id in IDS:
        for n in args.sizes if env_id == "SmaSpine-v0" else args.spatial_sizes:
            print(f"2. native vs kernel, {env_id} N = {n} ...", flush=True)
            res["native_vs_kernel"][f"{env_id} N={n}"] = native_vs_kernel(
                env_id, n, args.warm, args.steps, args.repeats
            )
    print("3. threads ...", flush=True)
    res["threads"] = thread_scaling(
        sorted(args.scaling_sizes), args.warm, args.steps, args.repeats, n_threads
    )
    res["kernel_threads"] = {
        str(n): kernel_scaling(n, args.warm, args.steps, args.repeats, n_threads)
        for n in sorted(
            {min(args.scaling_sizes), max(args.scaling_sizes)}
            | ({PARALLEL_MIN_ENVS} & set(args.scaling_sizes))
        )
    }
    res["machine_ceiling"] = machine_ceiling(n_threads, args.repeats)
    info["load_average_end"] = os.getloadavg()
    info["torch_threads"] = torch.get_num_threads()
    info["wall_time_s"] = time.perf_counter() - t_start
    info["parallel_min_envs"] = PARALLEL_MIN_ENVS
    res["machine"] = info
    args.out.mkdir(parents=True, exist_ok=True)
    js, png = args.out / f"training_share{args.tag}.json", args.out / f"training_share{args.tag}.png"
    js.write_text(json.dumps(res, indent=2, default=float))
    plot(res, png)
    report(res, n_threads)
    print(f"wrote {js} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
