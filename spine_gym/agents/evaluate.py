"""Evaluate baselines and saved policies on the fixed scenario suite of :mod:`spine_gym.agents.scenarios`.

Example (the README's main command; ``spine-gym evaluate`` is the same command)::

    python -m spine_gym.agents.evaluate            # shipped PPO/SAC policies + step, bang-bang, PID
    python -m spine_gym.agents.evaluate --env SmaSpine3D-v0      # the spatial spine's suite and policies

Every controller (anything with SB3's ``predict``) runs every scenario of the suite in its own
``SmaSpine-v0`` env, reset with the scenario's seed, target profile and load schedule. The CLI
prints one table per scenario group (mean over the group's scenarios) with tracking RMSE and max
error [deg], settling time [s] (step scenarios), electrical energy [J], peak wire temperature [K]
and time over the temperature limit [s], and writes to ``--out``:

* ``metrics.csv`` — one row per (controller, scenario); ``summary.csv`` — one row per
  (controller, group);
* ``trajectories/<controller>/<scenario>.csv`` — the step-by-step record;
* ``plots/<controller>_<group>.png`` — angle and target, voltages and temperatures vs time for
  each scenario of the group;
* with ``--video``: ``videos/<controller>/<scenario>.mp4`` — the episode as the env renders it
  (:mod:`spine_gym.agents.video`).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from spine_gym import cli_conventions as cli
from spine_gym.controllers.registry import BASELINES, REGISTRY, baselines_for, registry_for
from spine_gym.envs import base_id, config_of
from spine_gym.plotting import plot_episodes

from .metrics import METRIC_COLUMNS, Trajectory, episode_metrics
from .runtime import (
    build_controller,  # noqa: F401 - re-exported (the tests read ev.build_controller)
    controller_for,
    env_temperature_limit,
    evaluation_env_kwargs,  # noqa: F401 - re-exported (the tests read ev.evaluation_env_kwargs)
    load_policy,
    make_env,
    policy_env_kwargs,
    run_episode,
)
from .scenarios import SUITES, Scenario, get_suite
from .video import require_ffmpeg, write_videos
from .zoo_config import CHAIN_ENV_ID, ENV_ID, POLICIES_DIR

#: unit of the tracking error per env (the metric columns are named ``*_deg`` after the planar angle)
ERROR_UNIT = {CHAIN_ENV_ID: "mm"}

MPC_CONTROLLERS = tuple(name for name, spec in REGISTRY.items() if spec.plans_on_env)


def evaluate(
    controllers: dict[str, object],
    scenarios: Iterable[Scenario],
    env_kwargs: dict[str, dict] | None = None,
    *,
    progress: bool = False,
) -> tuple[list[dict], dict[tuple[str, str], Trajectory]]:
    """Run every controller on every scenario.

    Args:
        controllers: name -> object with SB3's ``predict``.
        scenarios: the suite.
        env_kwargs: per-controller env kwargs (e.g. a policy's training env kwargs); the
            scenario's ``episode_duration`` always wins.
        progress: a progress bar over the scenarios and one line per controller.

    Returns:
        ``(rows, trajectories)``: one metrics dict per (controller, scenario) and the
        trajectories keyed by (controller, scenario name).
    """
    scenarios = list(scenarios)
    rows, trajs = [], {}
    for name, ctrl in controllers.items():
        t0 = time.perf_counter()
        kw = dict((env_kwargs or {}).get(name, {}))
        envs: dict[tuple, object] = {}
        bar = tqdm(scenarios, desc=f"  {name}", unit="scenario", leave=False, disable=not progress)
        for sc in bar:
            key = (sc.env_id, sc.duration)
            if key not in envs:
                envs[key] = make_env({**kw, "episode_duration": sc.duration}, env_id=sc.env_id)
            env = envs[key]
            traj = run_episode(env, ctrl, sc)
            m = episode_metrics(
                traj, temperature_limit=env_temperature_limit(env), dt=float(env.control_period)
            )
            rows.append({"controller": name, "group": sc.group, "scenario": sc.name, "kind": sc.kind, **m})
            trajs[(name, sc.name)] = traj
        for env in envs.values():
            env.close()
        if progress:
            print(
                f"  {name:<12s} {len(scenarios)} scenarios in {time.perf_counter() - t0:5.1f} s", flush=True
            )
    return rows, trajs


def summarize(rows: list[dict]) -> list[dict]:
    """Mean of each metric per (controller, group), in first-seen order (NaN-aware for settling)."""
    keys = []
    for r in rows:
        k = (r["controller"], r["group"])
        if k not in keys:
            keys.append(k)
    out = []
    for ctrl, group in keys:
        sel = [r for r in rows if r["controller"] == ctrl and r["group"] == group]
        s = {"controller": ctrl, "group": group, "n_scenarios": len(sel)}
        for col in METRIC_COLUMNS:
            vals = np.array([r[col] for r in sel], dtype=float)
            s[col] = float(np.nanmean(vals)) if np.any(np.isfinite(vals)) else float("nan")
        out.append(s)
    return out


def relative_rows(summary: list[dict], reference: str) -> list[dict]:
    """Per (controller, group): RMSE and energy as ratios to ``reference``'s in the same group, and
    the time over the temperature limit minus the reference's [s] (a ratio of zeros is undefined)."""
    ref = {s["group"]: s for s in summary if s["controller"] == reference}
    if not ref:
        raise ValueError(f"reference controller {reference!r} is not in the summary")
    out = []
    for s in summary:
        r = ref.get(s["group"])
        if r is None:
            continue
        out.append(
            {
                "controller": s["controller"],
                "group": s["group"],
                "rmse_ratio": s["rmse_deg"] / r["rmse_deg"],
                "energy_ratio": s["energy_J"] / r["energy_J"],
                "over_limit_diff_s": s["time_over_limit_s"] - r["time_over_limit_s"],
            }
        )
    return out


def format_relative(rel: list[dict], reference: str) -> str:
    """Plain-text table of :func:`relative_rows`, one block per group."""
    lines = []
    for g in dict.fromkeys(r["group"] for r in rel):
        lines.append(f"relative to {reference}, group {g}: RMSE ratio, energy ratio, T>limit difference [s]")
        for r in (r for r in rel if r["group"] == g):
            lines.append(
                f"  {r['controller']:<14s} {r['rmse_ratio']:6.2f}  {r['energy_ratio']:6.2f}  "
                f"{r['over_limit_diff_s']:+6.1f}"
            )
    return "\n".join(lines) + "\n"


def format_tables(summary: list[dict], use_rich: bool = True, error_unit: str = "deg") -> str:
    """One table per scenario group (rows: controllers), as text; ``error_unit`` labels the
    tracking-error columns (``mm`` for the chain's tip position)."""
    groups = list(dict.fromkeys(s["group"] for s in summary))
    heads = ["controller"] + [h.replace("[deg]", f"[{error_unit}]") for h, _ in METRIC_COLUMNS.values()]
    chunks = []
    for g in groups:
        sel = [s for s in summary if s["group"] == g]
        body = [
            [s["controller"]]
            + [("n/a" if math.isnan(s[c]) else f.format(s[c])) for c, (_, f) in METRIC_COLUMNS.items()]
            for s in sel
        ]
        title = f"scenario group: {g} ({sel[0]['n_scenarios']} scenarios, mean per scenario)"
        if use_rich:
            from rich.console import Console
            from rich.markup import escape
            from rich.table import Table

            t = Table(title=title)
            for i, h in enumerate(heads):
                t.add_column(escape(h), justify="left" if i == 0 else "right", no_wrap=True)
            for row in body:
                t.add_row(*(escape(c) for c in row))
            con = Console(record=True, width=120, force_terminal=False)
            with con.capture() as cap:
                con.print(t)
            chunks.append(cap.get())
        else:
            w = [max(len(h), *(len(r[i]) for r in body)) for i, h in enumerate(heads)]
            lines = [
                title,
                "  ".join(h.ljust(w[i]) if i == 0 else h.rjust(w[i]) for i, h in enumerate(heads)),
            ]
            lines += [
                "  ".join(c.ljust(w[i]) if i == 0 else c.rjust(w[i]) for i, c in enumerate(r)) for r in body
            ]
            chunks.append("\n".join(lines) + "\n")
    return "\n".join(chunks)


# --------------------------------------------------------------------------- output
def write_csv(path: Path, rows: list[dict]) -> None:
    """Write dict rows (same keys) as CSV."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def write_trajectories(out: Path, trajs: dict[tuple[str, str], Trajectory]) -> None:
    """One CSV per (controller, scenario) under ``out/trajectories``."""
    for (ctrl, sc), tr in trajs.items():
        cols = tr.to_columns()
        rows = [dict(zip(cols, vals, strict=True)) for vals in zip(*cols.values(), strict=True)]
        write_csv(out / "trajectories" / ctrl / f"{sc}.csv", rows)


def plot_controller(
    path: Path, controller: str, group: str, scenarios: list[Scenario], trajs, temperature_limit: float
) -> None:
    """Angle/target, voltages and temperatures vs time for each scenario of a group (one PNG), with
    the scenario's tip pushes and payload shaded and the temperature limit labelled."""
    episodes = [
        (sc.name, trajs[(controller, sc.name)], sc.reset_options()["loads"]) for sc in scenarios
    ]
    plot_episodes(episodes, path, temperature_limit=temperature_limit, title=f"{controller} — {group}")


# --------------------------------------------------------------------------- CLI
EXAMPLES = """
spine-gym evaluate                                   # shipped policies + step, bang-bang, PID
spine-gym evaluate --env SmaSpine3D-v0 -o results/eval_3d
spine-gym evaluate --suite quick --baselines pid --models mine=logs/ppo/SmaSpine-v0_1
spine-gym evaluate --baselines pid --models --env-kwargs sensor_delay=1 --no-progress
"""


def build_parser(prog: str = "python -m spine_gym.agents.evaluate") -> argparse.ArgumentParser:
    p = cli.Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES)
    cli.add_env(p, default=ENV_ID)
    cli.add_env_kwargs(
        p, help="env keyword arguments key=value of every controller's envs (over a policy's own)"
    )
    p.add_argument(
        "--baselines",
        nargs="*",
        default=None,
        help=f"registered controllers to run (default for {ENV_ID}: {' '.join(BASELINES)}; "
        f"all: {' '.join(REGISTRY)}; other envs: their registry)",
    )
    p.add_argument(
        "--mpc",
        action="store_true",
        help=f"also run {' and '.join(MPC_CONTROLLERS)} (MPPI, on every env id: ~0.1 s per step, "
        "~15-30 min per mode on a full suite)",
    )
    p.add_argument(
        "--models",
        nargs="*",
        default=None,
        metavar="NAME=PATH",
        help="saved models (run folder, shipped folder or .zip); default: every policy in spine_gym/agents/policies/ "
        "trained on --env",
    )
    p.add_argument(
        "--suite", default="full", choices=sorted(SUITES), help="scenario suite (default: %(default)s)"
    )
    p.add_argument("--groups", nargs="*", default=None, help="only these scenario groups")
    p.add_argument("--scenarios", nargs="*", default=None, help="only these scenario names")
    cli.add_out(p, default="results/eval")
    cli.add_progress(p)
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--no-trajectories", action="store_true", help="skip the per-step CSVs")
    p.add_argument("--plain", action="store_true", help="plain-text tables (no rich)")
    p.add_argument(
        "--relative-to",
        default=None,
        metavar="NAME",
        help="also print RMSE/energy ratios and T>limit differences to this controller (e.g. mpc_estimated)",
    )
    p.add_argument("--video", action="store_true", help="also write videos/<controller>/<scenario>.mp4")
    p.add_argument("--video-speed", type=float, default=1.0, help="video playback speed (default: real time)")
    return p


def policy_env_id(folder: Path) -> str:
    """The env id a policy folder was trained on (its ``meta.json``; ``SmaSpine-v0`` without one)."""
    meta = folder / "meta.json"
    return json.loads(meta.read_text()).get("env_id", ENV_ID) if meta.exists() else ENV_ID


def shipped_policies(env_id: str = ENV_ID) -> dict[str, Path]:
    """Shipped policy folders ``spine_gym/agents/policies/<name>/`` that hold a ``model.zip`` trained on ``env_id``."""
    return {
        p.name: p
        for p in sorted(POLICIES_DIR.glob("*"))
        if (p / "model.zip").exists() and policy_env_id(p) == env_id
    }


def _models(items: list[str] | None, env_id: str) -> dict[str, Path]:
    """``--models`` as {name: path} (None: the shipped policies of ``env_id``); ValueError if a path
    does not exist."""
    if items is None:
        return shipped_policies(env_id)
    models = {}
    for item in items:
        name, sep, path = item.partition("=")
        if not sep:
            name, path = Path(item).stem if Path(item).suffix else Path(item).name, item
        cli.check_file(path, f"--models {name}")
        models[name] = Path(path)
    return models


def _plan(args) -> tuple[list[Scenario], list[str], dict[str, Path]]:
    """(scenarios, baselines, models) of the arguments, every one checked (ValueError, one line)
    before anything is built or written."""
    scenarios = get_suite(args.suite, groups=args.groups, names=args.scenarios, env_id=args.env)
    chosen = list(baselines_for(args.env)) if args.baselines is None else args.baselines
    baselines = list(dict.fromkeys(chosen + (list(MPC_CONTROLLERS) if args.mpc else [])))
    cli.check_keys(baselines, registry_for(args.env), "--baselines", what=f"controller of {args.env}")
    models = _models(args.models, args.env)
    if not baselines and not models:
        raise ValueError("nothing to evaluate: no baselines and no models")
    names = [*baselines, *models]
    if args.relative_to and args.relative_to not in names:
        hint = cli.did_you_mean(args.relative_to, names)
        raise ValueError(f"--relative-to {args.relative_to!r} is not one of {names}{hint}")
    cli.check_env_kwargs(args.env, args.env_kwargs)
    if args.video:
        require_ffmpeg()  # before the evaluation, not after it
    return scenarios, baselines, models


def _controllers(args, baselines: list[str], models: dict[str, Path]) -> tuple[dict, dict, float]:
    """(controllers, their env kwargs, the env's temperature limit [K])."""
    controllers: dict[str, object] = {}
    env_kwargs: dict[str, dict] = {}
    limit = config_of(args.env, **args.env_kwargs).temperature_limit
    for b in baselines:
        controllers[b] = controller_for(b, args.env, args.env_kwargs)
        env_kwargs[b] = dict(args.env_kwargs)
    if models:
        torch.set_num_threads(1)
    for name, path in models.items():
        pol = load_policy(path, name=name)
        controllers[name] = pol
        env_kwargs[name] = policy_env_kwargs(pol.env_kwargs, args.env_kwargs)
    return controllers, env_kwargs, limit


def main(argv: list[str] | None = None, prog: str = "python -m spine_gym.agents.evaluate") -> list[dict]:
    """Run the CLI; returns the summary rows. Usage errors exit with status 2 before any work."""
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    t_start = time.perf_counter()
    try:
        scenarios, baselines, models = _plan(args)
    except (ValueError, RuntimeError) as e:
        parser.error(str(e))
    controllers, env_kwargs, limit = _controllers(args, baselines, models)
    print(f"evaluating {list(controllers)} on suite '{args.suite}' ({len(scenarios)} scenarios)", flush=True)
    rows, trajs = evaluate(controllers, scenarios, env_kwargs, progress=args.progress)
    summary = summarize(rows)
    print()
    unit = ERROR_UNIT.get(base_id(args.env), "deg")
    print(format_tables(summary, use_rich=not args.plain, error_unit=unit))
    out = Path(args.out)
    if args.relative_to:
        rel = relative_rows(summary, args.relative_to)
        print(format_relative(rel, args.relative_to))
        write_csv(out / "relative.csv", rel)
    write_csv(out / "metrics.csv", rows)
    write_csv(out / "summary.csv", summary)
    if not args.no_trajectories:
        write_trajectories(out, trajs)
    if not args.no_plots:
        groups = list(dict.fromkeys(s.group for s in scenarios))
        for ctrl in controllers:
            for g in groups:
                scs = [s for s in scenarios if s.group == g]
                plot_controller(out / "plots" / f"{ctrl}_{g}.png", ctrl, g, scs, trajs, limit)
    if args.video:
        videos = write_videos(
            controllers, scenarios, out / "videos", env_kwargs,
            make_env=lambda kw: make_env(kw, env_id=args.env), run_episode=run_episode,
            speed=args.video_speed,
        )  # fmt: skip
        print(f"wrote {len(videos)} videos to {out / 'videos'}")
    wrote = "metrics.csv, summary.csv" + ("" if args.no_plots else ", plots/")
    print(f"wrote {wrote} to {out} in {time.perf_counter() - t_start:.1f} s total")
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
