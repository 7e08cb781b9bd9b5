"""Benchmark: the native vector env's kernels on a quiet machine and beside one CPU-bound process.

``gym.make_vec("SmaSpine-v0", num_envs=N)`` three times in one process: the ``serial`` kernel
(``parallel=False``), the ``parallel`` kernel (``parallel=True``, all numba threads) and the
``default`` (``parallel=None``: serial below ``PARALLEL_MIN_ENVS`` = 64 envs, from there the online
choice of :mod:`spine_gym.envs._kernel_choice`). For each N two phases:

* ``quiet`` — nothing else started by this script (the load average is recorded: on a shared
  machine other processes may still run, so check it);
* ``busy`` — one CPU-bound process beside the measurement (a pure-Python spin loop, started by this
  script, stopped after the phase): what a user with one other busy program sees.

In each phase every env is reset with the same seed and driven ``--warm`` untimed steps (default 250
= 25 s: the wires transform and the model sub-steps adaptively), then ``--repeats`` blocks of timed
steps (``--block`` env steps, ≥ 50 vector steps), the three envs interleaved block by block.
The three do the same work (same seeds and actions; the kernels are bit-identical), so their rates
compare directly. The default env is the same object in both phases, so its chooser sees the load
start between them (as a training run would). Reported per configuration: the median of the
blocks' env steps per wall second, and the process's CPU time per env step (all threads: spinning
OpenMP workers show up here). Then a **trace**: the default env at N = ``--trace`` (64) runs on
without a break for four ``--segment`` (3 s) segments, quiet, busy, quiet, busy (load that starts
and stops mid-run): its rate and the share of its steps on the parallel kernel per segment.
Writes the entry ``--condition`` of ``benchmarks/results/contention.json`` (the others are kept) and
redraws ``contention.png`` (one row of panels per entry); the committed entries are ``quiet`` (an
idle machine), ``busy`` (one other CPU-bound job running throughout) and ``busy_spin`` (the same
with the second command).

    PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_contention.py [--sizes 8 64 256] [--repeats 7] [--condition busy]
    GOMP_SPINCOUNT=300000 PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_contention.py --condition busy_spin

The env starts numba's threads with sleeping OpenMP workers (:func:`spine_gym.envs._kernel_choice.
launch_threads`) unless ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` is set; the second command keeps
libgomp's default (idle workers spin up to 300 000 rounds after each parallel loop, as in a process
where libgomp was loaded before the env started numba's threads) and so shows the online kernel
choice alone.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np

import spine_gym
from spine_gym.envs.spine_vector_env import PARALLEL_MIN_ENVS

OUT = Path(__file__).resolve().parent / "results"
SEED = 1000
KERNELS = {"serial": False, "parallel": True, "default": None}
BUSY = "while True:\n    pass\n"  # one CPU-bound process


def load() -> dict:
    """Load averages and the runnable/total task counts of /proc/loadavg."""
    with open("/proc/loadavg") as f:
        parts = f.read().split()
    return {"loadavg": [float(x) for x in parts[:3]], "running/total": parts[3]}


def drive(venv, acts: np.ndarray) -> tuple[float, float]:
    """Wall and process CPU seconds of ``venv.step`` over ``acts``."""
    t0, c0 = time.perf_counter(), time.process_time()
    for a in acts:
        venv.step(a)
    return time.perf_counter() - t0, time.process_time() - c0


def phase(envs: dict, n: int, warm: int, steps: int, repeats: int) -> dict:
    """One phase at N = ``n``: reset, warm, then ``repeats`` interleaved timed blocks per env."""
    rng = np.random.default_rng(n)
    acts = rng.uniform(-1.0, 1.0, size=(warm + steps * repeats, n, 2)).astype(np.float32)
    for venv in envs.values():
        venv.reset(seed=SEED)
        drive(venv, acts[:warm])
    choice = envs["default"].kernel_choice
    before = list(choice.steps) if choice else None
    wall = {k: [] for k in envs}
    cpu = {k: [] for k in envs}
    for r in range(repeats):
        block = acts[warm + r * steps : warm + (r + 1) * steps]
        for key, venv in envs.items():
            w, c = drive(venv, block)
            wall[key].append(w)
            cpu[key].append(c)
    out = {}
    for key in envs:
        rates = n * steps / np.array(wall[key])
        out[key] = {
            "steps_per_s": float(np.median(rates)),
            "steps_per_s_blocks": rates.tolist(),
            "cpu_us_per_step": float(1e6 * np.median(cpu[key]) / (n * steps)),
            "wall_us_per_step": float(1e6 * np.median(wall[key]) / (n * steps)),
        }
    if choice:
        serial, par = (a - b for a, b in zip(choice.steps, before, strict=True))
        out["default"]["parallel_share"] = par / max(serial + par, 1)
        out["default"]["switches_total"] = choice.switches
    else:
        out["default"]["parallel_share"] = float(envs["default"].parallel)
    for key in ("parallel", "default"):
        out[key]["over_serial"] = out[key]["steps_per_s"] / out["serial"]["steps_per_s"]
    return out


def measure(n: int, args) -> dict:
    envs = {k: gym.make_vec("SmaSpine-v0", num_envs=n, parallel=p) for k, p in KERNELS.items()}
    steps = max(50, args.block // n)
    res = {"vector_steps_per_block": steps}
    for name in ("quiet", "busy"):
        busy = subprocess.Popen([sys.executable, "-c", BUSY]) if name == "busy" else None
        try:
            time.sleep(0.2 if busy else 0.0)
            start = load()
            res[name] = phase(envs, n, args.warm, steps, args.repeats)
            res[name]["load_start"], res[name]["load_end"] = start, load()
        finally:
            if busy:
                busy.kill()
                busy.wait()
        print_phase(n, name, res[name])
    for venv in envs.values():
        venv.close()
    return res


def trace(n: int, segment: float, count: int) -> list[dict]:
    """The default env at N = ``n`` run on without a break while the busy process is started and
    stopped every ``segment`` seconds (quiet first, ``count`` segments): its rate and the share of
    steps on the parallel kernel per segment (load that starts or stops mid-run)."""
    venv = gym.make_vec("SmaSpine-v0", num_envs=n)
    choice = venv.kernel_choice
    rng = np.random.default_rng(n)
    venv.reset(seed=SEED)
    drive(venv, rng.uniform(-1.0, 1.0, size=(250, n, 2)).astype(np.float32))
    out = []
    for k in range(count):
        busy = subprocess.Popen([sys.executable, "-c", BUSY]) if k % 2 else None
        try:
            before, steps, t0, c0 = list(choice.steps), 0, time.perf_counter(), time.process_time()
            while time.perf_counter() - t0 < segment:
                drive(venv, rng.uniform(-1.0, 1.0, size=(10, n, 2)).astype(np.float32))
                steps += 10
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        finally:
            if busy:
                busy.kill()
                busy.wait()
        serial, par = (a - b for a, b in zip(choice.steps, before, strict=True))
        seg = {
            "phase": "busy" if busy else "quiet",
            "steps_per_s": n * steps / wall,
            "cpu_us_per_step": 1e6 * cpu / (n * steps),
            "parallel_share": par / max(serial + par, 1),
            "load_end": load(),
        }
        out.append(seg)
        print(
            f"trace N={n} segment {k} {seg['phase']:>5}: {seg['steps_per_s']:>9,.0f} env steps/s, "
            f"{seg['cpu_us_per_step']:.1f} CPU µs/step, {100 * seg['parallel_share']:.0f} % on the parallel "
            f"kernel, load {seg['load_end']['loadavg'][0]:.2f}",
            flush=True,
        )
    venv.close()
    return out


def print_header() -> None:
    print(
        f"{'N':>4} {'phase':>5} | {'serial':>8} {'parallel':>8} {'default':>8}  env steps/s | "
        f"{'par/ser':>7} {'def/ser':>7} | {'def on par':>10} | CPU µs/step ser/par/def | load"
    )


def print_phase(n: int, name: str, r: dict) -> None:
    s, p, d = (r[k] for k in KERNELS)
    print(
        f"{n:>4} {name:>5} | {s['steps_per_s']:>8,.0f} {p['steps_per_s']:>8,.0f} {d['steps_per_s']:>8,.0f}"
        f"              | {p['over_serial']:>6.2f}x {d['over_serial']:>6.2f}x | "
        f"{100 * d['parallel_share']:>9.0f}% | {s['cpu_us_per_step']:5.1f} / {p['cpu_us_per_step']:5.1f}"
        f" / {d['cpu_us_per_step']:5.1f}      | {r['load_start']['loadavg'][0]:.2f}"
        f" → {r['load_end']['loadavg'][0]:.2f}",
        flush=True,
    )


def machine() -> dict:
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return {
        "cpu_count": os.cpu_count(),
        "numba_threads": numba.config.NUMBA_NUM_THREADS,
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numba": numba.__version__,
        "OMP_WAIT_POLICY": os.environ.get("OMP_WAIT_POLICY", "(unset)"),
        "GOMP_SPINCOUNT": os.environ.get("GOMP_SPINCOUNT", "(unset)"),
        "spine_gym": spine_gym.__version__,
        "git_commit": commit.stdout.strip() or "unknown",
        "parallel_min_envs": PARALLEL_MIN_ENVS,
    }


def plot(conditions: dict[str, dict], path: Path) -> None:
    """One row of panels (quiet phase, busy phase) per entry of ``conditions`` (name -> results)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, rows = plt.subplots(len(conditions), 2, figsize=(11, 4.2 * len(conditions)), squeeze=False)
    for axes, (condition, res) in zip(rows, conditions.items(), strict=True):
        _plot_row(axes, condition, res)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _plot_row(axes, condition: str, res: dict) -> None:
    sizes = res["sizes"]
    width = 0.27
    colors = {"serial": "tab:blue", "parallel": "tab:orange", "default": "tab:green"}
    for ax, name in zip(axes, ("quiet", "busy"), strict=True):
        x = np.arange(len(sizes))
        for j, key in enumerate(KERNELS):
            vals = [res["runs"][str(n)][name][key]["steps_per_s"] / 1e3 for n in sizes]
            bars = ax.bar(x + (j - 1) * width, vals, width, label=key, color=colors[key])
            if key != "serial":
                ratios = [res["runs"][str(n)][name][key]["over_serial"] for n in sizes]
                for b, r in zip(bars, ratios, strict=True):
                    ax.annotate(
                        f"{r:.2f}x", (b.get_x() + b.get_width() / 2, b.get_height()),
                        ha="center", va="bottom", fontsize=7,
                    )  # fmt: skip
        ax.set_xticks(x, [f"N = {n}" for n in sizes])
        ax.set_xlabel("number of sub-envs N (ratios: over the serial kernel, same run)")
        title = "quiet (nothing started beside it)" if name == "quiet" else "beside one CPU-bound process"
        ends = ("load_start", "load_end")
        loads = [res["runs"][str(n)][name][k]["loadavg"][0] for n in sizes for k in ends]
        ax.set_title(
            f"{condition}: SmaSpine-v0 native vector env, {title}\n"
            f"1-min load average {min(loads):.1f}-{max(loads):.1f}",
            fontsize=9,
        )
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].set_ylabel("env steps per wall second [thousands]")
    axes[0].legend(title="kernel", fontsize=8)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[8, 64, 256], help="env counts N")
    ap.add_argument("--warm", type=int, default=250, help="untimed steps per phase (default 250 = 25 s)")
    ap.add_argument("--repeats", type=int, default=7, help="timed blocks per env and phase (median)")
    ap.add_argument("--block", type=int, default=20000, help="env steps per timed block (>= 50 vector steps)")
    ap.add_argument("--trace", type=int, default=64, help="N of the start/stop trace (0: none)")
    ap.add_argument("--segment", type=float, default=3.0, help="seconds per trace segment (default 3)")
    ap.add_argument("--condition", default="busy", help="the entry of contention.json to write (quiet, busy, ...)")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    for name in ("warm", "repeats", "block"):
        if getattr(args, name) < 1:
            ap.error(f"--{name} must be >= 1, got {getattr(args, name)}")
    if args.trace and args.trace < PARALLEL_MIN_ENVS:
        ap.error(f"--trace must be 0 or >= PARALLEL_MIN_ENVS = {PARALLEL_MIN_ENVS}, got {args.trace}")
    if args.segment <= 0:
        ap.error(f"--segment must be > 0, got {args.segment}")
    if min(args.sizes) < 1:
        ap.error(f"--sizes must be >= 1, got {args.sizes}")
    info = machine()
    for p in (True, False):  # load numba's cache, start the thread pool
        venv = gym.make_vec("SmaSpine-v0", num_envs=2, parallel=p)
        venv.reset(seed=0)
        drive(venv, np.zeros((3, 2, 2), np.float32))
    info["numba_threading_layer"] = numba.threading_layer()
    info["load_start"] = load()
    t0 = time.perf_counter()
    print_header()
    runs = {str(n): measure(n, args) for n in sorted(args.sizes)}
    traced = trace(args.trace, args.segment, 4) if args.trace else []
    info["load_end"] = load()
    res = {"sizes": sorted(args.sizes), "warm_steps": args.warm, "repeats": args.repeats, "runs": runs}
    res["trace"] = {"num_envs": args.trace, "segment_s": args.segment, "segments": traced}
    res["wall_time_s"] = time.perf_counter() - t0
    args.out.mkdir(parents=True, exist_ok=True)
    out = {"machine": info, "results": res}
    path = args.out / "contention.json"
    merged = json.loads(path.read_text()) if path.exists() else {}
    merged[args.condition] = out
    path.write_text(json.dumps(merged, indent=2))
    plot({c: entry["results"] for c, entry in merged.items()}, args.out / "contention.png")
    env = f"OMP_WAIT_POLICY {info['OMP_WAIT_POLICY']}, GOMP_SPINCOUNT {info['GOMP_SPINCOUNT']}"
    print(f"threading layer {info['numba_threading_layer']}, {env}; {res['wall_time_s']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
