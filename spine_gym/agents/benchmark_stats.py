"""Statistics, tables and plots of :mod:`spine_gym.agents.benchmark` (no training here).

* :func:`iqm_interval` — the interquartile mean (IQM) over seeds of one score and its 95 %
  stratified bootstrap confidence interval, both from ``rliable``
  (:func:`rliable.metrics.aggregate_iqm`, :func:`rliable.library.get_interval_estimates`);
  :func:`curve_intervals` — the same at every evaluation of a learning curve.
* :func:`time_to_level` — the first evaluation of a run at or below a reference level.
* :func:`summary_rows`, :func:`training_markdown`, :func:`plot_table`, :func:`plot_curves` — the
  final table (per algorithm x env id, plus the reference controllers) as CSV rows, the training
  cost as Markdown, the table as PNG, and the learning curves per env id. The table's Markdown,
  the constrained ranking first, is :mod:`spine_gym.agents.benchmark_ranking`.

rliable draws its bootstrap indices from NumPy's global generator; :func:`_estimates` seeds it for
the call (so a table is reproducible) and restores the caller's state afterwards.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from matplotlib.figure import Figure  # figures without pyplot: no global backend switch
from rliable import library as rly
from rliable import metrics as rly_metrics

from .metrics import TIME_OVER_LIMIT_CAP_S

CONFIDENCE = 0.95  # size of the confidence intervals
BOOTSTRAP_REPS = 2000  # bootstrap resamples per interval (rliable's own default is 50 000)
DASH = "—"  # a run that never reached the reference level

# the per-evaluation metrics of a run (validation means), their table headers with the unit slot
METRICS = {
    "rmse": "RMSE [{unit}]",
    "energy_J": "energy [J]",
    "time_over_limit_s": "T>limit [s]",
}


def _estimates(scores: np.ndarray, func: Callable, reps: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """rliable's point estimate and percentile-bootstrap interval of ``func`` on ``scores``
    (runs on axis 0), with NumPy's global generator seeded ``seed`` for the call."""
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        point, interval = rly.get_interval_estimates(
            {"x": scores}, func, reps=reps, confidence_interval_size=CONFIDENCE
        )
    finally:
        np.random.set_state(state)
    return np.asarray(point["x"]), np.asarray(interval["x"])


def _iqm_of_column(scores: np.ndarray) -> np.ndarray:
    return np.array([rly_metrics.aggregate_iqm(scores)])


def iqm_interval(
    scores: Sequence[float], reps: int = BOOTSTRAP_REPS, seed: int = 0
) -> tuple[float, float, float]:
    """``(IQM, CI low, CI high)`` of one score per run (e.g. the final validation RMSE of each seed).

    Raises:
        ValueError: no scores, or a score that is not finite.
    """
    x = np.asarray(scores, dtype=np.float64).reshape(-1)
    if x.size == 0 or not np.all(np.isfinite(x)):
        raise ValueError(f"scores must be a non-empty list of finite numbers, got {x.tolist()}")
    point, interval = _estimates(x.reshape(-1, 1), _iqm_of_column, reps, seed)
    return float(point[0]), float(interval[0, 0]), float(interval[1, 0])


def curve_intervals(
    curves: np.ndarray, reps: int = BOOTSTRAP_REPS, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """IQM over runs and its CI at each evaluation of ``curves`` (n_runs, n_evaluations): rliable's
    sample-efficiency curve (runs resampled as a whole, so the band is over seeds)."""
    c = np.asarray(curves, dtype=np.float64)
    if c.ndim != 2 or c.size == 0 or not np.all(np.isfinite(c)):
        raise ValueError(f"curves must be a finite (n_runs, n_evaluations) array, got shape {c.shape}")
    scores = c[:, None, :]  # (runs, one task, evaluations)

    def per_evaluation(s: np.ndarray) -> np.ndarray:
        return np.array([rly_metrics.aggregate_iqm(s[..., k]) for k in range(s.shape[-1])])

    point, interval = _estimates(scores, per_evaluation, reps, seed)
    return point, interval[0], interval[1]


def time_to_level(
    steps: Sequence[float], wall_s: Sequence[float], values: Sequence[float], level: float
) -> tuple[int | None, float | None]:
    """``(env steps, training wall time [s])`` of the first evaluation whose value is at or below
    ``level``; ``(None, None)`` if none is."""
    for s, w, v in zip(steps, wall_s, values, strict=True):
        if v <= level:
            return int(s), float(w)
    return None, None


# --------------------------------------------------------------------------- tables
def _metric_cells(scores: list, reps: int) -> tuple:
    """``(IQM, CI low, CI high)`` of a metric over seeds; all None if a seed lacks it (e.g. records
    written before the metric was recorded) or it is not finite."""
    if any(x is None or not math.isfinite(x) for x in scores):
        return None, None, None
    return iqm_interval(scores, reps=reps)


def summary_rows(
    runs: list[dict], references: dict[str, dict[str, dict]], reps: int = BOOTSTRAP_REPS
) -> list[dict]:
    """One row per (env id, algorithm) with the IQM and CI over seeds of each final metric and the
    mean wall/CPU time, then one row per reference controller of the env id (its validation means).
    A metric that some seed (or a reference) did not record gets None cells, not a number.

    Args:
        runs: per-run records (``env_id``, ``algo``, ``seed``, ``steps``, ``wall_s``, ``cpu_s``,
            ``steps_to_pid``, ``final_<metric>`` for each of :data:`METRICS`).
        references: ``{env_id: {controller: {<metric>: mean, "n_episodes": n}}}``.
        reps: bootstrap resamples.
    """
    out = []
    env_ids = list(dict.fromkeys([r["env_id"] for r in runs] + list(references)))
    for env_id in env_ids:
        sel = [r for r in runs if r["env_id"] == env_id]
        for algo in dict.fromkeys(r["algo"] for r in sel):
            group = [r for r in sel if r["algo"] == algo]
            row = {"env_id": env_id, "method": algo, "kind": "rl", "n_seeds": len(group)}
            row["steps"] = int(np.median([r["steps"] for r in group]))
            for m in METRICS:
                iqm, lo, hi = _metric_cells([r.get(f"final_{m}") for r in group], reps)
                row |= {f"{m}_iqm": iqm, f"{m}_ci_low": lo, f"{m}_ci_high": hi}
            row["wall_s_mean"] = float(np.mean([r["wall_s"] for r in group]))
            row["cpu_s_mean"] = float(np.mean([r["cpu_s"] for r in group]))
            row["reached_pid"] = sum(r["steps_to_pid"] is not None for r in group)
            row["n_episodes"] = None
            out.append(row)
        for name, ref in references.get(env_id, {}).items():
            row = {"env_id": env_id, "method": name, "kind": "reference", "n_seeds": None, "steps": None}
            for m in METRICS:
                row |= {f"{m}_iqm": ref.get(m), f"{m}_ci_low": None, f"{m}_ci_high": None}
            row |= {"wall_s_mean": None, "cpu_s_mean": None, "reached_pid": None}
            row["n_episodes"] = ref["n_episodes"]
            out.append(row)
    return out


def duration(seconds: float | None) -> str:
    """A duration for the table: seconds under 2 min, minutes under 2 h, hours above."""
    if seconds is None:
        return DASH
    if seconds < 120:
        return f"{seconds:.0f} s"
    return f"{seconds / 60:.1f} min" if seconds < 7200 else f"{seconds / 3600:.1f} h"


def fmt(x, spec: str = "{:.2f}") -> str:
    return DASH if x is None or (isinstance(x, float) and math.isnan(x)) else spec.format(x)


def interval_cell(row: dict, m: str, spec: str) -> str:
    """``IQM [CI low, CI high]`` of metric ``m`` of a summary row (the value alone without a CI)."""
    if row[f"{m}_ci_low"] is None:
        return fmt(row[f"{m}_iqm"], spec)
    return (
        f"{fmt(row[f'{m}_iqm'], spec)} [{fmt(row[f'{m}_ci_low'], spec)}, {fmt(row[f'{m}_ci_high'], spec)}]"
    )


def md_table(head: list[str], body: list[list[str]]) -> list[str]:
    """The lines of a Markdown table (first column left-aligned, the others right-aligned)."""
    lines = [
        "| " + " | ".join(head) + " |",
        "|" + "|".join("---" if i == 0 else "---:" for i in range(len(head))) + "|",
    ]
    return lines + ["| " + " | ".join(r) + " |" for r in body]


def training_markdown(summary: list[dict], runs: list[dict], units: dict[str, str]) -> str:
    """What the runs cost, as Markdown: per env id each algorithm's seeds, env steps, mean wall and
    CPU time and how many runs reached the PID's validation RMSE; then one line per run."""
    lines = []
    for env_id in dict.fromkeys(r["env_id"] for r in summary):
        head = ["algorithm", "seeds", "steps", "wall (mean)", "CPU (mean)", "reached PID"]
        body = [
            [r["method"], fmt(r["n_seeds"], "{}"), fmt(r["steps"], "{:,}")]
            + [duration(r["wall_s_mean"]), duration(r["cpu_s_mean"]), f"{r['reached_pid']}/{r['n_seeds']}"]
            for r in summary
            if r["env_id"] == env_id and r["kind"] == "rl"
        ]
        if body:
            lines += [f"### {env_id}", "", *md_table(head, body), ""]
    head = [
        "env id",
        "algorithm",
        "seed",
        "steps",
        "wall",
        "CPU",
        "final RMSE",
        "steps to PID",
        "wall to PID",
    ]
    body = [
        [
            r["env_id"],
            r["algo"],
            str(r["seed"]),
            f"{r['steps']:,}",
            duration(r["wall_s"]),
            duration(r["cpu_s"]),
        ]
        + [f"{r['final_rmse']:.2f} {units.get(r['env_id'], 'deg')}"]
        + [fmt(r["steps_to_pid"], "{:,}"), duration(r["wall_to_pid_s"])]
        for r in runs
    ]
    lines += ["### Runs", "", *md_table(head, body), ""]
    return "\n".join(lines)


# --------------------------------------------------------------------------- plots
def _over_cap(row: dict) -> bool:
    t = row["time_over_limit_s_iqm"]
    return t is None or not math.isfinite(t) or t > TIME_OVER_LIMIT_CAP_S


def plot_table(path, summary: list[dict], units: dict[str, str]) -> None:
    """One row of panels per env id: RMSE, energy and time over the temperature limit of each
    algorithm (IQM, CI bar; hollow grey: over :data:`~spine_gym.agents.metrics.TIME_OVER_LIMIT_CAP_S`
    or not recorded, so not ranked) with the references as vertical lines and the cap dotted."""
    env_ids = list(dict.fromkeys(r["env_id"] for r in summary))
    per_id = max(2, len(summary) // max(1, len(env_ids)))
    fig = Figure(figsize=(13, 1.2 + 0.45 * per_id * len(env_ids) + 0.6 * len(env_ids)))
    axes = fig.subplots(len(env_ids), 3, squeeze=False)
    for i, env_id in enumerate(env_ids):
        sel = [r for r in summary if r["env_id"] == env_id]
        rl, refs = [r for r in sel if r["kind"] == "rl"], [r for r in sel if r["kind"] == "reference"]
        panels = (
            ("rmse", f"RMSE [{units.get(env_id, 'deg')}]"),
            ("energy_J", "energy [J]"),
            ("time_over_limit_s", "time over the temperature limit [s]"),
        )
        for j, (m, label) in enumerate(panels):
            ax = axes[i, j]
            for k, r in enumerate(rl):
                if r[f"{m}_iqm"] is None:
                    continue
                x, lo, hi = r[f"{m}_iqm"], r[f"{m}_ci_low"], r[f"{m}_ci_high"]
                over = _over_cap(r)
                ax.errorbar([x], [k], xerr=[[x - lo], [hi - x]], fmt="o", capsize=4,
                            color="0.55" if over else "C0", mfc="none" if over else "C0")  # fmt: skip
            ax.set_yticks(np.arange(len(rl)), [r["method"] for r in rl])
            for k, r in enumerate(refs):
                if r[f"{m}_iqm"] is not None:
                    ax.axvline(r[f"{m}_iqm"], color=f"C{k + 1}", ls="--", lw=1, label=r["method"])
            if m == "time_over_limit_s":
                ax.axvline(TIME_OVER_LIMIT_CAP_S, color="C3", ls=":", lw=1.2, label="cap")
            ax.set_xlabel(f"final validation {label}")
            ax.set_title(env_id if j == 0 else "", loc="left", fontsize=10)
            if j == 2:
                ax.legend(fontsize=7, loc="best")
    fig.suptitle(
        f"IQM over seeds, {round(100 * CONFIDENCE)} % stratified bootstrap CI (rliable); hollow grey: "
        f"over {TIME_OVER_LIMIT_CAP_S} s per episode above the temperature limit (not ranked)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / fig.get_figheight()))  # room for the title
    fig.savefig(path, dpi=90)


def plot_curves(path, env_id: str, curves: dict[str, dict], references: dict[str, dict], unit: str) -> None:
    """Validation RMSE vs env steps of each algorithm (IQM line, CI band over seeds) with the
    references as horizontal lines (the tuned PID's drawn solid).

    Args:
        curves: ``{algo: {"steps", "iqm", "low", "high", "n_runs"}}`` (arrays over evaluations).
        references: ``{controller: {"rmse": mean, ...}}``.
    """
    fig = Figure(figsize=(7, 4.2))
    ax = fig.subplots()
    for k, (algo, c) in enumerate(curves.items()):
        ax.plot(c["steps"], c["iqm"], color=f"C{k}", lw=1.6, label=f"{algo} (IQM of {c['n_runs']} seeds)")
        ax.fill_between(c["steps"], c["low"], c["high"], color=f"C{k}", alpha=0.2, lw=0)
    for k, (name, ref) in enumerate(references.items()):
        pid = name == "pid"
        color, label = (
            ("k", "pid (tuned; the level of 'reached PID')") if pid else (f"C{len(curves) + k}", name)
        )
        ax.axhline(ref["rmse"], color=color, ls="-" if pid else ":", lw=1, label=label)
    ax.set_xlabel("environment steps")
    ax.set_ylabel(f"validation tracking RMSE [{unit}]")
    ax.set_title(f"{env_id}: IQM and {round(100 * CONFIDENCE)} % CI over seeds", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
