"""Is an RMSE target of the hard group physically reachable? The oracle MPC's RMSE–energy trade-off on validation episodes.

A study, not part of the runtime: it informed the decision that a 0.7 × PID RMSE at ≤ the PID's
energy is not a ceiling the validation distributions allow a planner to reach, so the learned
policies were not held to it there (the page, table and figure: ``docs/studies/ceiling/``; the causal
planner's runs: ``docs/studies/causal_planner.md``). Run it from the repository root.

Example::

    python scripts/studies/ceiling.py --episodes 4 --w-energy 0.05 0.3 1 3 --out results/ceiling
    python scripts/studies/ceiling.py --oracle mpc_oracle_causal --distributions hard_like --w-energy 0.05 1

``--oracle mpc_oracle_causal`` sweeps the causal privileged planner instead (true state and plant,
the current load held over the horizon, the observed target preview; no future loads or targets);
``--target-preview 3`` gives the planner the 3-s preview the shipped policies observe (the PID keeps
the env's 1 s it was tuned with; the episodes are the same, the preview draws nothing).

The privileged ``mpc_oracle`` (true state, parameters, future targets and loads) runs the
validation episodes (reset seeds ``VALIDATION_SEED_BASE + i``, never the evaluation suite) of the
default training distribution and of the hard-like one (:data:`spine_gym.agents.scenarios.HARD_LIKE_KWARGS`)
at several energy weights ``w_energy`` of its cost; the tuned PID runs the same episodes. If no
weight reaches RMSE ≤ ``--target`` × the PID's at ≤ the PID's energy, no controller that plans
with this model and horizon does, and a learned policy (which sees less) is not expected to.

Written to ``--out``: ``ceiling.csv`` (one row per distribution and controller) and
``ceiling.png`` (RMSE / PID against energy / PID, the target's corner shaded).
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from tqdm import tqdm  # noqa: E402

from spine_gym.agents.runtime import (  # noqa: E402
    ORACLE_NAMES,
    build_controller,
    energy_weighted_oracle,
    make_env,
    validation_scores,
)
from spine_gym.agents.scenarios import HARD_LIKE_KWARGS  # noqa: E402

DISTRIBUTIONS = {"default": {}, "hard_like": HARD_LIKE_KWARGS}


def ceiling_rows(
    episodes: int,
    weights: list[float],
    distributions: list[str],
    duration: float | None = None,
    oracle: str = "mpc_oracle",
    target_preview: float | None = None,
) -> list[dict]:
    """PID and privileged-MPC scores (mean RMSE [deg], energy [J], ratios to the PID) per
    distribution (``duration``: episode length [s], default the env's 60 s; ``oracle``: one of
    :data:`spine_gym.agents.runtime.ORACLE_NAMES`; ``target_preview``: the MPC's env preview [s], default the env's)."""
    rows = []
    jobs = [(d, w) for d in distributions for w in [None, *weights]]
    ref = {}
    for dist, w in tqdm(jobs, desc="ceiling", unit="run"):
        kw = dict(DISTRIBUTIONS[dist]) | ({} if duration is None else {"episode_duration": float(duration)})
        if w is not None and target_preview is not None:
            kw["target_preview"] = float(target_preview)
        env = make_env(kw)
        ctrl = build_controller("pid", env) if w is None else energy_weighted_oracle(env, w, oracle)
        rmse, energy = validation_scores(ctrl, episodes, kw)
        env.close()
        if w is None:
            ref[dist] = (rmse, energy)
        r0, e0 = ref[dist]
        name = "pid" if w is None else f"{oracle} w_energy={w:g}"
        rows.append(
            {
                "distribution": dist,
                "controller": name,
                "w_energy": "" if w is None else w,
                "rmse_deg": round(rmse, 3),
                "energy_J": round(energy, 1),
                "rmse_ratio": round(rmse / r0, 3),
                "energy_ratio": round(energy / e0, 3),
            }
        )
        tqdm.write(f"{dist:<10s} {name:<28s} RMSE {rmse:6.2f} ({rmse / r0:4.2f} x PID)  energy {energy:6.1f} J ({energy / e0:4.2f} x PID)")
    return rows


def plot(rows: list[dict], target: float, path: Path, oracle: str = "mpc_oracle") -> None:
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.fill_between([0.0, 1.0], 0.0, target, color="tab:green", alpha=0.15, label=f"target (≤ {target} × RMSE, ≤ 1 × energy)")
    for dist, marker in zip(DISTRIBUTIONS, "os", strict=True):
        pts = [r for r in rows if r["distribution"] == dist and r["controller"] != "pid"]
        if not pts:
            continue
        ax.plot([r["energy_ratio"] for r in pts], [r["rmse_ratio"] for r in pts], marker=marker, label=f"{oracle}, {dist}")
        for r in pts:
            ax.annotate(f"w={r['w_energy']:g}", (r["energy_ratio"], r["rmse_ratio"]), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.plot([1.0], [1.0], "k*", ms=10, label="tuned PID")
    ax.set_xlabel("energy / PID's")
    ax.set_ylabel("RMSE / PID's")
    ax.set_xlim(0.5, 1.5)
    ax.set_ylim(0.4, 1.3)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"{oracle} on validation episodes (privileged ceiling)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> list[dict]:
    p = argparse.ArgumentParser(prog="python scripts/studies/ceiling.py", description=__doc__.split("\n")[0])
    p.add_argument("--episodes", type=int, default=4, help="validation episodes per run (default: %(default)s)")
    p.add_argument("--w-energy", type=float, nargs="+", default=[0.05, 0.3, 1.0, 3.0], help="oracle energy weights [1/J]")
    p.add_argument("--distributions", nargs="+", choices=list(DISTRIBUTIONS), default=list(DISTRIBUTIONS))
    p.add_argument(
        "--oracle",
        choices=ORACLE_NAMES,
        default="mpc_oracle",
        help="privileged MPC to sweep (default: %(default)s)",
    )
    p.add_argument(
        "--target-preview", type=float, default=None, help="the MPC's target preview [s] (default: the env's)"
    )
    p.add_argument(
        "--duration", type=float, default=None, help="episode length [s] (default: the env's 60 s)"
    )
    p.add_argument("--target", type=float, default=0.7, help="RMSE ratio of the target (default: %(default)s)")
    p.add_argument("--out", default="results/ceiling", help="output folder (default: %(default)s)")
    args = p.parse_args(argv)
    for w in args.w_energy:
        if not w >= 0.0:
            raise SystemExit(f"--w-energy must be >= 0, got {w}")
    rows = ceiling_rows(
        args.episodes, args.w_energy, args.distributions, args.duration, args.oracle, args.target_preview
    )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "ceiling.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot(rows, args.target, out / "ceiling.png", args.oracle)
    print(f"wrote {out / 'ceiling.csv'} and {out / 'ceiling.png'}")
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
