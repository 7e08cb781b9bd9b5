"""Benchmark: wall time of a calibration fit, serial vs parallel candidate simulation.

The benchmark fit: 2 synthetic experiments × 60 s (sampled at 0.1 s; angle and both
wire temperatures measured, 0.5° / 1 K noise) made by a perturbed model (convection ×1.2, tube
modulus ×0.85, transformation temperatures +5 K), 4 fitted parameters (alpha, E_t, T_shift,
lam_A) from the MODEL.md §7 baseline, default fit settings (CMA-ES + 2 least-squares starts).
The same fit runs with ``n_workers=1`` (serial) and ``n_workers=K`` (a thread pool: the jitted
time loop is ``nogil``), alternating, best of ``--repeats``. Both must give bit-identical
parameters (checked). Also times one 60-s simulation, the unit of work, and records the process
CPU time of each fit: on a machine shared with other jobs, CPU/wall of the serial fit shows what
share of a core the process got (on an idle machine ≈ 1), and the serial CPU time / K is the
ideal parallel wall time. Writes
``benchmarks/results/calibrate_speed.json``.

    .venv/bin/python benchmarks/bench_calibrate.py [--workers 2] [--repeats 2]
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

import numba
import numpy as np

from spine_gym import ModelParams
from spine_gym.calibrate import fit, simulate_experiment, synthetic_experiment
from spine_gym.uncertainty import apply_offsets

OUT = Path(__file__).resolve().parent / "results" / "calibrate_speed.json"
PARAMETERS = ["alpha", "E_t", "T_shift", "lam_A"]


def experiments():
    base = ModelParams()
    truth = apply_offsets(
        base,
        [{"alpha": 1.0}, {"E_t": 1.0}, {"T_low": 1.0, "T_high": 1.0}],
        [0.2 * base.alpha, -0.15 * base.E_t, 5.0],
    )
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 60.0 + 1e-9, 0.1)
    chans = ("angle", "temperature_right", "temperature_left")
    return [
        synthetic_experiment(
            truth, t, np.where(t < 20, 3.2, 0.0), 0.0, channels=chans, rng=rng, name="hysteresis"
        ),
        synthetic_experiment(
            truth,
            t,
            np.where(t < 15, 3.2, 0.0),
            np.where((t >= 35) & (t < 50), 3.2, 0.0),
            channels=chans,
            rng=rng,
            name="alternate",
        ),
    ]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=2, help="best-of repeats per mode")
    args = ap.parse_args(argv)
    exps = experiments()
    base = ModelParams()
    simulate_experiment(base, exps[0])  # compile / load the cache
    t0 = time.perf_counter()
    for _ in range(5):
        simulate_experiment(base, exps[1])
    sim_s = (time.perf_counter() - t0) / 5
    times = {"serial": [], "parallel": []}
    cpu = {"serial": [], "parallel": []}
    results = {}
    for _ in range(args.repeats):
        for mode, k in (("serial", 1), ("parallel", args.workers)):
            t0, c0 = time.perf_counter(), time.process_time()
            res = fit(exps, PARAMETERS, base, seed=0, n_workers=k, progress=False)
            times[mode].append(time.perf_counter() - t0)
            cpu[mode].append(time.process_time() - c0)
            results[mode] = res
            print(
                f"{mode:9s} workers={k} {times[mode][-1]:6.1f} s wall, {cpu[mode][-1]:6.1f} s CPU, "
                f"{res.n_simulations} simulations",
                flush=True,
            )
    a, b = results["serial"], results["parallel"]
    identical = bool(np.array_equal(a.values, b.values) and np.array_equal(a.std_errors, b.std_errors))
    best = {m: min(v) for m, v in times.items()}
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    out = {
        "what": "fit wall time, 2 experiments x 60 s, 4 parameters (alpha, E_t, T_shift, lam_A), "
        "default settings",
        "workers": args.workers,
        "repeats": args.repeats,
        "serial_s": best["serial"],
        "parallel_s": best["parallel"],
        "speedup": best["serial"] / best["parallel"],
        "all_times_s": times,
        "cpu_s": cpu,
        "serial_cpu_over_wall": min(cpu["serial"]) / best["serial"],
        "n_simulations": a.n_simulations,
        "simulation_60s_ms": 1e3 * sim_s,
        "serial_ms_per_simulation": 1e3 * best["serial"] / a.n_simulations,
        "identical_results": identical,
        "fitted": {n: float(v) for n, v in zip(a.names, a.values, strict=True)},
        "std_errors": {n: float(v) for n, v in zip(a.names, a.std_errors, strict=True)},
        "machine": {
            "cpu_count": os.cpu_count(),
            "python": platform.python_version(),
            "numba": numba.__version__,
            "numpy": np.__version__,
            "loadavg": os.getloadavg(),
            "commit": commit,
        },
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(out, indent=2) + "\n")
    print(
        f"serial {best['serial']:.1f} s, {args.workers} workers {best['parallel']:.1f} s: speed-up "
        f"{out['speedup']:.2f}x ({a.n_simulations} simulations of 60 s; one takes {1e3 * sim_s:.0f} ms); "
        f"identical results: {identical}; serial CPU/wall {out['serial_cpu_over_wall']:.2f}; "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    print(f"wrote {OUT}")
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
