"""Benchmark: MPPI plan time per control step, its real-time factor, and RMSE against N, horizon, knots.

For every env id (``--envs``: ``SmaSpine-v0``, ``SmaSpine3D-v0``, ``SmaSpineChain-v0``) the MPC of
the registry (``MPPIController`` planar, ``SpatialMPPIController`` spatial) drives **validation
episodes** — the env's own random targets, loads and plants at reset seeds
``spine_gym.agents.runtime.VALIDATION_SEED_BASE + i`` (never the evaluation suite, whose seeds start at
900 000) — and every ``predict`` call (the whole plan: estimator update, N rollouts, weighting)
and every ``env.step`` is timed with ``time.perf_counter``. Reported per configuration:

* plan time per control step: median, 95th percentile and max [ms], as wall time and as the
  planning thread's CPU time (``time.thread_time``: what the plan costs a core of its own — on a
  machine shared by more runnable processes than cores the wall time also holds the time the
  process waited for a core; for the parallel kernel it misses the worker threads);
* **real-time factor** = control period (0.1 s) / plan time (median and p95, wall and CPU):
  >= 1 means the plan is ready before the next control step;
* the peer measured in the same loop: plan time / ``env.step`` time (how many env steps one plan
  costs — a ratio that survives a busier machine better than the absolute times);
* RMSE (the env's tracking error: [deg] planar and 3-D, [mm] chain) and energy [J] over the
  episodes, and the same for the env's tuned PID as a reference.

Configurations per env id: the defaults in both modes (planar ``MPPIConfig()``, spatial
``SpatialMPPIController.default_settings``), the default estimated mode with the parallel
``prange`` kernel, then the estimated mode with N in ``--samples``, the horizon in ``--horizons``
and the knot spacing in ``--knots``, each varied alone about the default.
Writes ``benchmarks/results/mpc_speed.json`` and ``benchmarks/results/mpc_speed.png``.

    .venv/bin/python benchmarks/bench_mpc.py

The machine is shared: the load average at start and end is recorded, and the absolute times are
upper bounds of what a quiet machine gives.
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

import matplotlib
import numba
import numpy as np
from tqdm import tqdm

import spine_gym
from spine_gym.agents.runtime import VALIDATION_SEED_BASE, build_controller, env_id_of, make_env
from spine_gym.agents.zoo_config import CHAIN_ENV_ID, ENV_ID, SPATIAL_ENV_ID
from spine_gym.controllers import MPPIConfig, MPPIController, SpatialMPPIController
from spine_gym.controllers.mpc import min_samples
from spine_gym.controllers.mpc_spatial import drive_patterns

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after the backend choice

OUT = Path(__file__).resolve().parent / "results"
ENV_IDS = (ENV_ID, SPATIAL_ENV_ID, CHAIN_ENV_ID)
SWEEPS = (("n_samples", "rollouts N"), ("horizon", "horizon [s]"), ("knot_period", "knot spacing [s]"))
UNIT = {ENV_ID: "deg", SPATIAL_ENV_ID: "deg", CHAIN_ENV_ID: "mm"}


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
        "numba": numba.__version__,
        "spine_gym": spine_gym.__version__,
        "git_commit": commit,
    }


def default_settings(env) -> MPPIConfig:
    """The registry MPC's default settings for ``env``."""
    cfg = env.unwrapped.config
    return MPPIConfig() if env_id_of(env) == ENV_ID else SpatialMPPIController.default_settings(cfg)


def make_mpc(env, mode: str, settings: MPPIConfig):
    guard = env.temperature_limit - 5.0
    if env_id_of(env) == ENV_ID:
        return MPPIController(env.config, mode, env=env, settings=settings, temperature_limit=guard)
    return SpatialMPPIController(env, mode, settings=settings, temperature_limit=guard)


def smallest_n(env) -> int:
    """The smallest N the env's MPC accepts (the always-sampled patterns)."""
    if env_id_of(env) == ENV_ID:
        return min_samples(np.eye(2))
    return min_samples(drive_patterns(env.unwrapped.config.layout))


def _timing(prefix: str, seconds: np.ndarray, period: float) -> dict:
    """Median / p95 / max [ms] and the real-time factors (period / median, period / p95)."""
    med, p95 = float(np.median(seconds)), float(np.percentile(seconds, 95))
    return {
        f"{prefix}_ms_median": 1e3 * med,
        f"{prefix}_ms_p95": 1e3 * p95,
        f"{prefix}_ms_max": 1e3 * float(seconds.max()),
        f"{prefix}_rtf_median": period / med,
        f"{prefix}_rtf_p95": period / p95,
    }


def run(ctrl, env, seeds, bar) -> dict:
    """Episodes of ``ctrl`` at ``seeds``; per-step plan and env-step times, RMSE and energy."""
    plan_t, plan_cpu, step_t, rmse, energy = [], [], [], [], []
    table = env.unwrapped.table
    error_key = [e.key for e in table.entries if e.source == "error"][0]
    for seed in seeds:
        if hasattr(ctrl, "bind"):
            ctrl.bind(env)
        ctrl.reset()
        obs, _ = env.reset(seed=seed)
        err, e = [], 0.0
        while True:
            t0, c0 = time.perf_counter(), time.thread_time()
            a, _ = ctrl.predict(obs)
            t1, c1 = time.perf_counter(), time.thread_time()
            obs, _, te, tr, info = env.step(a)
            t2 = time.perf_counter()
            plan_t.append(t1 - t0)
            plan_cpu.append(c1 - c0)
            step_t.append(t2 - t1)
            err.append(np.linalg.norm(info[error_key]))
            e += info["energy_J"]
            bar.update(1)
            if te or tr:
                break
        rmse.append(float(np.sqrt(np.mean(np.square(err)))))
        energy.append(e)
    period = float(env.control_period)
    plan, step = np.array(plan_t), np.array(step_t)
    return {
        **_timing("plan", plan, period),
        **_timing("plan_cpu", np.array(plan_cpu), period),
        "env_step_ms_median": 1e3 * float(np.median(step)),
        "plan_over_env_step": float(np.median(plan) / np.median(step)),
        "rmse": float(np.mean(rmse)),
        "energy_J": float(np.mean(energy)),
        "rmse_per_episode": rmse,
    }


def configurations(d: MPPIConfig, grids: dict, n_min: int) -> list[tuple[str, str, MPPIConfig]]:
    """Both modes at the defaults ``d``, the parallel kernel, then each sweep of ``grids`` alone
    (N below ``n_min``, the env's smallest, is left out)."""
    out = [
        ("default oracle", "oracle", d),
        ("default estimated", "estimated", d),
        ("default estimated, parallel kernel", "estimated", dataclasses.replace(d, parallel=not d.parallel)),
    ]
    for key, _ in SWEEPS:
        out += [
            (f"estimated {key}={v:g}", "estimated", dataclasses.replace(d, **{key: v}))
            for v in grids[key]
            if v != getattr(d, key) and not (key == "n_samples" and v < n_min)
        ]
    return out


def _line(name: str, r: dict, unit: str) -> str:
    return (
        f"{name:<40s} plan {r['plan_ms_median']:6.1f} ms (p95 {r['plan_ms_p95']:6.1f}; CPU "
        f"{r['plan_cpu_ms_median']:5.1f} / p95 {r['plan_cpu_ms_p95']:5.1f}), RTF p95 wall "
        f"{r['plan_rtf_p95']:5.2f} / CPU {r['plan_cpu_rtf_p95']:5.2f}, plan/env-step "
        f"{r['plan_over_env_step']:6.0f}, RMSE {r['rmse']:5.2f} {unit}, {r['energy_J']:5.0f} J"
    )


def sweep(env, seeds, cfgs, bar) -> dict:
    """The PID and every configuration ``(name, mode, settings)`` on the episodes at ``seeds``."""
    unit = UNIT[env_id_of(env)]
    out = {"seeds": list(seeds), "unit": unit, "pid": run(build_controller("pid", env), env, seeds, bar)}
    bar.write(_line(f"{env_id_of(env)} PID", out["pid"], unit))
    out["configs"] = []
    for name, mode, settings in cfgs:
        r = run(make_mpc(env, mode, settings), env, seeds, bar)
        row = {"name": name, "mode": mode, "settings": dataclasses.asdict(settings), **r}
        out["configs"].append(row)
        bar.write(_line(name, r, unit))
    return out


def _sweep_rows(res: dict, key: str) -> list[dict]:
    """The estimated serial-kernel rows that differ from the default in ``key`` only (and the default)."""
    rows = [r for r in res["configs"] if r["mode"] == "estimated" and "parallel" not in r["name"]]
    d = rows[0]["settings"]  # the default estimated row comes first
    sel = [r for r in rows if all(r["settings"][k] == d[k] for k, _ in SWEEPS if k != key)]
    return sorted(sel, key=lambda r: r["settings"][key])


def plot(res: dict, path: Path) -> None:
    """Per env id: RMSE and p95 plan CPU time against N, horizon and knots; real-time factors."""
    envs = list(res["envs"])
    fig, axes = plt.subplots(len(envs), 4, figsize=(20, 3.9 * len(envs)), squeeze=False)
    for row, env_id in enumerate(envs):
        r_env = res["envs"][env_id]
        for col, (key, label) in enumerate(SWEEPS):
            sel = _sweep_rows(r_env, key)
            x = [r["settings"][key] for r in sel]
            ax = axes[row, col]
            ax.plot(x, [r["rmse"] for r in sel], "o-", label="MPC estimated")
            ax.axhline(r_env["pid"]["rmse"], color="k", ls="--", lw=1, label="PID")
            ax.set_xlabel(label)
            ax.set_ylabel(f"{env_id}\nRMSE [{r_env['unit']}]")
            ax2 = ax.twinx()
            ax2.plot(x, [r["plan_cpu_ms_p95"] for r in sel], "s:", color="C3")
            ax2.axhline(1e3 * 0.1, color="C3", lw=0.8, alpha=0.5)
            ax2.set_ylabel("p95 plan CPU [ms]", color="C3")
            ax.legend(fontsize=8)
        ax = axes[row, 3]
        names = [r["name"] for r in r_env["configs"]]
        ax.barh(names, [r["plan_rtf_median"] for r in r_env["configs"]], color="C0", label="median (wall)")
        ax.barh(names, [r["plan_rtf_p95"] for r in r_env["configs"]], color="C1", alpha=0.7, label="p95 (wall)")
        ax.scatter([r["plan_cpu_rtf_p95"] for r in r_env["configs"]], names, color="k", marker="|", s=80,
                   label="p95 of CPU time", zorder=3)  # fmt: skip
        ax.axvline(1.0, color="k", lw=1)
        ax.set_xscale("log")
        ax.set_xlabel("real-time factor (0.1 s / plan time)")
        ax.tick_params(axis="y", labelsize=7)
        ax.legend(fontsize=7, loc="lower right")
    m = res["machine"]
    fig.suptitle(
        f"MPPI plan time and RMSE on validation episodes ({m['cpu_count']} cores, load average "
        f"{m['load_average_start'][0]:.1f} at start, {m['load_average_end'][0]:.1f} at end)"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _warm_up(env) -> None:
    """Compile / load both kernels of ``env``'s MPC outside the timing."""
    for par in (False, True):
        st = dataclasses.replace(default_settings(env), n_samples=10, horizon=0.2, parallel=par)
        for mode in ("oracle", "estimated"):
            make_mpc(env, mode, st).predict(env.reset(seed=0)[0])


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--envs", nargs="+", default=list(ENV_IDS), choices=ENV_IDS)
    p.add_argument("--episodes", type=int, default=2, help="validation episodes per configuration")
    p.add_argument("--duration", type=float, default=20.0, help="episode length [s] (default: %(default)s)")
    p.add_argument("--samples", nargs="*", type=int, default=[8, 12, 16, 32])
    p.add_argument("--horizons", nargs="*", type=float, default=[2.0, 3.0, 4.0])
    p.add_argument("--knots", nargs="*", type=float, default=[0.5, 1.0, 1.5])
    p.add_argument("--out", default=str(OUT))
    args = p.parse_args(argv)
    grids = {"n_samples": args.samples, "horizon": args.horizons, "knot_period": args.knots}
    seeds = [VALIDATION_SEED_BASE + i for i in range(args.episodes)]
    res = {"machine": machine(), "duration_s": args.duration, "envs": {}}
    plan = {}
    for env_id in args.envs:
        env = make_env({"episode_duration": args.duration}, env_id=env_id)
        _warm_up(env)
        plan[env_id] = (env, configurations(default_settings(env), grids, smallest_n(env)))
    steps = sum(len(seeds) * env.config.n_steps * (len(c) + 1) for env, c in plan.values())
    with tqdm(total=steps, desc="bench_mpc", unit="step") as bar:
        for env_id, (env, cfgs) in plan.items():
            bar.write(f"--- {env_id}")
            res["envs"][env_id] = sweep(env, seeds, cfgs, bar)
    res["machine"]["load_average_end"] = os.getloadavg()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "mpc_speed.json").write_text(json.dumps(res, indent=2))
    plot(res, out / "mpc_speed.png")
    print(f"wrote {out / 'mpc_speed.json'} and {out / 'mpc_speed.png'}")
    return res


if __name__ == "__main__":
    main()
