"""PNG plots of simulation results, capacity studies and benchmarks.

Every function takes plain results (:class:`~spine_gym.simulate.SimulationResult`,
:class:`~spine_gym.capacity.CapacityMetrics` lists, arrays) and writes one PNG file, returning its
path. matplotlib is imported lazily inside the functions (importing this module costs nothing and
pulls in no matplotlib) and drawn with the Agg canvas through matplotlib's object API, so no
pyplot state or global backend is touched and any caller (scripts, tests, notebooks, worker
processes) can use it.

Functions:

* :func:`plot_angle` — bending angle against time for one or more runs, with reference points
  overlaid and the wire voltages underneath (the seed's hysteresis / alternate-drive figures).
* :func:`plot_wire_states` — temperature, stress and phase fractions of both wires against time.
* :func:`plot_capacity` — the three capacity metrics against one design variable (the seed's
  Figs 15–16), with reference values overlaid.
* :func:`plot_timings` — bar chart of timings (log scale), optionally with a panel of errors
  against time.
* :func:`plot_episodes` (figure: :func:`episode_figure`) — evaluation episodes side by side:
  tracked quantity and target, wire voltages and temperatures against time, the temperature limit
  labelled and the disturbance windows (:func:`disturbance_windows`: tip pushes, payload) shaded.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "plot_angle",
    "plot_wire_states",
    "plot_capacity",
    "plot_timings",
    "plot_episodes",
    "episode_figure",
    "disturbance_windows",
    "DEFAULT_DPI",
]

DEFAULT_DPI = 120  # [dots per inch] of the written PNG files

_REF_STYLE = dict(ls="none", marker="o", ms=5, mfc="none", mec="k", mew=1.2, zorder=5)


def _figure(nrows: int, ncols: int, width: float, height: float, **kw):
    """A constrained-layout Figure on an Agg canvas and its axes array (lazy matplotlib import)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    axs = fig.subplots(nrows, ncols, squeeze=False, **kw)
    return fig, axs


def _save(fig, path: str | Path, dpi: int) -> Path:
    if not (isinstance(dpi, int | float) and 20 <= dpi <= 1200):
        raise ValueError(f"dpi must be in [20, 1200], got {dpi!r}")
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"path must end in .png, got {str(path)!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return path


def _as_list(results) -> list:
    from .simulate import SimulationResult

    if isinstance(results, SimulationResult):
        return [results]
    results = list(results)
    if not results:
        raise ValueError("results must hold at least one SimulationResult")
    for r in results:
        if not isinstance(r, SimulationResult):
            raise ValueError(f"results must be SimulationResult objects, got {type(r).__name__}")
    return results


def _reference_xy(reference, name: str = "reference") -> tuple[np.ndarray, np.ndarray]:
    """(x, y) arrays of equal length from a pair of sequences or a mapping x → y."""
    if isinstance(reference, Mapping):
        x, y = list(reference.keys()), list(reference.values())
    else:
        try:
            x, y = reference
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be (x, y) sequences or a mapping x -> y") from None
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.ndim != 1 or x.shape != y.shape:
        raise ValueError(f"{name} x and y must be 1-D of equal length, got shapes {x.shape} and {y.shape}")
    return x, y


def plot_angle(
    results,
    path: str | Path,
    *,
    labels: Sequence[str] | None = None,
    reference=None,
    reference_label: str = "reference (MODEL.md §10)",
    title: str | None = None,
    show_inputs: bool = True,
    dpi: int = DEFAULT_DPI,
) -> Path:
    """Bending angle Θ [deg] against time [s], one line per run, reference points as hollow circles.

    Args:
        results: a SimulationResult or a sequence of them.
        path: the PNG file to write (parent folders are created).
        labels: one legend label per run (default ``run 0``, ``run 1``, … or none for one run).
        reference: optional reference points: ``(times [s], angles [deg])`` or a mapping time → angle.
        reference_label: legend label of the reference points.
        title: figure title.
        show_inputs: add a lower panel with the right/left wire voltages [V] of the first run.
        dpi: resolution of the PNG.

    Returns:
        The path written.

    Raises:
        ValueError: empty or mistyped ``results``, label count mismatch, malformed ``reference``,
            a path not ending in ``.png`` or a dpi outside [20, 1200].
    """
    runs = _as_list(results)
    if labels is not None and len(labels) != len(runs):
        raise ValueError(f"labels must have one entry per run ({len(runs)}), got {len(labels)}")
    ref = _reference_xy(reference) if reference is not None else None
    if show_inputs:
        fig, axs = _figure(2, 1, 7.0, 5.2, sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    else:
        fig, axs = _figure(1, 1, 7.0, 4.0)
    ax = axs[0, 0]
    for i, r in enumerate(runs):
        lab = labels[i] if labels is not None else (f"run {i}" if len(runs) > 1 else "model")
        ax.plot(r.time, r.angle_deg, lw=1.6, color=f"C{i % 10}", label=lab)
    if ref is not None:
        ax.plot(ref[0], ref[1], label=reference_label, **_REF_STYLE)
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_ylabel("bending angle Θ [deg]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    if title:
        ax.set_title(title, fontsize=10)
    if show_inputs:
        bx = axs[1, 0]
        r = runs[0]
        bx.step(r.time, r.voltage_right, where="pre", color="C3", lw=1.2, label="right wire")
        bx.step(r.time, r.voltage_left, where="pre", color="C0", lw=1.2, ls="--", label="left wire")
        bx.set_ylabel("voltage [V]")
        bx.set_xlabel("time [s]")
        bx.grid(alpha=0.3)
        bx.legend(fontsize=7, loc="upper right")
    else:
        ax.set_xlabel("time [s]")
    out = _save(fig, path, dpi)
    return out


def plot_wire_states(
    result,
    path: str | Path,
    *,
    title: str | None = None,
    dpi: int = DEFAULT_DPI,
) -> Path:
    """Temperature [K], stress [MPa] and phase fractions x₊, x₋, x_A of both wires against time.

    Right wire solid, left wire dashed. Three stacked panels sharing the time axis.

    Args:
        result: one SimulationResult.
        path: the PNG file to write.
        title: figure title.
        dpi: resolution of the PNG.

    Returns:
        The path written.
    """
    (r,) = _as_list(result)
    fig, axs = _figure(3, 1, 7.0, 7.5, sharex=True)
    at, ax_s, ax_x = axs[0, 0], axs[1, 0], axs[2, 0]
    at.plot(r.time, r.temperature_right, "C3-", label="right wire")
    at.plot(r.time, r.temperature_left, "C0--", label="left wire")
    at.set_ylabel("temperature T [K]")
    ax_s.plot(r.time, r.stress_right / 1e6, "C3-", label="right wire")
    ax_s.plot(r.time, r.stress_left / 1e6, "C0--", label="left wire")
    ax_s.set_ylabel("stress σ [MPa]")
    for name, color in (("x_plus", "C1"), ("x_minus", "C2"), ("x_austenite", "C4")):
        sym = {"x_plus": "x₊ (M⁺)", "x_minus": "x₋ (M⁻)", "x_austenite": "x_A (A)"}[name]
        ax_x.plot(r.time, getattr(r, f"{name}_right"), "-", color=color, label=f"{sym} right")
        ax_x.plot(r.time, getattr(r, f"{name}_left"), "--", color=color, label=f"{sym} left")
    ax_x.set_ylabel("phase fraction [-]")
    ax_x.set_ylim(-0.03, 1.03)
    ax_x.set_xlabel("time [s]")
    for ax in (at, ax_s, ax_x):
        ax.grid(alpha=0.3)
    at.legend(fontsize=7, loc="best")
    ax_x.legend(fontsize=7, ncol=3, loc="center right")
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path, dpi)


# metric name → (axis label, reference key aliases)
_CAPACITY_PANELS = (
    ("stable_angle_deg", "stable angle θ_s [deg]"),
    ("responding_time_s", "responding time [s]"),
    ("actuating_ability", "actuating ability [1/deg]"),
)


def _metric(m: Any, name: str) -> float:
    if isinstance(m, Mapping):
        v = m.get(name, math.nan)
    else:
        v = getattr(m, name, math.nan)
    return math.nan if v is None else float(v)


def _plot_with_inf(ax, xs: np.ndarray, ys: np.ndarray, style: str, color: str, label: str) -> None:
    """``ys`` against ``xs`` on ``ax``; its ``inf`` values as ``^`` markers on the panel's top edge."""
    fin = np.isfinite(ys)
    ax.plot(xs[fin], ys[fin], style, color=color, ms=5, label=label)
    if np.isinf(ys).any():
        ax.plot(
            xs[np.isinf(ys)],
            np.ones(int(np.isinf(ys).sum())),
            "^",
            color=color,
            ms=8,
            clip_on=False,
            transform=ax.get_xaxis_transform(),
            label=f"{label}: never reached (inf)",
        )


def plot_capacity(
    x: Sequence[float],
    metrics: Sequence[Any],
    path: str | Path,
    *,
    xlabel: str,
    reference: Sequence[Any] | None = None,
    reference_label: str = "reference (MODEL.md §10.4)",
    title: str | None = None,
    integer_x: bool = False,
    dpi: int = DEFAULT_DPI,
) -> Path:
    """The capacity metrics against one design variable, as in the seed's Figs 15–16.

    Three panels: stable angle, responding time (reading (i) solid; reading (ii), 90 % of the swing,
    dashed, when available) and actuating ability. Values that are ``inf`` (a level never reached)
    are drawn as ``^`` markers on the top edge of their panel, never dropped silently.

    Args:
        x: the design-variable values, in display units (e.g. mm), one per design.
        metrics: one :class:`~spine_gym.capacity.CapacityMetrics` (or a mapping with the same
            keys) per design.
        path: the PNG file to write.
        xlabel: horizontal-axis label with unit.
        reference: optional reference metrics (CapacityMetrics or mappings; missing keys/None are
            skipped), one per design, drawn as hollow circles.
        reference_label: legend label of the reference points.
        title: figure title.
        integer_x: use integer ticks (e.g. wires per side).
        dpi: resolution of the PNG.

    Returns:
        The path written.

    Raises:
        ValueError: ``x``, ``metrics`` and ``reference`` of different lengths, or no design.
    """
    xs = np.asarray(x, dtype=float)
    if xs.ndim != 1 or xs.size == 0:
        raise ValueError(f"x must be a non-empty 1-D sequence, got shape {xs.shape}")
    if len(metrics) != xs.size:
        raise ValueError(f"metrics must have one entry per x value ({xs.size}), got {len(metrics)}")
    if reference is not None and len(reference) != xs.size:
        raise ValueError(f"reference must have one entry per x value ({xs.size}), got {len(reference)}")
    order = np.argsort(xs)
    xs = xs[order]
    fig, axs = _figure(1, 3, 12.6, 3.6)
    for ax, (name, ylabel) in zip(axs[0], _CAPACITY_PANELS, strict=True):
        series = [(name, "o-", "model")]
        if name == "responding_time_s":
            series.append(("responding_time_swing_s", "s--", "model, 90 % of swing"))
        for j, (key, style, lab) in enumerate(series):
            ys = np.array([_metric(metrics[i], key) for i in order])
            _plot_with_inf(ax, xs, ys, style, f"C{j}", lab)
            if reference is not None:
                rs = np.array([_metric(reference[i], key) for i in order])
                ok = np.isfinite(rs)
                if ok.any():
                    ax.plot(xs[ok], rs[ok], label=reference_label if j == 0 else None, **_REF_STYLE)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if integer_x:
            ax.set_xticks(xs)
            ax.set_xticklabels([f"{v:g}" for v in xs])
        ax.legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path, dpi)


def plot_timings(
    labels: Sequence[str],
    seconds: Sequence[float],
    path: str | Path,
    *,
    target_s: float | None = None,
    target_label: str = "target",
    annotations: Sequence[str] | None = None,
    title: str | None = None,
    errors: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None,
    errors_ylabel: str = "error",
    dpi: int = DEFAULT_DPI,
) -> Path:
    """Horizontal bars of timings [s] on a log axis, optionally with an error-vs-time panel.

    Args:
        labels: one name per bar.
        seconds: one positive time per bar [s] (drawn in ms).
        path: the PNG file to write.
        target_s: optional target time [s], drawn as a vertical line.
        target_label: legend label of the target line.
        annotations: optional text per bar (e.g. ``"×38 slower"``), written right of the bar.
        title: figure title.
        errors: optional mapping label → (time [s], error) drawn in a second panel.
        errors_ylabel: label of the error axis.
        dpi: resolution of the PNG.

    Returns:
        The path written.

    Raises:
        ValueError: lengths differ, or a time is not finite and positive.
    """
    t = np.asarray(seconds, dtype=float)
    if t.ndim != 1 or t.size != len(labels) or t.size == 0:
        raise ValueError(f"seconds must be 1-D with one entry per label ({len(labels)}), got shape {t.shape}")
    if not np.all(np.isfinite(t) & (t > 0)):
        raise ValueError(f"seconds must be finite and > 0, got {t.tolist()}")
    if annotations is not None and len(annotations) != t.size:
        raise ValueError(f"annotations must have one entry per label ({t.size}), got {len(annotations)}")
    ncols = 2 if errors else 1
    fig, axs = _figure(1, ncols, 6.4 * ncols, 0.5 * t.size + 2.0)
    ax = axs[0, 0]
    ms = t * 1e3
    y = np.arange(t.size)[::-1]
    ax.barh(y, ms, color=[f"C{i % 10}" for i in range(t.size)], alpha=0.8)
    ax.set_yticks(y)
    ax.set_yticklabels(labels, fontsize=8)
    ax.set_xscale("log")
    ax.set_xlabel("time [ms]")
    ax.grid(alpha=0.3, axis="x", which="both")
    for yi, v, i in zip(y, ms, range(t.size), strict=True):
        txt = f"{v:.3g} ms" + (f"  {annotations[i]}" if annotations is not None else "")
        ax.text(v * 1.08, yi, txt, va="center", fontsize=7, bbox=dict(fc="w", ec="none", alpha=0.8, pad=1))
    ax.set_xlim(ms.min() / 2.0, ms.max() * 30.0)
    if target_s is not None:
        ax.axvline(target_s * 1e3, color="k", ls="--", lw=1.0, label=f"{target_label} {target_s * 1e3:g} ms")
        ax.legend(fontsize=7, loc="lower right")
    if title:
        ax.set_title(title, fontsize=10)
    if errors:
        bx = axs[0, 1]
        for i, (lab, (te, err)) in enumerate(errors.items()):
            bx.plot(
                np.asarray(te, float),
                np.asarray(err, float),
                color=f"C{i % 10}",
                lw=0.8,
                alpha=0.8,
                label=lab,
            )
        bx.set_xlabel("time [s]")
        bx.set_ylabel(errors_ylabel)
        bx.grid(alpha=0.3)
        bx.legend(fontsize=7, loc="best")
    return _save(fig, path, dpi)


# --------------------------------------------------------------------------- evaluation episodes
PUSH_STYLE = dict(color="tab:orange", alpha=0.2, lw=0)  # shading of a tip push
PAYLOAD_STYLE = dict(color="tab:brown", alpha=0.45, lw=0, ymin=0.0, ymax=0.05)  # band at the bottom
LIMIT_STYLE = dict(color="tab:red", ls=":", lw=1.2)  # the temperature-limit line
PUSH_LABEL = "tip push acting"
PAYLOAD_LABEL = "payload attached (mass in the title)"


def disturbance_windows(loads, duration: float) -> list[tuple[float, float, str, str]]:
    """The time spans of an episode's disturbances, from its load schedule.

    Args:
        loads: a :class:`~spine_gym.envs.loads.LoadSchedule` (or None: no disturbance): tip-force
            events with ``start``/``end`` [s] and ``force`` [N], ``payload`` [kg].
        duration: episode duration [s]; open-ended events are cut there.

    Returns:
        ``(start [s], end [s], kind, text)`` per window: kind ``"push"`` (text: the force's
        magnitude in N) or ``"payload"`` (the whole episode; text: the mass in g).
    """
    if loads is None:
        return []
    out = []
    for e in loads.tip_force_events:
        if e.start < duration:
            out.append((e.start, min(e.end, duration), "push", f"{math.hypot(*e.force):.2g} N"))
    if loads.payload > 0.0:
        out.append((0.0, duration, "payload", f"{1000.0 * loads.payload:.0f} g"))
    return out


def _shade_windows(ax, windows, *, text: bool) -> None:
    """Shade each window on ``ax`` (label: kind, for the legend); ``text``: print push forces."""
    for t0, t1, kind, txt in windows:
        if kind == "push":
            ax.axvspan(t0, t1, label=PUSH_LABEL, **PUSH_STYLE)
            if text:
                ax.text(0.5 * (t0 + t1), 0.98, txt, transform=ax.get_xaxis_transform(),
                        ha="center", va="top", fontsize=6, color="tab:orange")  # fmt: skip
        else:
            ax.axvspan(t0, t1, label=PAYLOAD_LABEL, **PAYLOAD_STYLE)


def _wire_names(n: int) -> list[str]:
    """right/left (planar), w0 … w3 (one module) or m1 w0 … (module 1 = bottom) for ``n`` wires."""
    if n == 2:
        return ["right", "left"]
    if n == 4:
        return [f"w{j}" for j in range(4)]
    return [f"m{j // 4 + 1} w{j % 4}" for j in range(n)]


# tracked components → (axis label, component names)
_TRACKED = {
    1: ("bending angle [deg]", ("",)),
    2: ("tip bending vector [deg]", ("b₁ ", "b₂ ")),
    3: ("tip position [mm]", ("x ", "y ", "z ")),
}


def _tracking_panel(ax, traj) -> list:
    """Target (dashed) and tracked (solid) components against time; returns their lines."""
    n = len(traj.time)
    tracked, target = traj.angle_deg.reshape(n, -1), traj.target_deg.reshape(n, -1)
    d = tracked.shape[1]
    names = _TRACKED.get(d, ("", tuple(f"{c} " for c in range(d))))[1]
    lines = []
    for c in range(d):
        lines += ax.plot(traj.time, target[:, c], "--", color=f"C{c}", lw=1, label=f"{names[c]}target")
        lines += ax.plot(traj.time, tracked[:, c], color=f"C{c}", lw=1.3, label=f"{names[c]}tracked")
    return lines


def _wire_panels(ax_v, ax_t, traj, temperature_limit: float) -> None:
    for w, lab in enumerate(_wire_names(traj.voltage.shape[1])):
        ax_v.plot(traj.time, traj.voltage[:, w], lw=1, color=f"C{w % 10}", label=lab)
        ax_t.plot(traj.time, traj.temperature[:, w], lw=1, color=f"C{w % 10}", label=lab)
    ax_t.axhline(temperature_limit, label=f"temperature limit {temperature_limit:.0f} K", **LIMIT_STYLE)
    ax_t.set_xlabel("time [s]")


def _unique_handles(axes) -> tuple[list, list[str]]:
    """Legend handles of several axes, one per label (first seen)."""
    seen: dict[str, Any] = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(lab, h)
    return list(seen.values()), list(seen)


def episode_figure(episodes: Sequence[tuple[str, Any, Any]], temperature_limit: float, *, title: str = ""):
    """The figure of :func:`plot_episodes` (Agg canvas), for callers that add to it or inspect it.

    Args:
        episodes: ``(name, trajectory, loads)`` per column: a
            :class:`~spine_gym.agents.metrics.Trajectory` and its load schedule (or None).
        temperature_limit: the env's wire temperature limit [K], drawn as a labelled line.
        title: figure title.

    Returns:
        A matplotlib Figure: rows tracking / voltage [V] / temperature [K], one column per episode;
        each axes carries its disturbance windows as labelled patches; the tracking legend sits
        in the first column, the wire and disturbance legends below the figure.
    """
    if not episodes:
        raise ValueError("episodes must hold at least one (name, trajectory, loads) entry")
    n = len(episodes)
    fig, axes = _figure(3, n, max(3.4 * n, 6.0), 7.6, sharex="col")
    for j, (name, traj, loads) in enumerate(episodes):
        windows = disturbance_windows(loads, float(traj.time[-1]))
        payload = [txt for *_, kind, txt in windows if kind == "payload"]
        axes[0, j].set_title(name + (f" (payload {payload[0]})" if payload else ""), fontsize=9)
        lines = _tracking_panel(axes[0, j], traj)
        _wire_panels(axes[1, j], axes[2, j], traj, temperature_limit)
        for row in range(3):
            _shade_windows(axes[row, j], windows, text=row == 0)
            axes[row, j].grid(alpha=0.3)
    label, _ = _TRACKED.get(len(lines) // 2, ("tracked quantity", ()))
    for row, ylabel in enumerate((label, "wire voltage [V]", "wire temperature [K]")):
        axes[row, 0].set_ylabel(ylabel)
    axes[0, n - 1].legend(handles=lines, fontsize=6, ncol=max(len(lines) // 2, 1), loc="best")
    handles, labels = _unique_handles(axes[1:].ravel())
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 6), fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_episodes(
    episodes: Sequence[tuple[str, Any, Any]],
    path: str | Path,
    *,
    temperature_limit: float,
    title: str = "",
    dpi: int = 80,
) -> Path:
    """Evaluation episodes side by side (see :func:`episode_figure`), written as one PNG.

    Args:
        episodes: ``(name, trajectory, loads)`` per column.
        path: the PNG file to write.
        temperature_limit: wire temperature limit [K].
        title: figure title.
        dpi: resolution of the PNG.

    Returns:
        The path written.
    """
    return _save(episode_figure(episodes, temperature_limit, title=title), path, dpi)
