"""Study: PPO's learner throughput vs its sample efficiency on the -v1 tier ids, on tuning seeds.

PPO spends most of its wall time in SGD when it makes many gradient steps per rollout: 10 epochs of
minibatch 256 over each 2 048-sample rollout are 80. This study trains each candidate override of
the ``-v1`` entry (``spine_gym/agents/hyperparams/ppo.yml``) on every benchmark id
(``spine_gym.envs.BENCHMARK_IDS``, or ``--envs``) with the tuning seeds ``--seeds`` (default 100
and 101, never the benchmark's seeds 0-4), validates every ``--eval-freq`` steps on the benchmark's validation
episodes (reset seeds 500 000+, :mod:`spine_gym.agents.benchmark`; the evaluation suite is never
touched) and reports, per candidate and id, the median training wall time and steps to the tuned
PID's validation RMSE and the final RMSE and energy as ratios to the PID's. Each run is one
:func:`spine_gym.agents.benchmark_run.run_one`, so runs are resumable (finished ones are skipped) and
measured exactly as the benchmark measures them (validation time excluded, torch on one thread).

    PYTHONPATH=$PWD .venv/bin/python benchmarks/tune_ppo_v1.py --workers 2 \
        --candidates batch256_epochs10 epochs5 batch512 batch512_epochs5
    PYTHONPATH=$PWD .venv/bin/python benchmarks/tune_ppo_v1.py --workers 2 --envs SmaSpine3DHard-v1 \
        --candidates batch512_epochs5_envs16 batch512_epochs5_lr6e-4 batch512_epochs5_envs32 \
        batch1024_epochs5_envs16 batch512_epochs5_envs16_steps64 batch512_epochs5_envs16_steps32

Writes ``benchmarks/results/ppo_v1_tuning/`` (the run folders, ``summary.csv`` and ``README.md`` with
the table); the runs' records are kept there as ``records.tar.xz``
(:mod:`spine_gym.agents.benchmark_records`), unpacked on start, so ``--summary-only`` rewrites the
summary from them.
The PID's validation scores are read from the benchmark's reference cache
(``benchmarks/results/rl_benchmark/references``, unpacked from that study's ``records.tar.xz``),
computed there if missing.
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing
import statistics
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import torch

from spine_gym.agents import benchmark_stats as stats
from spine_gym.agents.benchmark import reference_scores
from spine_gym.agents.benchmark_records import restore_records, restore_references
from spine_gym.agents.benchmark_run import RunSpec, read_curve, run_one
from spine_gym.agents.training import resolve_config
from spine_gym.envs import BENCHMARK_IDS

ROOT = Path(__file__).resolve().parent
OUT = ROOT / "results" / "ppo_v1_tuning"
REFERENCES = ROOT / "results" / "rl_benchmark"
VAL_EPISODES = 10  # the benchmark's default

# name -> overrides of the shipped -v1 entry; gradient steps per 2 048-sample rollout in the comment
CANDIDATES = {
    "batch256_epochs10": {"batch_size": 256, "n_epochs": 10},  # 80: the -v1 entry before this study
    "epochs5": {"n_epochs": 5},  # 40
    "batch512": {"batch_size": 512},  # 40
    "batch512_epochs5": {"batch_size": 512, "n_epochs": 5},  # 20
    # the chosen setting with twice the sub-envs (same 2 048-sample rollout), or twice the step size
    "batch512_epochs5_envs16": {"batch_size": 512, "n_epochs": 5, "n_envs": 16, "n_steps": 128},
    "batch512_epochs5_lr6e-4": {"batch_size": 512, "n_epochs": 5, "learning_rate": 6e-4},
    # more sub-envs again (fewer policy calls per env step), or half the gradient steps at 16
    "batch512_epochs5_envs32": {"batch_size": 512, "n_epochs": 5, "n_envs": 32, "n_steps": 64},
    "batch1024_epochs5_envs16": {"batch_size": 1024, "n_epochs": 5, "n_envs": 16, "n_steps": 128},  # 10
    # 16 sub-envs with half the rollout (1 024 samples): as many gradient steps per sample, twice the updates
    "batch512_epochs5_envs16_steps64": {"batch_size": 512, "n_epochs": 5, "n_envs": 16, "n_steps": 64},
    "batch512_epochs5_envs16_steps32": {"batch_size": 512, "n_epochs": 5, "n_envs": 16, "n_steps": 32},  # 5 per 512
}


def _worker_init() -> None:
    torch.set_num_threads(1)


def plan(names: list[str], seeds: list[int], eval_freq: int, env_ids: list[str]) -> list[tuple[str, RunSpec]]:
    """Every (candidate, run) pair, seed by seed, so that a partial study covers every candidate."""
    out = []
    for seed in seeds:
        for env_id in env_ids:
            n = resolve_config("ppo", env_id).n_timesteps
            for name in names:
                hp = dict(CANDIDATES[name])
                out.append((name, RunSpec("ppo", env_id, seed, n, -1, eval_freq, VAL_EPISODES, {}, hp)))
    return out


def run(runs: list[tuple[str, RunSpec]], workers: int) -> None:
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_worker_init) as pool:
        futures = {pool.submit(run_one, spec, OUT / name): (name, spec) for name, spec in runs}
        for i, fut in enumerate(as_completed(futures), 1):
            name, spec = futures[fut]
            rec = fut.result()
            print(f"[{i}/{len(runs)}] {name:18s} {spec.label}: {rec['wall_s']:.0f} s, "
                  f"final RMSE {rec['final_rmse']:.2f}", flush=True)  # fmt: skip


def summarise(runs: list[tuple[str, RunSpec]]) -> list[dict]:
    pid = {e: reference_scores(e, ("pid",), {}, VAL_EPISODES, 5, REFERENCES)["pid"] for e in BENCHMARK_IDS}
    groups: dict[tuple[str, str], list[dict]] = {}
    for name, spec in runs:
        folder = OUT / name / spec.folder
        if not (folder / "done.json").exists():
            continue
        c = read_curve(folder / "curve.csv")
        ref = pid[spec.env_id]
        steps, wall = stats.time_to_level(c["step"], c["train_wall_s"], c["rmse"], ref["rmse"])
        _, cpu = stats.time_to_level(c["step"], c["train_cpu_s"], c["rmse"], ref["rmse"])
        groups.setdefault((name, spec.env_id), []).append({
            "steps": steps, "wall": wall, "cpu": cpu, "total_wall": float(c["train_wall_s"][-1]),
            "rmse_ratio": float(c["rmse"][-1]) / ref["rmse"],
            "energy_ratio": float(c["energy_J"][-1]) / ref["energy_J"],
        })  # fmt: skip
    rows = []
    for (name, env_id), g in groups.items():
        reached = [r for r in g if r["wall"] is not None]
        # a run that never reached the PID counts as infinitely slow in the median
        walls = sorted(r["wall"] if r["wall"] is not None else float("inf") for r in g)
        cpus = sorted(r["cpu"] if r["cpu"] is not None else float("inf") for r in g)
        rows.append({
            "candidate": name, "env_id": env_id, "runs": len(g), "reached": len(reached),
            "median_wall_to_pid_s": statistics.median(walls),
            "median_cpu_to_pid_s": statistics.median(cpus),
            "median_steps_to_pid": statistics.median(sorted(r["steps"] or float("inf") for r in g)),
            "mean_total_wall_s": statistics.mean(r["total_wall"] for r in g),
            "mean_final_rmse_ratio": statistics.mean(r["rmse_ratio"] for r in g),
            "mean_final_energy_ratio": statistics.mean(r["energy_ratio"] for r in g),
        })  # fmt: skip
    return rows


#: the head of the study's README.md, above the table :func:`write` puts under it
README_HEAD = """# PPO's -v1 entry: learner throughput vs sample efficiency

Written by `benchmarks/tune_ppo_v1.py` (its docstring gives the two commands; the candidates are
overrides of the `-v1` entry of `spine_gym/agents/hyperparams/ppo.yml`), on the tuning seeds 100 and
101, validated on the benchmark's validation episodes against the PID of
`../rl_benchmark/references/` (in `../rl_benchmark/records.tar.xz`, unpacked by
the script). What it chose and why: `benchmarks/README.md` and `docs/results.md`.

* the table below / `summary.csv` — per candidate × env id: runs that reached the PID's validation
  RMSE, median wall, CPU time and steps to it, mean total wall time, final RMSE and energy over the PID's.
* `records.tar.xz` — every run's record (`<candidate>/runs/<env id>/ppo/seed_<k>/`: `curve.csv`,
  `done.json`, `meta.json`; no models), unpacked on start by the script wherever a run folder is
  missing; `python benchmarks/tune_ppo_v1.py --summary-only` rewrites this page and `summary.csv` from it
  (byte-identical). After new runs: `pack_records('benchmarks/results/ppo_v1_tuning')` of
  `spine_gym.agents.benchmark_records`. An archive in the tree, as for the RL benchmark
  (`../rl_benchmark/README.md` says why).

## The candidates
"""


def write(rows: list[dict]) -> None:
    if not rows:
        return
    with open(OUT / "summary.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        "| candidate | env id | reached PID | median wall to PID | median CPU to PID | median steps to PID | "
        "total wall (mean) | final RMSE / PID | final energy / PID |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in sorted(rows, key=lambda r: (r["env_id"], r["candidate"])):
        lines.append(
            f"| {r['candidate']} | {r['env_id']} | {r['reached']}/{r['runs']} | "
            f"{r['median_wall_to_pid_s']:.1f} s | {r['median_cpu_to_pid_s']:.1f} s | "
            f"{r['median_steps_to_pid']:,.0f} | {r['mean_total_wall_s']:.0f} s | "
            f"{r['mean_final_rmse_ratio']:.2f} | "
            f"{r['mean_final_energy_ratio']:.2f} |"
        )  # fmt: skip
    (OUT / "README.md").write_text(README_HEAD + "\n" + "\n".join(lines) + "\n")
    print("\n".join(lines))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--candidates", nargs="+", choices=list(CANDIDATES), default=list(CANDIDATES))
    p.add_argument("--seeds", nargs="+", type=int, default=[100, 101], help="tuning seeds (not 0-4)")
    p.add_argument("--eval-freq", type=int, default=10_000, help="env steps between validations")
    p.add_argument("--envs", nargs="+", choices=BENCHMARK_IDS, default=list(BENCHMARK_IDS), help="env ids")
    p.add_argument("--workers", type=int, default=2, help="runs in parallel processes")
    p.add_argument("--summary-only", action="store_true", help="train nothing; summarise finished runs")
    args = p.parse_args()
    if any(0 <= s < 5 for s in args.seeds):
        p.error(f"--seeds must avoid the benchmark's seeds 0-4, got {args.seeds}")
    runs = plan(args.candidates, args.seeds, args.eval_freq, args.envs)
    restore_records(OUT)  # the study's runs of records.tar.xz, as run folders
    restore_references(REFERENCES)  # the benchmark's references/*.json of its records.tar.xz
    if not args.summary_only:
        run(runs, args.workers)
    write(summarise(runs))


if __name__ == "__main__":
    main()
