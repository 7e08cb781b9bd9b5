"""Benchmark: the long-horizon MPC's plan time per control period, and its tracking against the PID.

``mpc_long`` (:class:`spine_gym.controllers.LongHorizonMPC`: move-blocked MPPI over the wires'
thermal time scale, from the observation) drives the **validation episodes** of each env id
(``--envs``, default ``SmaSpineEasy-v2 SmaSpineHard-v2``: the env's own random targets, loads and
plants at reset seeds ``spine_gym.agents.runtime.VALIDATION_SEED_BASE + i``, never the evaluation
suite's), on one thread. Every ``predict`` call — the whole plan of one control period: estimator
update, rollouts, weighting — is timed as wall time (``time.perf_counter``) and as the planning
thread's CPU time (``time.thread_time``, what the plan costs a core of its own; on a shared
machine the wall time also holds the time the process waited for a core). Reported per env id and
controller: plan time median, 95th percentile and max [ms], wall and CPU, and whether the p95 is
below the control period (0.1 s: real time); RMSE [deg], energy [J] and time over the temperature
limit [s] per episode and their means. The registry's tuned ``pid`` (and, with
``--controllers``, any other registry entry, e.g. ``mpc_estimated``, the 3-s MPPI) runs the same
episodes in the same envelope (the ``-v2`` plant's cut-off, no controller guard).

    OMP_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_mpc_plan_time.py --episodes 5

``--horizon``, ``--block``, ``--w-energy``, ``--n-samples`` change ``mpc_long``'s settings
(:class:`spine_gym.controllers.LongMPCConfig`). Writes ``benchmarks/results/mpc_plan_time.json``
(``--out``). The load average at start and end is recorded.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import subprocess
import time
from pathlib import Path

import numba
import numpy as np

import spine_gym
from spine_gym.agents.metrics import episode_metrics
from spine_gym.agents.runtime import (
    VALIDATION_SEED_BASE,
    build_controller,
    env_temperature_limit,
    make_env,
    run_episode,
)
from spine_gym.controllers import LongHorizonMPC, LongMPCConfig

OUT = Path(__file__).resolve().parent / "results" / "mpc_plan_time.json"
ENVS = ("SmaSpineEasy-v2", "SmaSpineHard-v2")


class Timed:
    """A policy whose ``predict`` calls are timed (wall and thread CPU seconds)."""

    def __init__(self, policy):
        self.policy, self.wall, self.cpu = policy, [], []

    def bind(self, env) -> None:
        if hasattr(self.policy, "bind"):
            self.policy.bind(env)

    def reset(self) -> None:
        if hasattr(self.policy, "reset"):
            self.policy.reset()

    def predict(self, *args, **kwargs):
        t0, c0 = time.perf_counter(), time.thread_time()
        out = self.policy.predict(*args, **kwargs)
        self.wall.append(time.perf_counter() - t0)
        self.cpu.append(time.thread_time() - c0)
        return out


def machine() -> dict:
    try:
        git = ["git", "rev-parse", "--short", "HEAD"]
        commit = subprocess.run(git, capture_output=True, text=True).stdout
    except OSError:
        commit = "unknown"
    return {
        "cpu_count": os.cpu_count(),
        "numba_threads": numba.config.NUMBA_NUM_THREADS,
        "omp_threads": os.environ.get("OMP_NUM_THREADS"),
        "load_average_start": os.getloadavg(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numba": numba.__version__,
        "spine_gym": spine_gym.__version__,
        "git_commit": commit.strip(),
    }


def timing(seconds: list[float], period: float) -> dict:
    """Median, p95 and max [ms] of the plan times and whether the p95 is below ``period``."""
    ms = 1e3 * np.asarray(seconds)
    p95 = float(np.percentile(ms, 95))
    return {
        "median_ms": float(np.median(ms)),
        "p95_ms": p95,
        "max_ms": float(ms.max()),
        "real_time_p95": bool(p95 < 1e3 * period),
    }


def run(name: str, ctrl, env, n_episodes: int) -> dict:
    """Plan times and episode metrics of ``ctrl`` over the validation episodes of ``env``."""
    timed = Timed(ctrl)
    limit, period = env_temperature_limit(env), float(env.control_period)
    rows = []
    for i in range(n_episodes):
        traj = run_episode(env, timed, seed=VALIDATION_SEED_BASE + i)
        rows.append(episode_metrics(traj, temperature_limit=limit, dt=period))
        r = rows[-1]
        print(f"  {name:24s} seed {VALIDATION_SEED_BASE + i}: RMSE {r['rmse_deg']:.2f} deg, "
              f"{r['energy_J']:.1f} J, T>limit {r['time_over_limit_s']:.1f} s", flush=True)  # fmt: skip
    keys = ("rmse_deg", "energy_J", "time_over_limit_s", "peak_temperature_K")
    return {
        "plan_wall": timing(timed.wall, period),
        "plan_cpu": timing(timed.cpu, period),
        "plans": len(timed.wall),
        **{f"{k}_mean": float(np.mean([r[k] for r in rows])) for k in keys},
        "episodes": rows,
        "settings": ctrl.config() if hasattr(ctrl, "config") else {},
    }


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", nargs="+", default=list(ENVS))
    ap.add_argument("--episodes", type=int, default=5, help="validation episodes per env (default 5)")
    ap.add_argument("--controllers", nargs="*", default=["pid"], help="registry peers (default: pid)")
    d = LongMPCConfig()
    ap.add_argument("--horizon", type=float, default=d.horizon, help="[s] (default %(default)s)")
    ap.add_argument("--block", type=float, default=d.block, help="[s] (default %(default)s)")
    ap.add_argument("--w-energy", type=float, default=d.w_energy, help="[1/J] (default %(default)s)")
    ap.add_argument("--n-samples", type=int, default=d.n_samples, help="(default %(default)s)")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    settings = dataclasses.replace(
        d, horizon=args.horizon, block=args.block, w_energy=args.w_energy, n_samples=args.n_samples
    )
    result = {"machine": machine(), "settings": dataclasses.asdict(settings), "envs": {}}
    t0 = time.perf_counter()
    for env_id in args.envs:
        env = make_env(env_id=env_id)
        print(env_id, flush=True)
        ctrl = LongHorizonMPC(env.config, env=env, settings=settings)
        run("warm-up (compile)", ctrl, make_env({"episode_duration": 1.0}, env_id=env_id), 1)
        rows = {"mpc_long": run("mpc_long", ctrl, env, args.episodes)}
        for name in args.controllers:
            rows[name] = run(name, build_controller(name, env), env, args.episodes)
        result["envs"][env_id] = {"seeds": [VALIDATION_SEED_BASE + i for i in range(args.episodes)], **rows}
        env.close()
    result["duration_s"] = time.perf_counter() - t0
    result["machine"]["load_average_end"] = os.getloadavg()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2, default=str) + "\n")
    for env_id, rows in result["envs"].items():
        for name, r in rows.items():
            if name == "seeds":
                continue
            w, c = r["plan_wall"], r["plan_cpu"]
            print(f"{env_id:18s} {name:16s} RMSE {r['rmse_deg_mean']:6.2f} deg  "
                  f"E {r['energy_J_mean']:6.1f} J  "
                  f"T>lim {r['time_over_limit_s_mean']:5.1f} s  plan wall p50/p95/max {w['median_ms']:.1f}/"
                  f"{w['p95_ms']:.1f}/{w['max_ms']:.1f} ms  cpu {c['median_ms']:.1f}/{c['p95_ms']:.1f}/"
                  f"{c['max_ms']:.1f} ms")  # fmt: skip
    print(f"wrote {args.out}")
    return result


if __name__ == "__main__":
    main()
