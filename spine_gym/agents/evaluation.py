"""Evaluation of controllers on the scenario suite of :mod:`spine_gym.agents.scenarios`: the library
behind ``spine-gym evaluate`` (:mod:`spine_gym.agents.evaluate`).

:func:`evaluate` runs every controller (anything with SB3's ``predict``) on every scenario in its
own env, reset with the scenario's seed, target profile and load schedule; :func:`summarize` takes
the mean per (controller, scenario group), :func:`relative_rows` the ratios to a reference
controller; :func:`format_tables` and :func:`format_relative` print them; :func:`write_csv`,
:func:`write_trajectories` and :func:`plot_controller` write them; :func:`shipped_policies` lists
the shipped policies of an env id.
"""

from __future__ import annotations

import csv
import json
import math
import shutil
import time
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from tqdm import tqdm

from spine_gym.csv_numbers import csv_row
from spine_gym.plotting import plot_episodes

from .metrics import METRIC_COLUMNS, Trajectory, episode_metrics
from .runtime import (
    ENVELOPE_COLUMNS,
    controller_cutoff,
    env_temperature_limit,
    envelope_of,
    make_env,
    run_episode,
)
from .scenarios import Scenario
from .zoo_config import CHAIN_ENV_ID, ENV_ID, POLICIES_DIR

__all__ = [
    "ERROR_UNIT",
    "evaluate",
    "summarize",
    "relative_rows",
    "format_relative",
    "format_tables",
    "write_csv",
    "write_trajectories",
    "plot_controller",
    "policy_env_id",
    "shipped_policies",
]

#: unit of the tracking error per env (the metric columns are named ``*_deg`` after the planar angle)
ERROR_UNIT = {CHAIN_ENV_ID: "mm"}


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
        ``(rows, trajectories)``: one metrics dict per (controller, scenario), with the envelope it
        ran in (:func:`~spine_gym.agents.runtime.envelope_of`: ``v_max_V``, ``cutoff_K``, ``guard``),
        and the trajectories keyed by (controller, scenario name).
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
            fields = {"controller": name, "group": sc.group, "scenario": sc.name, "kind": sc.kind}
            rows.append({**fields, **m, **envelope_of(env, controller_cutoff(ctrl))})
            trajs[(name, sc.name)] = traj
        for env in envs.values():
            env.close()
        if progress:
            print(
                f"  {name:<12s} {len(scenarios)} scenarios in {time.perf_counter() - t0:5.1f} s", flush=True
            )
    return rows, trajs


def summarize(rows: list[dict]) -> list[dict]:
    """Mean of each metric per (controller, group), in first-seen order (NaN-aware for settling),
    with the group's envelope columns (those of its first row)."""
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
        s.update((c, sel[0][c]) for c in ENVELOPE_COLUMNS if c in sel[0])
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
    envelope = "guard" in summary[0]  # the envelope each row ran in: the voltage ceiling and the cut-off
    heads += ["v_max [V]", "guard"] if envelope else []
    chunks = []
    for g in groups:
        sel = [s for s in summary if s["group"] == g]
        body = [
            [s["controller"]]
            + [("n/a" if math.isnan(s[c]) else f.format(s[c])) for c, (_, f) in METRIC_COLUMNS.items()]
            + ([f"{s['v_max_V']:g}", s["guard"]] if envelope else [])
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
            con = Console(record=True, width=shutil.get_terminal_size((120, 24)).columns, force_terminal=False)
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
    """Write dict rows (same keys) as CSV, floats to 12 significant digits (:mod:`spine_gym.csv_numbers`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(csv_row(r) for r in rows)


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


# --------------------------------------------------------------------------- shipped policies
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
