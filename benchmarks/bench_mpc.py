"""Benchmark: MPPI plan time per control step, its real-time factor, and RMSE against N and horizon.

For each configuration the MPC (``spine_gym.controllers.MPPIController``) drives whole episodes of
``SmaSpine-v0`` (suite scenarios of ``agents.scenarios`` cut to ``--duration`` seconds); every
``predict`` call (the whole plan: estimator update, N rollouts, weighting) and every ``env.step``
is timed with ``time.perf_counter``. Reported per configuration:

* plan time per control step: median, 95th percentile and max [ms], as wall time and as the
  planning thread's CPU time (``time.thread_time``: what the plan costs a core of its own — on a
  machine shared by more runnable processes than cores the wall time also holds the time the
  process waited for a core; for the parallel kernel it misses the worker threads);
* **real-time factor** = control period (0.1 s) / plan time (median and p95): >= 1 means the
  plan is ready before the next control step;
* the peer measured in the same loop: plan time / ``env.step`` time (how many env steps one plan
  costs — a ratio that survives a busier machine better than the absolute times);
* RMSE [deg] and energy [J] over the episodes, and the same for the tuned PID as a reference.

Configurations: the defaults (``MPPIConfig()``) in both modes, the default with the parallel
``prange`` kernel instead of the serial one (numba threads on a shared machine), then the
estimated mode with N in ``--samples`` at the default horizon and with the horizon in
``--horizons`` at the default N, and both modes with the rollouts' sub-step criterion c
(``MPPIConfig.plan_step_c``) in ``--step-c`` (0.01 is the env's own criterion, the setting before
the default became 0.03: where every rollout crosses a phase transformation it needs ~3x the
sub-steps, and the 95th percentile of the plan time went over the control period).
The planar defaults run twice more with the rollouts on the frozen-rate scheme of MODEL.md §6.1
(``MPPIConfig(plan_scheme="frozen")``) instead of the env's coupled scheme (§6.5): the MPC plan
time before and after issue 11's faster physics, in the same run.

Every spatial env id (``--envs``: ``SmaSpine3D-v0``, ``SmaSpineChain-v0``) runs
:class:`~spine_gym.controllers.SpatialMPPIController` at its default settings
(``SpatialMPPIController.default_settings``) in both modes on two scenarios of its suite, against
its tuned PID, the default estimated mode with the parallel kernel, and the estimated mode with
N in ``--spatial-samples`` and the horizon in
``--spatial-horizons`` (their RMSE is the tip-bending error [deg] or the tip-position error [mm]).
Writes ``benchmarks/results/mpc_speed.json`` and ``benchmarks/results/mpc_speed.png``.

    .venv/bin/python benchmarks/bench_mpc.py [--duration 15] [--scenarios step_cross sine_fast_dist]
        [--samples 16 32 64] [--horizons 2 3 5] [--step-c 0.01 0.03 0.1]
        [--envs SmaSpine3D-v0 SmaSpineChain-v0] [--spatial-samples 12 32] [--spatial-horizons 2 4]

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

import numba
import numpy as np
from tqdm import tqdm

import spine_gym
from agents.common import CHAIN_ENV_ID, SPATIAL_ENV_ID
from agents.runtime import build_controller, make_env
from agents.scenarios import build_spatial_suite, build_suite
from spine_gym.controllers import MPPIConfig, MPPIController, SpatialMPPIController

OUT = Path(__file__).resolve().parent / "results"
SPATIAL_SCENARIOS = {SPATIAL_ENV_ID: ("step_diag", "circle_dist"), CHAIN_ENV_ID: ("steps", "circle_dist")}


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


def run(ctrl, env, scenarios, bar) -> dict:
    """Episodes of ``ctrl``; per-step plan and env-step times, RMSE and energy."""
    plan_t, plan_cpu, step_t, rmse, energy = [], [], [], [], []
    table = env.unwrapped.table
    error_key = [e.key for e in table.entries if e.source == "error"][0]
    for sc in scenarios:
        if hasattr(ctrl, "bind"):
            ctrl.bind(env)
        ctrl.reset()
        obs, _ = env.reset(seed=sc.seed, options=sc.reset_options())
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
    plan = np.array(plan_t)
    cpu = np.array(plan_cpu)
    step = np.array(step_t)
    period = float(env.control_period)
    return {
        "plan_ms_median": 1e3 * float(np.median(plan)),
        "plan_ms_p95": 1e3 * float(np.percentile(plan, 95)),
        "plan_ms_max": 1e3 * float(plan.max()),
        "plan_cpu_ms_median": 1e3 * float(np.median(cpu)),
        "plan_cpu_ms_p95": 1e3 * float(np.percentile(cpu, 95)),
        "plan_cpu_ms_max": 1e3 * float(cpu.max()),
        "realtime_factor_cpu_p95": period / float(np.percentile(cpu, 95)),
        "env_step_ms_median": 1e3 * float(np.median(step)),
        "plan_over_env_step": float(np.median(plan) / np.median(step)),
        "realtime_factor_median": period / float(np.median(plan)),
        "realtime_factor_p95": period / float(np.percentile(plan, 95)),
        "rmse_deg": float(np.mean(rmse)),
        "energy_J": float(np.mean(energy)),
        "rmse_per_scenario": rmse,
    }


def configurations(samples, horizons, step_cs) -> list[tuple[str, str, MPPIConfig]]:
    d = MPPIConfig()
    out = [
        ("default oracle", "oracle", d),
        ("default estimated", "estimated", d),
        ("default estimated, parallel kernel", "estimated", dataclasses.replace(d, parallel=not d.parallel)),
    ]
    out += [
        (f"estimated N={n}", "estimated", dataclasses.replace(d, n_samples=n))
        for n in samples
        if n != d.n_samples
    ]
    out += [
        (f"estimated H={h:g}s", "estimated", dataclasses.replace(d, horizon=h))
        for h in horizons
        if h != d.horizon
    ]
    out += [
        (f"{mode} c={c:g}", mode, dataclasses.replace(d, plan_step_c=c))
        for c in step_cs
        if c != d.plan_step_c
        for mode in ("oracle", "estimated")
    ]
    out += [
        (f"default {mode}, frozen scheme", mode, dataclasses.replace(d, plan_scheme="frozen"))
        for mode in ("oracle", "estimated")
    ]
    return out


def spatial_configurations(env, samples, horizons) -> list[tuple[str, str, MPPIConfig]]:
    """Both modes at the env's defaults, then the estimated mode over N and the horizon."""
    d = SpatialMPPIController.default_settings(env.unwrapped.config)
    out = [
        ("default oracle", "oracle", d),
        ("default estimated", "estimated", d),
        ("default estimated, parallel kernel", "estimated", dataclasses.replace(d, parallel=not d.parallel)),
    ]
    out += [
        (f"estimated N={n}", "estimated", dataclasses.replace(d, n_samples=n))
        for n in samples
        if n != d.n_samples
    ]
    out += [
        (f"estimated H={h:g}s", "estimated", dataclasses.replace(d, horizon=h))
        for h in horizons
        if h != d.horizon
    ]
    return out


def _line(name: str, r: dict) -> str:
    return (
        f"{name:<36s} plan {r['plan_ms_median']:6.1f} ms (p95 {r['plan_ms_p95']:6.1f}; CPU "
        f"{r['plan_cpu_ms_median']:5.1f} / p95 {r['plan_cpu_ms_p95']:5.1f}), RTF "
        f"{r['realtime_factor_median']:5.2f} (p95 {r['realtime_factor_p95']:5.2f}), plan/env-step "
        f"{r['plan_over_env_step']:6.0f}, RMSE {r['rmse_deg']:5.2f}, {r['energy_J']:5.0f} J"
    )


def sweep(env, suite, cfgs, make, bar) -> dict:
    """The PID and every configuration ``(name, mode, settings)`` of ``make(mode, settings)``."""
    out = {"scenarios": [s.name for s in suite], "pid": run(build_controller("pid", env), env, suite, bar)}
    out["configs"] = []
    for name, mode, settings in cfgs:
        r = run(make(mode, settings), env, suite, bar)
        out["configs"].append(
            {
                "name": name,
                "mode": mode,
                "parallel": settings.parallel,
                "settings": dataclasses.asdict(settings),
                **r,
            }
        )
        bar.write(_line(name, r))
    return out


def spatial_suite(env_id: str, duration: float) -> list:
    names = SPATIAL_SCENARIOS[env_id]
    profiles = sorted({n.removesuffix("_dist") for n in names})
    suite = build_spatial_suite(env_id, duration, profiles)
    return [s for s in suite if s.name in names]


def plot(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = MPPIConfig()
    rows = res["configs"]
    sweeps = (("n_samples", "rollouts N"), ("horizon", "horizon [s]"), ("plan_step_c", "rollout sub-step c"))
    fig, axes = plt.subplots(1, 5, figsize=(21, 4.2))
    for ax_i, (key, label) in enumerate(sweeps):
        sel = [
            r
            for r in rows
            if r["mode"] == "estimated"
            and r["parallel"] == d.parallel
            and r["settings"].get("plan_scheme") is None
            and all(r["settings"][k] == getattr(d, k) for k, _ in sweeps if k != key)
        ]
        sel.sort(key=lambda r: r["settings"][key])
        x = [r["settings"][key] for r in sel]
        ax = axes[ax_i]
        ax.plot(x, [r["rmse_deg"] for r in sel], "o-", label="MPC estimated")
        ax.axhline(res["pid"]["rmse_deg"], color="k", ls="--", lw=1, label="PID")
        ax.set_xlabel(label)
        ax.set_ylabel("RMSE [deg]")
        ax2 = ax.twinx()
        ax2.plot(x, [r.get("plan_cpu_ms_p95", np.nan) for r in sel], "s:", color="C3")
        ax2.set_ylabel("p95 plan CPU time [ms]", color="C3")
        if key == "plan_step_c":
            ax.set_xscale("log")
        ax.legend(fontsize=8)
    ax = axes[3]
    names = [r["name"] for r in rows]
    ax.barh(names, [r["realtime_factor_median"] for r in rows], color="C0", label="median")
    ax.barh(names, [r["realtime_factor_p95"] for r in rows], color="C1", alpha=0.7, label="p95")
    ax.scatter([r["realtime_factor_cpu_p95"] for r in rows], names, color="k", marker="|", s=80,
               label="p95 of CPU time (serial kernel)", zorder=3)  # fmt: skip
    ax.axvline(1.0, color="k", lw=1)
    ax.set_xlabel("real-time factor (0.1 s / plan time)")
    ax.tick_params(axis="y", labelsize=7)
    ax.legend(fontsize=7, loc="lower right")
    ax = axes[4]
    names, med, p95, cpu = [], [], [], []
    for env_id, sres in res.get("spatial", {}).items():
        for r in sres["configs"]:
            names.append(f"{env_id.removeprefix('SmaSpine').removesuffix('-v0')}: {r['name']}")
            med.append(r["realtime_factor_median"])
            p95.append(r["realtime_factor_p95"])
            cpu.append(r["realtime_factor_cpu_p95"])
    if names:
        ax.barh(names, med, color="C0", label="median")
        ax.barh(names, p95, color="C1", alpha=0.7, label="p95")
        ax.scatter(cpu, names, color="k", marker="|", s=80, label="p95 of CPU time", zorder=3)
        ax.axvline(1.0, color="k", lw=1)
        ax.set_xscale("log")
        ax.set_xlabel("real-time factor, spatial envs")
        ax.tick_params(axis="y", labelsize=7)
        ax.legend(fontsize=7, loc="lower right")
    la = res["machine"]["load_average_start"][0]
    cores = res["machine"]["cpu_count"]
    fig.suptitle(f"MPPI on SmaSpine-v0 and the spatial envs ({cores} cores, load average {la:.1f} at start)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--duration", type=float, default=15.0, help="episode length [s] (default: %(default)s)")
    p.add_argument("--scenarios", nargs="+", default=["step_cross", "sine_fast_dist"])
    p.add_argument("--samples", nargs="+", type=int, default=[16, 32, 64])
    p.add_argument("--horizons", nargs="+", type=float, default=[2.0, 3.0, 5.0])
    p.add_argument(
        "--step-c",
        nargs="+",
        type=float,
        default=[0.01, 0.03, 0.1],
        help="rollout sub-step criteria c to compare (0.01: the env's own)",
    )
    p.add_argument("--envs", nargs="*", default=[SPATIAL_ENV_ID, CHAIN_ENV_ID], help="spatial env ids")
    p.add_argument("--spatial-samples", nargs="*", type=int, default=[12, 32])
    p.add_argument("--spatial-horizons", nargs="*", type=float, default=[2.0, 4.0])
    p.add_argument("--out", default=str(OUT))
    args = p.parse_args(argv)
    names = sorted({n.removesuffix("_dist") for n in args.scenarios})
    suite = [
        s
        for s in build_suite(args.duration, names, groups=("nominal", "disturbed"))
        if s.name in args.scenarios
    ]
    env = make_env({"episode_duration": args.duration})
    info = machine()
    warm = MPPIController(env.config, "oracle", env=env, settings=MPPIConfig(n_samples=4, horizon=0.2))
    env.reset(seed=0)
    warm.predict(env.reset(seed=0)[0])  # compile / load the kernels outside the timing
    warm = MPPIController(
        env.config, "oracle", env=env, settings=MPPIConfig(n_samples=4, horizon=0.2, parallel=False)
    )
    warm.predict(env.reset(seed=0)[0])
    cfgs = configurations(args.samples, args.horizons, args.step_c)
    for env_id in args.envs:  # compile / load the spatial kernels outside the timing
        senv = make_env({"episode_duration": 1.0}, env_id=env_id)
        for par in (False, True):
            st = MPPIConfig(n_samples=10, horizon=0.2, parallel=par)
            SpatialMPPIController(senv, "oracle", settings=st).predict(senv.reset(seed=0)[0])
    steps = len(suite) * env.unwrapped.config.n_steps * (len(cfgs) + 1)
    spatial = {}
    for env_id in args.envs:
        senv = make_env({"episode_duration": args.duration}, env_id=env_id)
        scfgs = spatial_configurations(senv, args.spatial_samples, args.spatial_horizons)
        ssuite = spatial_suite(env_id, args.duration)
        spatial[env_id] = (senv, ssuite, scfgs)
        steps += len(ssuite) * senv.config.n_steps * (len(scfgs) + 1)
    res = {"machine": info, "duration_s": args.duration, "scenarios": [s.name for s in suite]}
    guard = env.temperature_limit - 5.0
    with tqdm(total=steps, desc="bench_mpc", unit="step") as bar:
        planar = sweep(
            env, suite, cfgs,
            lambda mode, st: MPPIController(env.config, mode, env=env, settings=st, temperature_limit=guard),
            bar,
        )  # fmt: skip
        res["pid"], res["configs"] = planar["pid"], planar["configs"]
        res["spatial"] = {}
        for env_id, (senv, ssuite, scfgs) in spatial.items():
            bar.write(f"--- {env_id}")

            def make(mode, st, senv=senv):
                return SpatialMPPIController(
                    senv, mode, settings=st, temperature_limit=senv.temperature_limit - 5.0
                )

            res["spatial"][env_id] = sweep(senv, ssuite, scfgs, make, bar)
    info["load_average_end"] = os.getloadavg()
    pid = res["pid"]
    print(f"PID reference: RMSE {pid['rmse_deg']:.2f} deg, {pid['energy_J']:.0f} J")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "mpc_speed.json").write_text(json.dumps(res, indent=2))
    plot(res, out / "mpc_speed.png")
    print(f"wrote {out / 'mpc_speed.json'} and {out / 'mpc_speed.png'}")
    return res


if __name__ == "__main__":
    main()
