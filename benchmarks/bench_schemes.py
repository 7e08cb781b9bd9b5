"""Benchmark: the phase-step schemes under the MPC and the vector env, before/after in one run.

``SolverOptions(scheme="frozen")`` (the previous default, MODEL.md §6.1) against the default coupled
step (MODEL.md §6.5), interleaved in one process so that machine load hits both alike:

* **MPC plan time** — ``MPPIController`` (estimated mode, default ``MPPIConfig``) driving
  ``SmaSpine-v0`` through the suite scenarios ``step_cross`` and ``sine_fast`` cut to
  ``--duration`` seconds (bench_mpc's short configuration); the env and the planner's rollouts use
  the scheme under test. Median and 95th percentile of the ``predict`` times, the env step, RMSE.
* **Vector env per env step** — ``gym.make_vec("SmaSpine-v0", num_envs=N)`` (native, numba loop),
  ``--warm`` untimed control periods after ``reset(seed=0)`` (the wires warm up to the
  transformation), then ``--steps`` timed ones with fixed uniform random actions; best of
  ``--repeats``; wall time per env step [µs].

Writes ``benchmarks/results/schemes_speed.json``. On a shared machine the absolute times are upper
bounds; the before/after ratios are the result.

    .venv/bin/python benchmarks/bench_schemes.py [--duration 15] [--envs 16] [--repeats 3]
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

import spine_gym  # noqa: F401  (registers SmaSpine-v0)
from spine_gym.agents.runtime import make_env
from spine_gym.agents.scenarios import build_suite
from spine_gym import SolverOptions
from spine_gym.controllers import MPPIController

OUT = Path(__file__).resolve().parent / "results"
SCHEMES = {"frozen": SolverOptions(scheme="frozen"), "coupled": SolverOptions()}


def _mpc(duration: float) -> dict:
    suite = build_suite(duration, ["step_cross", "sine_fast"], groups=("nominal",))
    envs = {k: make_env({"solver": s}) for k, s in SCHEMES.items()}
    ctrls = {k: MPPIController(e.config, "estimated", env=e) for k, e in envs.items()}
    plan, step, rmse = ({k: [] for k in SCHEMES} for _ in range(3))
    for rep in range(2):  # the first pass compiles and warms up
        for sc in suite:
            for k in SCHEMES:
                env, ctrl = envs[k], ctrls[k]
                ctrl.bind(env)
                ctrl.reset()
                obs, _ = env.reset(seed=sc.seed, options=sc.reset_options())
                err = []
                while True:
                    t0 = time.perf_counter()
                    a, _ = ctrl.predict(obs)
                    t1 = time.perf_counter()
                    obs, _, te, tr, info = env.step(a)
                    t2 = time.perf_counter()
                    if rep:
                        plan[k].append(t1 - t0)
                        step[k].append(t2 - t1)
                    err.append(info["tracking_error_deg"])
                    if te or tr:
                        break
                if rep:
                    rmse[k].append(float(np.sqrt(np.mean(np.square(err)))))
    return {
        k: {
            "plan_ms_median": 1e3 * float(np.median(plan[k])),
            "plan_ms_p95": 1e3 * float(np.percentile(plan[k], 95)),
            "env_step_ms_median": 1e3 * float(np.median(step[k])),
            "rmse_deg": float(np.mean(rmse[k])),
        }
        for k in SCHEMES
    }


def _vector_env(n: int, warm: int, steps: int, repeats: int) -> dict:
    venvs = {k: gym.make_vec("SmaSpine-v0", num_envs=n, solver=s) for k, s in SCHEMES.items()}
    acts = np.random.default_rng(0).uniform(-1.0, 1.0, (warm + steps, n, 2))
    best = {k: np.inf for k in SCHEMES}
    for _ in range(repeats):
        for k, venv in venvs.items():
            venv.reset(seed=0)
            for j in range(warm):
                venv.step(acts[j])
            t0 = time.perf_counter()
            for j in range(warm, warm + steps):
                venv.step(acts[j])
            best[k] = min(best[k], (time.perf_counter() - t0) / (steps * n))
    return {k: {"us_per_env_step": 1e6 * best[k]} for k in SCHEMES}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=15.0, help="MPC episode length [s]")
    ap.add_argument("--envs", type=int, default=16, help="vector env size")
    ap.add_argument("--warm", type=int, default=50, help="untimed control periods (default 50 = 5 s)")
    ap.add_argument("--steps", type=int, default=50, help="timed control periods")
    ap.add_argument("--repeats", type=int, default=3, help="best-of repeats of the vector env")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    for name in ("duration", "envs", "warm", "steps", "repeats"):
        if getattr(args, name) <= 0:
            ap.error(f"--{name} must be > 0, got {getattr(args, name)}")
    load = [os.getloadavg()[0]]
    print("MPC plan times (frozen vs coupled, interleaved) ...", flush=True)
    mpc = _mpc(args.duration)
    print("vector env per env step ...", flush=True)
    venv = _vector_env(args.envs, args.warm, args.steps, args.repeats)
    load.append(os.getloadavg()[0])
    report = {
        "mpc": mpc,
        "mpc_plan_median_ratio_frozen_over_coupled": mpc["frozen"]["plan_ms_median"]
        / mpc["coupled"]["plan_ms_median"],
        "mpc_plan_p95_ratio_frozen_over_coupled": mpc["frozen"]["plan_ms_p95"]
        / mpc["coupled"]["plan_ms_p95"],
        "vector_env": venv,
        "vector_env_ratio_frozen_over_coupled": venv["frozen"]["us_per_env_step"]
        / venv["coupled"]["us_per_env_step"],
        "args": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
        "load_average_start_end": load,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "schemes_speed.json"
    path.write_text(json.dumps(report, indent=2))
    for k, m in mpc.items():
        print(
            f"MPC {k:8s}: plan median {m['plan_ms_median']:7.2f} ms, p95 {m['plan_ms_p95']:7.2f} ms, "
            f"env.step {m['env_step_ms_median']:.3f} ms, RMSE {m['rmse_deg']:.3f} deg"
        )
    print(
        f"MPC plan frozen/coupled: median {report['mpc_plan_median_ratio_frozen_over_coupled']:.2f}x, "
        f"p95 {report['mpc_plan_p95_ratio_frozen_over_coupled']:.2f}x"
    )
    for k, v in venv.items():
        print(f"vector env ({args.envs} envs) {k:8s}: {v['us_per_env_step']:8.1f} us per env step")
    print(f"vector env frozen/coupled: {report['vector_env_ratio_frozen_over_coupled']:.2f}x; wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
