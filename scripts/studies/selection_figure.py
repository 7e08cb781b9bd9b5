"""Draw a selection's scores: each candidate's RMSE and energy as ratios to the tuned PID's.

A study's figure, not part of the runtime: the candidates scored by
``python -m spine_gym.agents.selection ... --out scores.csv`` on validation episodes, the eligible
region (energy ≤ ``--max-energy`` × the PID's), the RMSE target (``--target`` × the PID's) and the
chosen model. Run it from the repository root.

Example::

    python scripts/studies/selection_figure.py docs/studies/ppo_hard_v2/scores.csv \\
        --chosen runs/hard_int2/ppo/SmaSpineHard-v2_1 --title SmaSpineHard-v2 \\
        --out docs/studies/ppo_hard_v2/selection.png
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path


def read_scores(path: Path) -> list[dict]:
    """The rows of a selection CSV (``model``, ``rmse_ratio``, ``energy_ratio``, ...; the PID's row too)."""
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def group_of(model: str) -> str:
    """The run a candidate belongs to: its run folder (a checkpoint's folder above ``checkpoints/``)."""
    p = Path(model)
    return str(p.parent.parent) if p.parent.name == "checkpoints" else str(p)


def draw(rows: list[dict], chosen: str, title: str, target: float, max_energy: float, out: Path) -> None:
    """Write the figure to ``out`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=120)
    candidates = [r for r in rows if r["model"] != "pid"]
    groups = sorted({group_of(r["model"]) for r in candidates})
    for g in groups:
        pts = [r for r in candidates if group_of(r["model"]) == g]
        energy, rmse = [float(r["energy_ratio"]) for r in pts], [float(r["rmse_ratio"]) for r in pts]
        ax.plot(energy, rmse, "o", label=g, alpha=0.8)
    best = next(r for r in candidates if r["model"] == chosen)
    ax.plot(float(best["energy_ratio"]), float(best["rmse_ratio"]), "k*", ms=16, label=f"chosen: {chosen}")
    ax.plot(1.0, 1.0, "ks", ms=8, label="tuned PID")
    ax.axvline(max_energy, color="grey", ls="--", lw=1, label=f"eligible: energy ≤ {max_energy:g} × PID")
    ax.axhline(target, color="tab:red", ls=":", lw=1, label=f"target: RMSE ≤ {target:g} × PID")
    ax.set_xlabel("energy per episode / PID's energy [-]")
    ax.set_ylabel("tracking RMSE / PID's RMSE [-]")
    ax.set_title(f"{title}: candidates on 20 validation episodes")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6, loc="upper right")
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scores", help="the selection's CSV")
    p.add_argument("--chosen", required=True, help="the chosen model, as in the CSV's model column")
    p.add_argument("--title", required=True, help="the figure's title (the env id)")
    p.add_argument("--target", type=float, default=0.8, help="RMSE target as a ratio to the PID's")
    p.add_argument("--max-energy", type=float, default=1.0, help="eligibility: energy ratio to the PID's")
    p.add_argument("--out", required=True, help="PNG file")
    args = p.parse_args(argv)
    rows = read_scores(Path(args.scores))
    if not any(r["model"] == args.chosen for r in rows):
        p.error(f"--chosen {args.chosen!r} is not a model of {args.scores}")
    draw(rows, args.chosen, args.title, args.target, args.max_energy, Path(args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
