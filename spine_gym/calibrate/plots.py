"""PNG plots of a fit: measured vs start/fitted traces with residuals, and the correlation matrix.

Drawn like :mod:`spine_gym.plotting` (Agg canvas, object API, matplotlib imported only when a plot
is made).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..plotting import _figure, _save
from .data import Experiment, Samples

__all__ = ["plot_experiment_fit", "plot_correlation"]


FIT_COLUMNS = 3  # channels per row of a fit figure (a 4-wire experiment's 10 stay readable at page width)


def plot_experiment_fit(exp: Experiment | Samples, traces: dict, path: str | Path, dpi: int = 120) -> Path:
    """One panel pair per measured channel, :data:`FIT_COLUMNS` to a row: traces on top, residual
    (fitted − measured) below."""
    chans = list(traces)
    ncols = min(len(chans), FIT_COLUMNS)
    nrows = -(-len(chans) // ncols)
    fig, axs = _figure(
        2 * nrows, ncols, 4.8 * ncols, 5.6 * nrows, sharex=True, height_ratios=[3, 1.3] * nrows
    )
    t = exp.time - exp.time[0]
    for k in range(nrows * ncols):
        ax, axr = axs[2 * (k // ncols), k % ncols], axs[2 * (k // ncols) + 1, k % ncols]
        if k >= len(chans):
            ax.set_visible(False)
            axr.set_visible(False)
            continue
        c = chans[k]
        unit = exp.unit(c)
        tr = traces[c]
        ax.plot(t, tr["measured"], ".", ms=2, color="0.55", label="measured")
        ax.plot(t, tr["start"], "--", color="tab:orange", lw=1.2, label="start")
        ax.plot(t, tr["fitted"], "-", color="tab:blue", lw=1.5, label="fitted")
        ax.set_ylabel(f"{c} [{unit}]")
        ax.set_title(f"{Path(exp.name).name}: {c}", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        res = tr["fitted"] - tr["measured"]
        axr.plot(t, res, ".", ms=2, color="tab:blue")
        axr.axhline(0.0, color="k", lw=0.8)
        for s in (-2, 2):
            axr.axhline(s * exp.noise[c], color="tab:red", lw=0.8, ls=":")
        axr.set_ylabel(f"residual [{unit}]")
        axr.set_xlabel("time [s]")
        axr.tick_params(labelbottom=True)  # every row of panels keeps its time axis
        axr.grid(alpha=0.3)
    return _save(fig, path, dpi)


def plot_correlation(
    names: Sequence[str], corr: np.ndarray, identified, path: str | Path, dpi: int = 120
) -> Path:
    """Heat map of the parameter correlation matrix; unidentified parameters marked with '?'."""
    n = len(names)
    fig, axs = _figure(1, 1, 1.0 + 0.9 * n, 0.6 + 0.8 * n)
    ax = axs[0, 0]
    im = ax.imshow(corr, vmin=-1.0, vmax=1.0, cmap="RdBu_r")
    labels = [nm if ok else f"{nm} (?)" for nm, ok in zip(names, identified, strict=True)]
    ax.set_xticks(range(n), labels, rotation=45, ha="right", fontsize=8)
    ax.set_yticks(range(n), labels, fontsize=8)
    for i in range(n):
        for j in range(n):
            colour = "w" if abs(corr[i, j]) > 0.6 else "k"  # readable on the dark ends of the map
            ax.text(j, i, f"{corr[i, j]:+.2f}", ha="center", va="center", fontsize=7, color=colour)
    fig.colorbar(im, ax=ax, shrink=0.8, label="correlation")
    ax.set_title("parameter correlations ((?) = not identified)", fontsize=9)
    return _save(fig, path, dpi)
