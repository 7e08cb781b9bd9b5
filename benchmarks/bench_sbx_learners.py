"""Benchmark: the JAX learners (``sbx-rl``, the ``jax`` extra) in env steps to the PID's validation
RMSE and in CPU time per 60 k env steps, on tuning seeds.

Each algorithm of ``--algos`` trains on each env id of ``--envs`` with each tuning seed of ``--seeds``
(default 100 and 101: not the benchmark's 0-4) for ``-n`` env steps, with its
``spine_gym/agents/hyperparams/<algo>.yml`` entry, one thread (run through a 1-thread launcher; JAX
on one thread, :mod:`spine_gym.agents.jax_algos`). The runs are the benchmark's own
(:func:`spine_gym.agents.benchmark_run.run_one`: validation episodes every ``--eval-freq`` steps,
training wall and CPU time without the validation), so the curves are the benchmark's curves.

Per run: the env steps (and hardware time: steps x control period) of the first validation whose
RMSE is at or below the tuned PID's on the same validation episodes, the energy ratio to the PID's
at that evaluation, and the training CPU time scaled to 60 k env steps (the CPU of the first
2 000-step warm-up, JAX's compilation included, is in it).

Writes ``benchmarks/results/sbx_learners/``: ``runs/<env id>/<algo>/seed_<k>/curve.csv`` (every
evaluation; ``done.json`` marks a finished run, which a second invocation skips), ``references/``
(the PID's validation episodes), ``summary.csv`` / ``summary.md`` (one row per run), ``evaluations.csv``
(every evaluation of every run: the curves, kept in the repository where ``runs/`` is not), ``command.txt``.

    OMP_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_sbx_learners.py --algos crossq droq -n 40000
"""

from __future__ import annotations

import argparse
import csv
import json
import shlex
import sys
from pathlib import Path

from spine_gym.agents.benchmark import reference_scores
from spine_gym.agents.benchmark_run import CURVE_COLUMNS, DONE, RunSpec, read_curve, run_one
from spine_gym.agents.benchmark_stats import time_to_level
from spine_gym.cli_conventions import KeyValues
from spine_gym.envs import config_of

OUT = Path(__file__).parent / "results" / "sbx_learners"
ENVS = ("SmaSpineEasy-v2", "SmaSpine3DEasy-v2")
COLUMNS = (
    "algo", "env_id", "seed", "steps", "cpu_s", "cpu_s_per_60k", "pid_rmse", "best_rmse", "final_rmse",
    "steps_to_pid", "hardware_min_to_pid", "energy_ratio_at_pid", "final_energy_ratio",
)  # fmt: skip


def run_row(spec: RunSpec, out: Path, pid: dict, control_period: float) -> dict:
    """The summary row of the finished run ``spec`` against the PID's validation means ``pid``."""
    record = json.loads((out / spec.folder / DONE).read_text())["record"]
    curve = read_curve(out / spec.folder / "curve.csv")
    steps, _ = time_to_level(curve["step"], curve["train_wall_s"], curve["rmse"], pid["rmse"])
    at = None if steps is None else list(curve["step"]).index(steps)
    energy_at = None if at is None else float(curve["energy_J"][at] / pid["energy_J"])
    return {
        "algo": spec.algo,
        "env_id": spec.env_id,
        "seed": spec.seed,
        "steps": record["steps"],
        "cpu_s": round(record["cpu_s"], 1),
        "cpu_s_per_60k": round(record["cpu_s"] * 60_000 / record["steps"], 1),
        "pid_rmse": round(pid["rmse"], 3),
        "best_rmse": round(float(min(curve["rmse"])), 3),
        "final_rmse": round(float(curve["rmse"][-1]), 3),
        "steps_to_pid": steps,
        "hardware_min_to_pid": None if steps is None else round(steps * control_period / 60, 1),
        "energy_ratio_at_pid": None if energy_at is None else round(energy_at, 3),
        "final_energy_ratio": round(float(curve["energy_J"][-1]) / pid["energy_J"], 3),
    }


def curve_rows(spec: RunSpec, out: Path) -> list[dict]:
    """Every evaluation of the finished run ``spec``, as rows of ``evaluations.csv``."""
    curve = read_curve(out / spec.folder / "curve.csv")
    run = {"algo": spec.algo, "env_id": spec.env_id, "seed": spec.seed}
    return [run | {k: float(curve[k][i]) for k in CURVE_COLUMNS} for i in range(len(curve["step"]))]


def write_summary(rows: list[dict], evaluations: list[dict], out: Path) -> None:
    """``summary.csv`` / ``summary.md`` (one row per run) and ``evaluations.csv`` (the runs' curves:
    the run folders themselves are not kept in the repository)."""
    with open(out / "evaluations.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["algo", "env_id", "seed", *CURVE_COLUMNS])
        w.writeheader()
        w.writerows(evaluations)
    with open(out / "summary.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join("—" if r[c] is None else str(r[c]) for c in COLUMNS) + " |" for r in rows]
    (out / "summary.md").write_text("\n".join(lines) + "\n")


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--algos", nargs="+", default=["crossq"])
    p.add_argument("--envs", nargs="+", default=list(ENVS))
    p.add_argument("--seeds", nargs="+", type=int, default=[100, 101])
    p.add_argument("-n", "--n-timesteps", type=int, default=40_000)
    p.add_argument("--eval-freq", type=int, default=4_000)
    p.add_argument("--val-episodes", type=int, default=10)
    p.add_argument("--out", type=Path, default=OUT)
    p.add_argument(
        "-params", "--hyperparams", nargs="+", action=KeyValues, default={}, metavar="KEY=VALUE",
        help="overrides of the YAML entries (a variant: give it its own --out)",
    )  # fmt: skip
    args = p.parse_args(argv)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "command.txt", "a") as f:
        f.write("python " + shlex.join(["benchmarks/bench_sbx_learners.py", *sys.argv[1:]]) + "\n")
    for env_id in args.envs:
        reference_scores(env_id, ("pid",), {}, args.val_episodes, 1, out)
        for algo in args.algos:
            for seed in args.seeds:
                spec = RunSpec(
                    algo, env_id, seed, args.n_timesteps, -1, args.eval_freq, args.val_episodes,
                    hyperparams=dict(args.hyperparams),
                )  # fmt: skip
                run_one(spec, out)
                write_all_summaries(out)


def write_all_summaries(out: Path) -> None:
    """The summaries of every finished run under ``out`` (this and earlier invocations), printing the
    newest run's row."""
    rows, evaluations, newest = [], [], (0.0, None)
    fields = set(RunSpec.__dataclass_fields__)
    for done in sorted((out / "runs").glob(f"*/*/seed_*/{DONE}")):
        settings = json.loads(done.read_text())["settings"]
        spec = RunSpec(**{k: v for k, v in settings.items() if k in fields})
        pid = json.loads((out / "references" / f"{spec.env_id}.json").read_text())["pid"]["means"]
        rows.append(run_row(spec, out, pid, float(config_of(spec.env_id).control_period)))
        evaluations += curve_rows(spec, out)
        newest = max(newest, (done.stat().st_mtime, len(rows) - 1), key=lambda t: t[0])
    write_summary(rows, evaluations, out)
    if newest[1] is not None:
        print(json.dumps(rows[newest[1]]), flush=True)

if __name__ == "__main__":
    main()
