"""Statistics, tables and plots of :mod:`spine_gym.agents.benchmark` (no training here).

* :func:`iqm_interval` — the interquartile mean (IQM) over seeds of one score and its 95 %
  stratified bootstrap confidence interval, both from ``rliable``
  (:func:`rliable.metrics.aggregate_iqm`, :func:`rliable.library.get_interval_estimates`);
  :func:`curve_intervals` — the same at every evaluation of a learning curve.
* :func:`steps_to_level` — the env steps of a run's first evaluation at or below a reference level
  (the PID's validation RMSE), None if it never gets there; :func:`time_to_level` — the same with
  its training wall time; :func:`censored_iqm_interval` — their IQM and CI over seeds, a run that
  never got there counted as later than every one that did (so it is trimmed, never dropped);
  :func:`hardware_time` — env steps as the time a real spine would run them (× the control period).
* :func:`performance_profiles`, :func:`plot_profiles` — rliable's performance profiles over every
  env id: the fraction of runs at least ``τ`` × as accurate as the PID, and the fraction of runs at
  most ``τ`` seconds per episode over the temperature limit.
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


def _first_at_or_below(steps: Sequence[float], values: Sequence[float], level: float) -> int | None:
    """Index of the first evaluation whose value is at or below ``level`` (None if none is; a NaN
    value is not). ValueError on curves of unequal length, steps that do not increase or a level
    that is not finite."""
    s, v = np.asarray(steps, dtype=np.float64), np.asarray(values, dtype=np.float64)
    if s.shape != v.shape or s.ndim != 1:
        raise ValueError(f"steps and values must be 1-D of one length, got shapes {s.shape} and {v.shape}")
    if np.any(np.diff(s) <= 0):
        raise ValueError("steps must increase from one evaluation to the next")
    if not math.isfinite(level):
        raise ValueError(f"level must be a finite number, got {level}")
    hits = np.flatnonzero(v <= level)
    return int(hits[0]) if hits.size else None


def steps_to_level(steps: Sequence[float], values: Sequence[float], level: float) -> int | None:
    """Env steps of a run's first evaluation whose value (e.g. validation RMSE) is at or below
    ``level`` (e.g. the PID's on the same validation episodes); None if no evaluation is.

    The first such evaluation counts even if a later one is above the level again (a noisy curve
    crosses once per dip): the time to reach a level, not to stay there. The resolution is the
    evaluation interval: a run that reaches it between two evaluations is counted at the second.
    """
    i = _first_at_or_below(steps, values, level)
    return None if i is None else int(steps[i])


def time_to_level(
    steps: Sequence[float], wall_s: Sequence[float], values: Sequence[float], level: float
) -> tuple[int | None, float | None]:
    """``(env steps, training wall time [s])`` of :func:`steps_to_level`'s evaluation; ``(None, None)``
    if the run never reaches the level."""
    i = _first_at_or_below(steps, values, level)
    return (None, None) if i is None else (int(steps[i]), float(wall_s[i]))


def hardware_time(steps: float | None, control_period_s: float) -> float | None:
    """[s] The time a real spine takes to run ``steps`` env steps: one step is one control period
    (None stays None, an infinity stays one: not reached)."""
    return None if steps is None else float(steps) * float(control_period_s)


def _trimmed_means(samples: np.ndarray) -> np.ndarray:
    """The IQM of each row of ``samples`` (n_rows, n): the mean of the middle half after cutting
    ``int(n / 4)`` values at each end (scipy's ``trim_mean(x, 0.25)``, rliable's
    ``aggregate_iqm``); a row whose middle half holds an infinity has an infinite IQM."""
    n = samples.shape[1]
    k = int(0.25 * n)
    return np.sort(samples, axis=1)[:, k : n - k].mean(axis=1)


def censored_iqm_interval(
    values: Sequence[float | None], reps: int = BOOTSTRAP_REPS, seed: int = 0
) -> tuple[float, float, float]:
    """``(IQM, CI low, CI high)`` over seeds of a time to a level, e.g. :func:`steps_to_level` of
    each seed, where None (not reached within the budget) is later than every reached value.

    Not-reached runs are counted, not dropped: as +∞ they are the first trimmed from the top, so
    the IQM is finite while at most the top quarter of the runs missed the level and ``inf`` (not
    reached) once the middle half holds one; the 95 % percentile bootstrap CI over seeds (resampled
    as rliable resamples runs) reads the bootstrap's own order statistics, so a bound is ``inf``
    where the resamples' are.

    Raises:
        ValueError: no values, or a value that is negative or NaN.
    """
    x = np.array([math.inf if v is None else float(v) for v in values], dtype=np.float64)
    if x.size == 0 or np.any(np.isnan(x)) or np.any(x < 0):
        raise ValueError(f"values must be a non-empty list of numbers >= 0 or None, got {list(values)}")
    point = float(_trimmed_means(x[None, :])[0])
    rng = np.random.default_rng(seed)
    boot = _trimmed_means(x[rng.integers(0, x.size, size=(reps, x.size))])
    alpha = (1 - CONFIDENCE) / 2
    low, high = np.quantile(boot, [alpha, 1 - alpha], method="inverted_cdf")
    return point, float(low), float(high)


# --------------------------------------------------------------------------- tables
def _metric_cells(scores: list, reps: int) -> tuple:
    """``(IQM, CI low, CI high)`` of a metric over seeds; all None if a seed lacks it (e.g. records
    written before the metric was recorded) or it is not finite."""
    if any(x is None or not math.isfinite(x) for x in scores):
        return None, None, None
    return iqm_interval(scores, reps=reps)


def _to_pid_cells(group: list[dict], control_period_s: float | None, reps: int) -> dict:
    """The time to the PID's level of one algorithm's runs: env steps IQM and CI over seeds
    (:func:`censored_iqm_interval`), the hardware time they stand for, and the IQM of the training
    CPU and wall time to it (inf: not reached by the middle half of the seeds)."""
    iqm, lo, hi = censored_iqm_interval([r["steps_to_pid"] for r in group], reps=reps)
    out = {"steps_to_pid_iqm": iqm, "steps_to_pid_ci_low": lo, "steps_to_pid_ci_high": hi}
    for k, v in (("iqm", iqm), ("ci_low", lo), ("ci_high", hi)):
        hw = None if control_period_s is None else hardware_time(v, control_period_s)
        out[f"hardware_to_pid_s_{k}"] = hw
    for t in ("cpu", "wall"):
        times = [r.get(f"{t}_to_pid_s") for r in group]
        out[f"{t}_to_pid_s_iqm"] = censored_iqm_interval(times, reps=reps)[0]
    return out


def summary_rows(
    runs: list[dict],
    references: dict[str, dict[str, dict]],
    reps: int = BOOTSTRAP_REPS,
    control_periods: dict[str, float] | None = None,
) -> list[dict]:
    """One row per (env id, algorithm) with the IQM and CI over seeds of each final metric, of the
    env steps to the PID's level and the hardware time they stand for, and the mean wall/CPU time,
    then one row per reference controller of the env id (its validation means). A metric that
    some seed (or a reference) did not record gets None cells, not a number.

    Args:
        runs: per-run records (``env_id``, ``algo``, ``seed``, ``steps``, ``wall_s``, ``cpu_s``,
            ``steps_to_pid``, ``final_<metric>`` for each of :data:`METRICS`; ``cpu_to_pid_s`` and
            ``wall_to_pid_s`` where known).
        references: ``{env_id: {controller: {<metric>: mean, "n_episodes": n}}}``.
        reps: bootstrap resamples.
        control_periods: ``{env_id: control period [s]}`` for the hardware time (None cells without).
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
            row |= _to_pid_cells(group, (control_periods or {}).get(env_id), reps)
            row["n_episodes"] = None
            out.append(row)
        for name, ref in references.get(env_id, {}).items():
            row = {"env_id": env_id, "method": name, "kind": "reference", "n_seeds": None, "steps": None}
            for m in METRICS:
                row |= {f"{m}_iqm": ref.get(m), f"{m}_ci_low": None, f"{m}_ci_high": None}
            row |= {"wall_s_mean": None, "cpu_s_mean": None, "reached_pid": None}
            cells = ("iqm", "ci_low", "ci_high")
            row |= {f"{k}_{c}": None for k in ("steps_to_pid", "hardware_to_pid_s") for c in cells}
            row |= {"cpu_to_pid_s_iqm": None, "wall_to_pid_s_iqm": None}
            row["n_episodes"] = ref["n_episodes"]
            out.append(row)
    return out


NOT_REACHED = "not reached"


def duration(seconds: float | None) -> str:
    """A duration for the table: seconds under 2 min, minutes under 2 h, hours above (infinite:
    :data:`NOT_REACHED`)."""
    if seconds is None:
        return DASH
    if math.isinf(seconds):
        return NOT_REACHED
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


def steps_cell(steps: float | None) -> str:
    """Env steps, from 10 000 on in thousands (``40 k``); :data:`NOT_REACHED` if infinite."""
    if steps is None:
        return DASH
    if math.isinf(steps):
        return NOT_REACHED
    return f"{steps / 1000:,.0f} k" if steps >= 10_000 else f"{steps:,.0f}"


def _to_pid_interval(row: dict, key: str, cell: Callable) -> str:
    if row.get(f"{key}_iqm") is None:
        return DASH
    if math.isinf(row[f"{key}_ci_low"]):  # no seed, nor any resample, got there
        return NOT_REACHED
    return f"{cell(row[f'{key}_iqm'])} [{cell(row[f'{key}_ci_low'])}, {cell(row[f'{key}_ci_high'])}]"


TRAINING_HEAD = [
    "algorithm", "seeds", "steps (budget)", "reached PID", "env steps to PID, IQM [95 % CI]",
    "hardware time to PID (steps × control period)", "CPU to PID (IQM)", "wall to PID (IQM)",
    "CPU (mean, budget)", "wall (mean, budget)",
]  # fmt: skip


def _training_row(r: dict) -> list[str]:
    return [
        r["method"], fmt(r["n_seeds"], "{}"), fmt(r["steps"], "{:,}"), f"{r['reached_pid']}/{r['n_seeds']}",
        _to_pid_interval(r, "steps_to_pid", steps_cell), _to_pid_interval(r, "hardware_to_pid_s", duration),
        duration(r.get("cpu_to_pid_s_iqm")), duration(r.get("wall_to_pid_s_iqm")),
        duration(r["cpu_s_mean"]), duration(r["wall_s_mean"]),
    ]  # fmt: skip


def training_markdown(summary: list[dict], runs: list[dict], units: dict[str, str]) -> str:
    """What the runs cost, as Markdown: per env id each algorithm's seeds, budget, how many runs
    reached the PID's validation RMSE, the env steps to it (IQM [95 % CI] over seeds, runs that
    never reached it counted as later than all that did: :func:`censored_iqm_interval`), the
    hardware time they stand for and the training CPU and wall time to it, and the mean CPU and
    wall time of the whole budget; then one line per run."""
    lines = []
    for env_id in dict.fromkeys(r["env_id"] for r in summary):
        body = [_training_row(r) for r in summary if r["env_id"] == env_id and r["kind"] == "rl"]
        if body:
            lines += [f"### {env_id}", "", *md_table(TRAINING_HEAD, body), ""]
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
        "CPU to PID",
        "energy there (× PID)",
        "T>limit there [s]",
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
        + [fmt(r["steps_to_pid"], "{:,}"), duration(r["wall_to_pid_s"]), duration(r.get("cpu_to_pid_s"))]
        + [fmt(r.get("energy_ratio_at_pid"), "{:.2f}"), fmt(r.get("time_over_limit_at_pid_s"), "{:.1f}")]
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


def _plot_curve_panel(ax, env_id: str, curves: dict[str, dict], references: dict[str, dict], unit: str) -> None:
    """One env id's panel of :func:`plot_curves`."""
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
    ax.legend(fontsize=7)


def plot_curves(path, panels: dict[str, dict]) -> None:
    """Validation RMSE vs env steps of each algorithm (IQM line, CI band over seeds) with the
    references as horizontal lines (the tuned PID's drawn solid): one panel per env id, in the
    order of ``panels``, two per row, in one figure.

    Args:
        panels: ``{env id: {"curves", "references", "unit"}}``: ``curves`` is
            ``{algo: {"steps", "iqm", "low", "high", "n_runs"}}`` (arrays over evaluations),
            ``references`` ``{controller: {"rmse": mean, ...}}``, ``unit`` the RMSE's unit.
    """
    cols = min(2, len(panels))
    rows = math.ceil(len(panels) / cols)
    fig = Figure(figsize=(7 * cols, 4.2 * rows))
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, (env_id, panel) in zip(axes, panels.items()):
        _plot_curve_panel(ax, env_id, panel["curves"], panel["references"], panel["unit"])
    for ax in axes[len(panels) :]:
        ax.set_visible(False)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


# --------------------------------------------------------------------------- performance profiles
def _seeded(seed: int, func: Callable, *args, **kwargs):
    """``func(*args, **kwargs)`` with NumPy's global generator seeded ``seed`` (rliable draws its
    bootstrap indices from it), the caller's state restored afterwards."""
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        return func(*args, **kwargs)
    finally:
        np.random.set_state(state)


def profile_scores(runs: list[dict], references: dict[str, dict[str, dict]]) -> tuple[dict, dict, list[str]]:
    """The score matrices (runs × env ids) of rliable's performance profiles, per algorithm:
    ``accuracy`` = the PID's validation RMSE ÷ the run's final one (1: the PID's level, above:
    better) and ``over`` = the run's final time over the temperature limit [s per episode]. The
    env ids are those every algorithm ran on and that have the PID's reference; each algorithm
    keeps as many seeds per id as it has on all of them (its lowest seeds). Returns
    ``(accuracy, over, env ids)``; an algorithm with an unrecorded time over the limit is left out
    of ``over``."""
    algos = list(dict.fromkeys(r["algo"] for r in runs))
    ids = [e for e in dict.fromkeys(r["env_id"] for r in runs) if "pid" in references.get(e, {})]
    ids = [e for e in ids if all(any(r["algo"] == a and r["env_id"] == e for r in runs) for a in algos)]
    accuracy, over = {}, {}
    for algo in algos:
        per_id = [sorted((r for r in runs if r["algo"] == algo and r["env_id"] == e), key=lambda r: r["seed"])
                  for e in ids]  # fmt: skip
        n = min((len(p) for p in per_id), default=0)
        if n == 0:
            continue
        acc = [[references[e]["pid"]["rmse"] / p[k]["final_rmse"] for e, p in zip(ids, per_id, strict=True)]
               for k in range(n)]  # fmt: skip
        accuracy[algo] = np.array(acc)
        t = [[p[k].get("final_time_over_limit_s") for p in per_id] for k in range(n)]
        if all(x is not None and math.isfinite(x) for row in t for x in row):
            over[algo] = np.array(t, dtype=np.float64)
    return accuracy, over, ids


def performance_profiles(
    scores: dict[str, np.ndarray], taus: np.ndarray, reps: int = BOOTSTRAP_REPS, seed: int = 0, below=False
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """rliable's performance profile of each algorithm's ``scores`` (runs × tasks): the fraction of
    runs with a score above each ``τ`` of ``taus`` (``below``: at or under it) and its 95 % CI
    (stratified bootstrap over runs), as ``(profiles, cis)``; reproducible for a ``seed``."""
    if below:  # score <= tau  <=>  -score >= -tau; rliable counts score > tau, so shift by an ulp
        scores = {a: -s for a, s in scores.items()}
        taus = np.nextafter(-np.asarray(taus, dtype=np.float64), -np.inf)
    return _seeded(
        seed, rly.create_performance_profile, scores, taus, reps=reps, confidence_interval_size=CONFIDENCE
    )


def plot_profiles(
    path, runs: list[dict], references: dict[str, dict[str, dict]], reps: int = BOOTSTRAP_REPS
) -> bool:
    """Two performance profiles over every env id (:func:`profile_scores`), a line and its 95 % CI
    band per algorithm: the fraction of runs at least ``τ`` × as accurate as the tuned PID (the
    PID's RMSE ÷ the run's), and the fraction of runs at most ``τ`` seconds per episode over the
    temperature limit (the cap dotted). Returns False (and writes nothing) without a common env id."""
    accuracy, over, ids = profile_scores(runs, references)
    if not ids or not accuracy:
        return False
    fig = Figure(figsize=(11, 4.2))
    ax_acc, ax_over = fig.subplots(1, 2)
    hi_acc = max(2.0, 1.05 * max(float(np.max(s)) for s in accuracy.values()))
    hi_over = max([5.0, *(float(np.max(s)) for s in over.values())])
    panels = (
        (ax_acc, accuracy, np.linspace(0.0, hi_acc, 121), False,
         "τ: accuracy relative to the tuned PID (its RMSE ÷ the run's)", "fraction of runs with accuracy > τ"),
        (ax_over, over, np.linspace(0.0, hi_over, 121), True,
         "τ: time over the temperature limit [s per episode]", "fraction of runs at most τ over the limit"),
    )  # fmt: skip
    colors = {a: f"C{k}" for k, a in enumerate(accuracy)}
    for ax, scores, taus, below, xlabel, ylabel in panels:
        if not scores:
            ax.set_axis_off()
            continue
        prof, cis = performance_profiles(scores, taus, reps=reps, below=below)
        for algo in scores:
            label = f"{algo} ({scores[algo].shape[0]} seeds × {len(ids)} ids)"
            ax.plot(taus, prof[algo], color=colors[algo], lw=1.6, label=label)
            ax.fill_between(taus, cis[algo][0], cis[algo][1], color=colors[algo], alpha=0.2, lw=0)
        ref = (TIME_OVER_LIMIT_CAP_S, "the cap") if below else (1.0, "the PID's level")
        ax.axvline(ref[0], color="k", ls=":", lw=1.2, label=ref[1])
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    fig.suptitle(
        f"Performance profiles over {len(ids)} env ids (final validation; rliable, "
        f"{round(100 * CONFIDENCE)} % stratified bootstrap CI)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    return True
