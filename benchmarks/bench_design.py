"""Benchmark: capacity-protocol designs evaluated per second, serial vs parallel.

Runs the same grid of designs (full MODEL.md §10.4 protocol, 60 + 60 + 30 s) four ways in one
process and reports designs/s and the ratio to the serial run measured in the same session:

* ``serial``        — one process, one design after the other;
* ``process_cold``  — ``sweep(n_workers=K)``: a fresh ``spawn`` process pool per sweep (includes
  the worker start-up: import + loading numba's on-disk cache);
* ``process_warm``  — the same pool reused (``sweep(executor=...)``) after a warm-up sweep;
* ``thread``        — a thread pool of K threads (the jitted loop is ``nogil``).

Every parallel result is checked to be bit-identical to the serial one. A second part times the
optimiser (TPE, same constrained problem, journal-file storage) with 1 and K worker processes on
one study: trials/s including sampler, storage and worker start-up. Writes
``benchmarks/results/design_speed.json``.

    .venv/bin/python benchmarks/bench_design.py [--workers 2] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import platform
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import optuna

from spine_gym.capacity import CapacityProtocol
from spine_gym.design import DesignProblem, optimize, sweep
from spine_gym.design.optimizer import make_storage

AXES = {"a": list(np.linspace(6e-3, 14e-3, 5)), "n_w": [1, 2, 3]}  # 15 designs
OUT = Path(__file__).resolve().parent / "results" / "design_speed.json"


def _timed(fn, repeats: int):
    best, result = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3, help="best-of repeats per mode")
    ap.add_argument("--trials", type=int, default=60, help="optimiser budget per run")
    args = ap.parse_args(argv)
    k = args.workers
    proto = CapacityProtocol()
    n = int(np.prod([len(v) for v in AXES.values()]))

    sweep({"a": [14e-3]}, protocol=proto)  # load/compile the kernels before timing
    t_serial, ref = _timed(lambda: sweep(AXES, protocol=proto, n_workers=1), args.repeats)
    t_cold, cold = _timed(lambda: sweep(AXES, protocol=proto, n_workers=k), args.repeats)
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=k, mp_context=ctx) as ex:
        sweep(AXES, protocol=proto, executor=ex)  # warm-up: start workers, load the numba cache
        t_warm, warm = _timed(lambda: sweep(AXES, protocol=proto, executor=ex, n_workers=k), args.repeats)
    t_thread, thr = _timed(lambda: sweep(AXES, protocol=proto, n_workers=k, backend="thread"), args.repeats)
    identical = ref.rows == cold.rows == warm.rows == thr.rows

    # optimiser scale-out: the same budget with 1 and k worker processes on one journal study
    problem = DesignProblem(
        space=("a=6e-3:14e-3", "n_w=1,2,3", "eps0=0.03:0.06"),
        metric="stable_angle",
        constraints=("ability>=0.15", "responding_time<=36"),
        protocol=proto,
    )
    opt = {}
    with tempfile.TemporaryDirectory() as tmp:
        for workers in sorted({1, k}):
            t0 = time.perf_counter()
            r = optimize(
                problem, n_trials=args.trials, storage=f"{tmp}/w{workers}.journal", n_workers=workers
            )
            dt = time.perf_counter() - t0
            # time from the first trial's start to the last trial's end (excludes worker start-up)
            st = optuna.load_study(
                study_name="spine-design", storage=make_storage(f"{tmp}/w{workers}.journal")
            )
            span = (
                max(t.datetime_complete for t in st.trials) - min(t.datetime_start for t in st.trials)
            ).total_seconds()
            opt[f"workers_{workers}"] = {
                "seconds": dt,
                "trials_per_s": args.trials / dt,
                "trial_phase_seconds": span,
                "trials_per_s_excluding_startup": args.trials / span,
                "best_stable_angle_deg": None if r.best is None else r.best["value"],
            }
    t1 = opt["workers_1"]["seconds"]
    for v in opt.values():
        v["speedup_vs_1_worker"] = t1 / v["seconds"]

    def entry(t):
        return {"seconds": t, "designs_per_s": n / t, "speedup_vs_serial": t_serial / t}

    res = {
        "benchmark": "capacity protocol (MODEL.md §10.4, 150 s simulated) per design",
        "n_designs": n,
        "grid": {k_: [v if isinstance(v, int) else float(v) for v in vals] for k_, vals in AXES.items()},
        "workers": k,
        "repeats_best_of": args.repeats,
        "cpu_count": os.cpu_count(),
        "load_average_1min": os.getloadavg()[0],
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "serial": entry(t_serial),
        "process_cold": entry(t_cold),
        "process_warm": entry(t_warm),
        "thread": entry(t_thread),
        "bit_identical_to_serial": identical,
        "optimizer": {"n_trials": args.trials, "sampler": "tpe", "storage": "journal file", **opt},
        "date": time.strftime("%Y-%m-%d %H:%M:%S"),
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(res, indent=2) + "\n")
    for mode in ("serial", "process_cold", "process_warm", "thread"):
        e = res[mode]
        print(
            f"{mode:<13} {e['seconds']:7.3f} s  {e['designs_per_s']:6.2f} designs/s  "
            f"x{e['speedup_vs_serial']:.2f}"
        )
    for name, e in opt.items():
        print(
            f"optimize {name:<10} {e['seconds']:6.2f} s  {e['trials_per_s']:6.2f} trials/s  "
            f"x{e['speedup_vs_1_worker']:.2f}  (trial phase {e['trial_phase_seconds']:.2f} s, "
            f"{e['trials_per_s_excluding_startup']:.2f} trials/s)"
        )
    print(f"bit-identical: {identical}; wrote {OUT}")
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
