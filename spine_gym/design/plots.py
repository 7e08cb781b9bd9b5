"""Plots of design studies: 1-D capacity curves (the seed's Figs 15-16), 2-D heat maps, and the
optimisation history. PNG files; matplotlib's object API (no pyplot state, any backend).

``inf`` metrics (a responding time never reached, MODEL.md §10.4) are never dropped silently:
curves draw them as ``^`` markers on the top edge, heat maps as hatched grey cells marked ``∞``;
failed runs (NaN) appear as ``×``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .space import METRICS
from .sweeps import SweepResult

__all__ = ["DEFAULT_METRICS", "plot_curves", "plot_heatmap", "plot_sweep", "plot_history", "axis_label"]

#: The three capacity metrics of the seed (stable angle, responding time, actuating ability).
DEFAULT_METRICS = ("stable_angle_deg", "responding_time_s", "actuating_ability")

# Display unit and scale of common design variables (values stay SI in the CSV).
_DISPLAY: dict[str, tuple[str, float]] = {
    "a": ("mm", 1e3),
    "d": ("mm", 1e3),
    "ls": ("mm", 1e3),
    "D_o": ("mm", 1e3),
    "D_i": ("mm", 1e3),
    "L0": ("m", 1.0),
    "E_t": ("MPa", 1e-6),
    "E_A": ("GPa", 1e-9),
    "E_M": ("GPa", 1e-9),
    "dsigma": ("MPa", 1e-6),
    "sigma_A_low": ("MPa", 1e-6),
    "sigma_A_high": ("MPa", 1e-6),
    "eps0": ("%", 100.0),
    "eps_T": ("%", 100.0),
    "alpha": ("W/(m²K)", 1.0),
    "T_E": ("K", 1.0),
    "T_low": ("K", 1.0),
    "T_high": ("K", 1.0),
    "voltage": ("V", 1.0),
    "n_w": ("wires per side", 1.0),
    "n_seg": ("segments", 1.0),
    "n_modules": ("modules", 1.0),
    "m_seg": ("kg", 1.0),
    "m_top": ("kg", 1.0),
}


def axis_label(name: str) -> str:
    """Axis label with display unit, e.g. ``a [mm]``."""
    if name in METRICS:
        return METRICS[name]
    unit = _DISPLAY.get(name, ("SI", 1.0))[0]
    return f"{name} [{unit}]"


def _scale(name: str) -> float:
    return _DISPLAY.get(name, ("", 1.0))[1]


def _fmt_value(name: str, v: Any) -> str:
    return f"{name}={v * _scale(name):.4g}"


def _save(fig: Figure, path: str | Path | None) -> Figure:
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=120)
    return fig


def _new_figure(n_panels: int, width: float = 4.2, height: float = 3.4) -> tuple[Figure, list]:
    fig = Figure(figsize=(width * n_panels, height), layout="constrained")
    FigureCanvasAgg(fig)
    axs = fig.subplots(1, n_panels, squeeze=False)[0]
    return fig, list(axs)


def _edge_markers(ax, xs: np.ndarray, edge: float, marker: str, color: str, label, **style) -> bool:
    """Markers at ``xs`` on the bottom (``edge`` 0) or top (1) edge of the panel, for values a line
    cannot show (inf, failed runs); returns whether there were any."""
    if not xs.size:
        return False
    ax.plot(
        xs,
        np.full(xs.size, edge),
        marker,
        color=color,
        ms=8,
        clip_on=False,
        transform=ax.get_xaxis_transform(),
        label=label,
        **style,
    )
    return True


def plot_curves(
    result: SweepResult,
    x: str,
    metrics: Sequence[str] = DEFAULT_METRICS,
    path: str | Path | None = None,
) -> Figure:
    """Metric(s) against one swept parameter; one line per combination of the other axes.

    Args:
        result: a sweep.
        x: the swept parameter on the horizontal axis.
        metrics: metric names, one panel each.
        path: PNG file to write (None: only return the figure).
    """
    if x not in result.axes:
        raise ValueError(f"x must be a swept parameter {result.param_names}, got {x!r}")
    others = [k for k in result.param_names if k != x]
    groups: dict[tuple, list[dict]] = {}
    for r in result.rows:
        groups.setdefault(tuple(r[k] for k in others), []).append(r)
    fig, axs = _new_figure(len(metrics))
    colors = [f"C{i % 10}" for i in range(len(groups))]
    for ax, metric in zip(axs, metrics, strict=True):
        if metric not in METRICS:
            raise ValueError(f"unknown metric {metric!r}; valid: {list(METRICS)}")
        inf_label = nan_label = True
        for (key, rows), color in zip(groups.items(), colors, strict=True):
            rows = sorted(rows, key=lambda r: r[x])
            xs = np.array([r[x] for r in rows], float) * _scale(x)
            ys = np.array([r[metric] for r in rows], float)
            fin = np.isfinite(ys)
            label = ", ".join(_fmt_value(k, v) for k, v in zip(others, key, strict=True)) or None
            ax.plot(xs[fin], ys[fin], "o-", color=color, ms=4, label=label)
            inf_text = "never reached (inf)" if inf_label else None
            if _edge_markers(ax, xs[np.isinf(ys)], 1.0, "^", color, inf_text, mfc="none"):
                inf_label = False
            if _edge_markers(ax, xs[np.isnan(ys)], 0.0, "x", color, "failed run" if nan_label else None):
                nan_label = False
        ax.set_xlabel(axis_label(x))
        ax.set_ylabel(METRICS[metric])
        ax.grid(alpha=0.3)
    handles, labels = axs[0].get_legend_handles_labels()
    for ax in axs[1:]:  # inf/failed markers may appear in any panel
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    if labels:
        axs[-1].legend(handles, labels, fontsize=7, loc="best")
    fig.suptitle(f"capacity vs {x}")
    return _save(fig, path)


def plot_heatmap(result: SweepResult, x: str, y: str, metric: str, path: str | Path | None = None) -> Figure:
    """Heat map of one metric over two swept parameters (other axes must hold one value each)."""
    for name in (x, y):
        if name not in result.axes:
            raise ValueError(f"heat-map axis must be a swept parameter {result.param_names}, got {name!r}")
    if x == y:
        raise ValueError("heat map needs two different parameters")
    extra = [k for k in result.param_names if k not in (x, y) and len(result.axes[k]) > 1]
    if extra:
        raise ValueError(f"heat map of {x} x {y} is ambiguous: {extra} also vary")
    if metric not in METRICS:
        raise ValueError(f"unknown metric {metric!r}; valid: {list(METRICS)}")
    xs, ys = result.axes[x], result.axes[y]
    z = np.full((len(ys), len(xs)), np.nan)
    for r in result.rows:
        z[ys.index(r[y]), xs.index(r[x])] = r[metric]
    fig, (ax,) = _new_figure(1, width=5.6, height=4.4)
    finite = np.isfinite(z)
    masked = np.ma.masked_where(~finite, z)
    im = ax.imshow(masked, origin="lower", aspect="auto", cmap="viridis")
    # hatched background shows through the masked (inf / failed) cells
    ax.set_facecolor("0.85")
    ax.patch.set_hatch("//")
    fig.colorbar(im, ax=ax, label=METRICS[metric])
    ax.set_xticks(range(len(xs)), [f"{v * _scale(x):.4g}" for v in xs], rotation=45 if len(xs) > 8 else 0)
    ax.set_yticks(range(len(ys)), [f"{v * _scale(y):.4g}" for v in ys])
    ax.set_xlabel(axis_label(x))
    ax.set_ylabel(axis_label(y))
    if finite.any():
        lo, hi = float(z[finite].min()), float(z[finite].max())
    else:
        lo = hi = 0.0
    if len(xs) * len(ys) <= 225:
        for (i, j), v in np.ndenumerate(z):
            if math.isinf(v):
                txt, color = "∞", "k"
            elif math.isnan(v):
                txt, color = "×", "k"
            else:
                txt = f"{v:.3g}"
                color = "w" if hi > lo and (v - lo) / (hi - lo) < 0.5 else "k"
            big = txt in ("∞", "×")
            ax.text(
                j,
                i,
                txt,
                ha="center",
                va="center",
                fontsize=11 if big else 7,
                color=color,
                weight="bold" if big else "normal",
                bbox=dict(boxstyle="round,pad=0.15", fc="w", ec="none", alpha=0.8) if big else None,
            )
    title = METRICS[metric]
    if np.isinf(z).any():
        title += "  (∞ = never reached)"
    if np.isnan(z).any():
        title += "  (× = failed run)"
    ax.set_title(title, fontsize=10)
    return _save(fig, path)


def plot_sweep(
    result: SweepResult, out_dir: str | Path, metrics: Sequence[str] = DEFAULT_METRICS
) -> list[Path]:
    """All standard plots of a sweep, written as PNG into ``out_dir``.

    One axis: ``curves_<x>.png``. Two axes: curves against each axis (one line per value of the
    other) and ``heatmap_<metric>.png`` per metric. Three or more: curves against each axis (one
    line per combination of the others). Axes with a single value are treated as fixed.
    """
    out_dir = Path(out_dir)
    varying = [k for k in result.param_names if len(result.axes[k]) > 1] or result.param_names[:1]
    written = []
    for x in varying:
        p = out_dir / f"curves_{x}.png"
        plot_curves(result, x, metrics, p)
        written.append(p)
    if len(varying) == 2:
        x, y = varying
        for m in metrics:
            p = out_dir / f"heatmap_{m}.png"
            plot_heatmap(result, x, y, m, p)
            written.append(p)
    return written


def plot_history(
    trials: Sequence[dict[str, Any]], metric: str, maximize: bool, path: str | Path | None = None
) -> Figure:
    """Optimisation history: objective per trial (filled = feasible, hollow = infeasible) and the
    best feasible value so far.

    Args:
        trials: records with ``number``, ``value`` (objective; may be inf/NaN) and ``feasible``.
        metric: objective metric name.
        maximize: direction.
        path: PNG file to write.
    """
    fig, (ax,) = _new_figure(1, width=6.0, height=3.8)
    trials = sorted(trials, key=lambda t: t["number"])
    num = np.array([t["number"] for t in trials], float)
    val = np.array([t["value"] if t["value"] is not None else np.nan for t in trials], float)
    feas = np.array([bool(t["feasible"]) for t in trials])
    fin = np.isfinite(val)
    ax.plot(num[fin & feas], val[fin & feas], "o", color="C0", ms=4, label="feasible")
    ax.plot(num[fin & ~feas], val[fin & ~feas], "o", color="C3", mfc="none", ms=4, label="infeasible")
    inf = np.isinf(val)
    if inf.any():
        ax.plot(
            num[inf],
            np.ones(inf.sum()),
            "^",
            color="C7",
            mfc="none",
            clip_on=False,
            transform=ax.get_xaxis_transform(),
            label="inf (never reached)",
        )
    best = []
    cur = math.nan
    for v, f in zip(val, feas, strict=True):
        if f and math.isfinite(v):
            cur = v if math.isnan(cur) else (max(cur, v) if maximize else min(cur, v))
        best.append(cur)
    ax.step(num, np.array(best), where="post", color="k", lw=1.2, label="best feasible")
    ax.set_xlabel("trial")
    ax.set_ylabel(METRICS.get(metric, metric))
    ax.set_title(f"{'maximise' if maximize else 'minimise'} {metric}", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return _save(fig, path)
