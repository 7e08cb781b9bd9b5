"""Benchmark RL algorithms on the spine envs at fixed step budgets, against the tuned PID and the MPC.

Example (``spine-gym benchmark`` is the same command)::

    python -m spine_gym.agents.benchmark --workers 2                 # every algorithm on the default env ids
    python -m spine_gym.agents.benchmark --quick --out /tmp/bench    # the smoke run of CI (under 2 min on 2 cores)
    python -m spine_gym.agents.benchmark --address HOST:6379         # one run per Ray task on a Ray cluster

Every algorithm of ``--algos`` (default PPO, SAC, TD3, TQC; the JAX learners CrossQ and DroQ of the ``jax``
extra when named) trains on every env id (default: the Easy and Hard tiers of ``-v1``; ``--envs v2``: of
``-v2``, whose plant cuts a hot wire for every method alike) with every seed, with the
hyperparameters of ``spine_gym/agents/hyperparams/{algo}.yml`` (the entry of the env id; its
``n_timesteps`` is the budget unless ``-n``/``--budget`` set one), built as
:mod:`spine_gym.agents.train` builds a run (:func:`~spine_gym.agents.training.resolve_config`,
:func:`~spine_gym.agents.training.build_envs`, :func:`~spine_gym.agents.training.build_model`). Every
``--eval-freq`` env steps (and at step 0 and at the budget) the policy runs the validation episodes:
the env's own sampled tasks with reset seeds ``VALIDATION_SEED_BASE + i`` (:func:`spine_gym.agents.runtime.validation_metrics`),
disjoint from the training seeds and from the evaluation suite's (``EVAL_SEED_BASE`` and above,
never used here). Recorded: the mean tracking RMSE (the env's unit: deg, or mm for the chain's tip
position), electrical energy [J] and time over the temperature limit [s] per episode, and the
training wall and CPU time (validation excluded).

The reference controllers (the tuned ``pid``, ``mpc_estimated``, ``mpc_oracle`` of
:func:`spine_gym.agents.registry.registry_for`) run the same validation episodes once per env id (the PID
all of them, the MPC the first ``--reference-episodes``); they are cached in the output folder.

The runs themselves (training, validation, the process pool and Ray) are
:mod:`spine_gym.agents.benchmark_run`; this module plans them, runs the references and writes the report.

Output folder (``--out``, default ``results/benchmark``):

* ``runs/<env id>/<algo>/seed_<k>/`` — ``curve.csv`` (one row per evaluation, appended as it
  comes), ``model.zip`` + ``vecnormalize.pkl`` + ``meta.json`` (loadable with
  :func:`spine_gym.agents.runtime.load_policy`), ``done.json`` (the run's settings and result; a run that
  has it is skipped on the next invocation, one without it starts over);
* ``records.tar.xz`` (a study's folder only) — its runs' records (``curve.csv``, ``meta.json``,
  ``done.json``) and ``references/`` as one archive (:mod:`spine_gym.agents.benchmark_records`),
  unpacked on start wherever a run folder or reference file is missing, so the study resumes from it;
* ``references/<env id>.json`` — the reference controllers' validation episodes;
* ``evaluations.csv`` (every evaluation of every finished run), ``learning_curves.csv`` (IQM and
  CI over seeds per evaluation), ``curves.png`` (one panel per env id);
* ``table.csv`` (per algorithm x env id: IQM and 95 % stratified bootstrap CI over seeds of the
  final validation metrics, from ``rliable``, and of the env steps to the PID's validation RMSE
  with the hardware time they stand for (steps × the control period: what a real spine would
  run); the references' means; the envelope and budget), ``runs.csv`` (per run: wall and CPU
  time, steps, and the steps, wall and CPU time to the PID's validation RMSE with the energy and
  time over the limit there: :func:`to_pid`), ``table.md`` (the constrained ranking first:
  :mod:`spine_gym.agents.benchmark_ranking`), ``table.png``, ``profiles.png`` (rliable's
  performance profiles over the env ids: accuracy relative to the PID, time over the limit);
  ``command.txt`` (every invocation).

``--address`` farms the runs out to a Ray cluster (``local``: a Ray instance started here with
``--workers`` CPUs; ``auto`` or ``HOST:PORT``: a running cluster), one run per Ray task of one CPU.
A task trains in a temporary folder of its node and returns the run folder's files as bytes; the
driver writes them into ``--out`` as a local run does (so the nodes need no shared file system).
Ray is imported only then: it is not a dependency of the ``rl`` extra.

``--quick`` is the same pipeline at toy size (two env ids, one seed, 512 steps, 3-s episodes, the
PID as the only reference): every code path in well under two minutes. Docs: docs/benchmark.md.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import shlex
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from tqdm import tqdm

from spine_gym.cli_conventions import (
    check_out_dir,
    ENV_IDS,
    Parser,
    add_env_kwargs,
    add_out,
    add_progress,
    add_workers,
    check_env_kwargs,
    module_prog,
    usage_errors,
)
from spine_gym.cli_conventions import env_id as env_id_type
from spine_gym.controllers.registry import registry_for
from spine_gym.envs import BENCHMARK_IDS, ENV_SPECS, config_of

from . import benchmark_ranking as ranking
from . import benchmark_stats as stats
from .benchmark_records import restore_records
from .benchmark_run import (
    CURVE_COLUMNS,
    DONE,
    RunSpec,
    check_finished,
    execute,
    read_curve,
    validation_means,
)
from .evaluation import write_csv
from .runtime import (
    MAX_VALIDATION_EPISODES,
    OBSERVATION_KWARGS,
    build_controller,
    make_env,
    validation_metrics,
)
from .training import resolve_config
from .zoo_config import ALGOS, JAX_ALGOS, SB3_ALGOS

#: ``--envs v1`` / ``--envs v2``: the Easy and Hard tiers of every family in that version (``-v2``: the
#: same tasks on a plant with the driver's thermal cut-off, the same protection for every method)
TIER_IDS = {
    f"v{v}": tuple(s.id for s in ENV_SPECS.values() if s.version == v and s.tier != "default") for v in (1, 2)
}
DEFAULT_ENV_IDS = BENCHMARK_IDS  # the Easy and Hard tiers of -v1 of every family (the shipped table's)
REFERENCES = ("pid", "mpc_estimated", "mpc_oracle")
SEEDS_PER_ALGO = {"ppo": 5}  # seeds of each algorithm by default; DEFAULT_SEEDS for the others
DEFAULT_SEEDS = 3

# flags whose default depends on --quick: normal default, quick default (a given flag wins over both)
DEFAULTS = {
    "n_seeds": ([], ["1"]),  # []: SEEDS_PER_ALGO
    "n_timesteps": (-1, 512),
    "n_envs": (-1, 2),
    "eval_freq": (10_000, 256),
    "val_episodes": (10, 2),
    "references": (REFERENCES, ("pid",)),
    "reference_episodes": (5, 2),
    "bootstrap_reps": (stats.BOOTSTRAP_REPS, 200),
}
QUICK_ENV_KWARGS = {"episode_duration": 3.0}
# --quick: updates small enough for a 512-step budget (the YAML's would not update at all)
QUICK_HYPERPARAMS = {
    "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 2},
    "sac": {"learning_starts": 64, "batch_size": 64, "gradient_steps": 1, "buffer_size": 5000},
    "td3": {"learning_starts": 64, "batch_size": 64, "gradient_steps": 1, "buffer_size": 5000},
    "tqc": {"learning_starts": 64, "batch_size": 64, "gradient_steps": 1, "buffer_size": 5000},
    "crossq": {"learning_starts": 64, "batch_size": 64, "gradient_steps": 1, "buffer_size": 5000},
    "droq": {"learning_starts": 64, "batch_size": 64, "gradient_steps": 1, "buffer_size": 5000},
    "sbx_sac": {"learning_starts": 64, "batch_size": 64, "gradient_steps": 1, "buffer_size": 5000, "train_freq": 1},
    "sbx_tqc": {"learning_starts": 64, "batch_size": 64, "gradient_steps": 1, "buffer_size": 5000, "train_freq": 1},
    "sbx_mbpo": {
        "learning_starts": 64, "batch_size": 64, "gradient_steps": 1, "buffer_size": 5000, "train_freq": 1,
        "model_train_freq": 128, "model_train_steps": 20, "rollout_batch_size": 64,
    },
}


# --------------------------------------------------------------------------- references
def reference_scores(
    env_id: str, names: tuple[str, ...], task_kwargs: dict, n_val: int, n_ref: int, out: Path, progress: bool = True
) -> dict[str, dict]:
    """Validation means of the reference controllers on ``env_id`` (the PID on ``n_val`` episodes,
    the others on the first ``n_ref``), from the cache ``out/references/<env id>.json`` when it
    holds them for the same settings."""
    path = Path(out) / "references" / f"{env_id}.json"
    cache = json.loads(path.read_text()) if path.exists() else {}
    kw = {k: v for k, v in task_kwargs.items() if k not in OBSERVATION_KWARGS}
    result = {}
    for name in names:
        settings = json.loads(json.dumps({"env_kwargs": kw, "n_episodes": n_val if name == "pid" else n_ref}))
        if cache.get(name, {}).get("settings") != settings:
            probe = make_env(kw, env_id=env_id)
            ctrl = build_controller(name, probe)
            probe.close()
            desc = f"  reference {name} on {env_id}" if progress else ""
            rows = validation_metrics(ctrl, settings["n_episodes"], kw, env_id, progress=desc)
            cache[name] = {"settings": settings, "episodes": rows, "means": validation_means(rows)}
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(cache, indent=2))
        result[name] = {**cache[name]["means"], "n_episodes": settings["n_episodes"]}
    return result


# --------------------------------------------------------------------------- report
#: what :func:`to_pid` adds to a run's record
TO_PID_KEYS = (
    "steps_to_pid", "wall_to_pid_s", "cpu_to_pid_s", "energy_ratio_at_pid", "time_over_limit_at_pid_s",
)  # fmt: skip


def to_pid(curve: dict[str, np.ndarray], pid: dict) -> dict:
    """A run's way to the PID's level (its validation RMSE ``pid["rmse"]``): the env steps, training
    wall and CPU time of its first evaluation at or below it
    (:func:`~spine_gym.agents.benchmark_stats.steps_to_level`), and its energy (× the PID's) and
    time over the temperature limit there; None cells if it never got there."""
    steps = stats.steps_to_level(curve["step"], curve["rmse"], pid["rmse"])
    if steps is None:
        return dict.fromkeys(TO_PID_KEYS)
    i = int(np.flatnonzero(curve["step"] == steps)[0])
    return {
        "steps_to_pid": steps,
        "wall_to_pid_s": float(curve["train_wall_s"][i]),
        "cpu_to_pid_s": float(curve["train_cpu_s"][i]),
        "energy_ratio_at_pid": float(curve["energy_J"][i] / pid["energy_J"]),
        "time_over_limit_at_pid_s": float(curve["time_over_limit_s"][i]),
    }


def finished_runs(out: Path, specs: list[RunSpec], references: dict) -> tuple[list[dict], dict, list[dict]]:
    """The finished runs among ``specs``: their records with the steps and wall time to the PID's
    validation RMSE, their curves ``{env id: {algo: [curve, ...]}}`` and every evaluation as a row."""
    runs, curves, evaluations = [], {}, []
    for spec in specs:
        done = out / spec.folder / DONE
        if not done.exists():
            continue
        record = json.loads(done.read_text())["record"]
        curve = read_curve(out / spec.folder / "curve.csv")
        runs.append({**record, **to_pid(curve, references[spec.env_id]["pid"])})
        curves.setdefault(spec.env_id, {}).setdefault(spec.algo, []).append(curve)
        for i in range(len(curve["step"])):
            evaluations.append({"env_id": spec.env_id, "algo": spec.algo, "seed": spec.seed,
                                **{k: float(curve[k][i]) for k in CURVE_COLUMNS}})  # fmt: skip
    return runs, curves, evaluations


def learning_curves(curves: list[dict], reps: int) -> dict[str, np.ndarray]:
    """IQM and CI over the runs ``curves`` (of one algorithm and env id) at each evaluation, for the
    RMSE and the energy."""
    n = min(len(c["step"]) for c in curves)  # equal for runs of one budget; guards a short one
    out = {"step": curves[0]["step"][:n]}
    for m in ("rmse", "energy_J"):
        iqm, low, high = stats.curve_intervals(np.array([c[m][:n] for c in curves]), reps=reps)
        out |= {f"{m}_iqm": iqm, f"{m}_ci_low": low, f"{m}_ci_high": high}
    return out


def write_report(out: Path, specs: list[RunSpec], references: dict, units: dict, reps: int) -> list[dict]:
    """Evaluations, learning curves (CSV, PNG) and the final table (CSV, Markdown, PNG) of the
    finished runs among ``specs``; returns the summary rows (empty if no run finished)."""
    runs, curves, evaluations = finished_runs(out, specs, references)
    if not runs:
        return []
    write_csv(out / "evaluations.csv", evaluations)
    write_csv(out / "runs.csv", runs)
    curve_rows, panels = [], {}
    for env_id, by_algo in curves.items():
        plotted = {}
        for algo, cs in by_algo.items():
            lc = learning_curves(cs, reps)
            plotted[algo] = {"steps": lc["step"], "iqm": lc["rmse_iqm"], "low": lc["rmse_ci_low"],
                             "high": lc["rmse_ci_high"], "n_runs": len(cs)}  # fmt: skip
            curve_rows += [
                {"env_id": env_id, "algo": algo, "n_runs": len(cs), **{k: float(v[i]) for k, v in lc.items()}}
                for i in range(len(lc["step"]))
            ]
        panels[env_id] = {"curves": plotted, "references": references[env_id], "unit": units[env_id]}
    stats.plot_curves(out / "curves.png", panels)
    write_csv(out / "learning_curves.csv", curve_rows)
    kwargs = {s.env_id: s.env_kwargs for s in specs}
    periods = {e: float(config_of(e, **kwargs[e]).control_period) for e in curves}
    refs = {k: v for k, v in references.items() if k in curves}
    summary = stats.summary_rows(runs, refs, reps=reps, control_periods=periods)
    summary = ranking.with_envelope(summary, kwargs)
    write_csv(out / "table.csv", summary)
    (out / "table.md").write_text(ranking.report_markdown(summary, runs, units))
    stats.plot_table(out / "table.png", summary, units)
    stats.plot_profiles(out / "profiles.png", runs, refs, reps=reps)
    return summary


# --------------------------------------------------------------------------- CLI
#: this command's name as ``python -m <module>`` (``spine-gym <command>`` passes its own ``prog``)
PROG = module_prog(__spec__.name)

EXAMPLES = """
spine-gym benchmark --workers 2                  # every algorithm on the default env ids
spine-gym benchmark --quick -o runs/bench      # the smoke run of CI
spine-gym benchmark --algos ppo sac --env SmaSpine-v1 --n-seeds 10 -n 200000
spine-gym benchmark --address HOST:6379          # one run per Ray task on a Ray cluster
"""


def env_ids_type(text: str) -> str:
    """argparse ``type`` of ``--envs``: a registered spine env id or a key of :data:`TIER_IDS`."""
    return text if text in TIER_IDS else env_id_type(text)


def expand_env_ids(items: list[str]) -> list[str]:
    """``--envs`` items with each :data:`TIER_IDS` key replaced by its ids, in order, once each."""
    return list(dict.fromkeys(i for item in items for i in TIER_IDS.get(item, (item,))))


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    p = Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES)
    p.add_argument(
        "--algos", nargs="+", choices=ALGOS, default=list(SB3_ALGOS),
        help=f"algorithms (default: {' '.join(SB3_ALGOS)}; the JAX learners {' '.join(JAX_ALGOS)} "
        "need the jax extra)",
    )  # fmt: skip
    p.add_argument(
        "--envs",
        "--env",
        nargs="+",
        type=env_ids_type,
        default=None,
        metavar="ID",
        help=f"env ids (default: {' '.join(DEFAULT_ENV_IDS)}; --quick: the first two), or v1 / v2: the Easy "
        f"and Hard tiers of that version (v2: {' '.join(TIER_IDS['v2'])}); any of: {', '.join(ENV_IDS)}",
    )
    p.add_argument(
        "--n-seeds",
        nargs="+",
        default=None,
        metavar="N|ALGO:N",
        help="seeds 0..N-1 per env id: N for every algorithm and/or ALGO:N for one "
        f"(default: ppo:{SEEDS_PER_ALGO['ppo']}, {DEFAULT_SEEDS} for the others; --quick: 1)",
    )
    p.add_argument(
        "-n",
        "--n-timesteps",
        type=int,
        default=None,
        help="step budget of every run (default: each YAML entry's n_timesteps)",
    )
    p.add_argument("--budget", nargs="+", default=[], metavar="ID:N", help="step budget per env id")
    p.add_argument("--n-envs", type=int, default=None, help="training sub-envs (default: the YAML's)")
    p.add_argument(
        "--eval-freq", type=int, default=None, help="env steps between evaluations (default 10000)"
    )
    p.add_argument(
        "--val-episodes", type=int, default=None, help="validation episodes per evaluation (default 10)"
    )
    p.add_argument(
        "--references",
        nargs="+",
        default=None,
        metavar="NAME",
        help=f"reference controllers (default: {' '.join(REFERENCES)}; the PID is always run)",
    )
    p.add_argument(
        "--reference-episodes",
        type=int,
        default=None,
        help="validation episodes of the MPC references, the first of the PID's (default 5)",
    )
    add_env_kwargs(
        p,
        help="env kwargs key=value (key:value also accepted) of training and validation "
        "(default: none; --quick: episode_duration=3.0)",
    )  # fmt: skip
    p.add_argument(
        "--bootstrap-reps", type=int, default=None, help="bootstrap resamples per CI (default 2000)"
    )
    add_workers(p, help="runs in parallel processes")
    p.add_argument(
        "--address",
        default=None,
        help="farm the runs out to a Ray cluster, one per task: 'auto', HOST:PORT, ray://HOST:PORT, or "
        "'local' (a Ray instance started here with --workers CPUs); needs Ray",
    )
    add_out(p, default="results/benchmark")
    add_progress(p)
    p.add_argument("--quick", action="store_true", help="toy sizes: every code path in under 2 minutes")
    p.add_argument(
        "--report-only",
        action="store_true",
        help="train nothing: write the table and curves of the runs of the plan that have finished",
    )
    return p


@dataclass
class Plan:
    """The validated settings of an invocation."""

    specs: list[RunSpec]
    env_ids: list[str]
    references: tuple[str, ...]
    task_kwargs: dict
    val_episodes: int
    reference_episodes: int
    bootstrap_reps: int
    units: dict[str, str]


def _settings(args: argparse.Namespace) -> dict:
    """Each quick-dependent flag: the given value, else the --quick or the normal default."""
    return {k: v if (v := getattr(args, k)) is not None else d[int(args.quick)] for k, d in DEFAULTS.items()}


def _positive(name: str, value: int, allow_default: bool = False) -> None:
    if not (value >= 1 or (allow_default and value == -1)):
        extra = " (or -1: the YAML's)" if allow_default else ""
        raise ValueError(f"{name} must be a positive integer{extra}, got {value}")


def _budgets(items: list[str], env_ids: list[str]) -> dict[str, int]:
    out = {}
    for item in items:
        env_id, sep, n = item.rpartition(":")
        if not sep or env_id not in env_ids or not n.isdigit() or int(n) < 1:
            raise ValueError(f"--budget takes ID:N with ID one of {env_ids} and N >= 1, got {item!r}")
        out[env_id] = int(n)
    return out


def seed_counts(items: list[str], algos: list[str]) -> dict[str, int]:
    """Seeds per algorithm from ``--n-seeds`` items (``N`` for all, ``ALGO:N`` for one; later items
    win); the defaults (:data:`SEEDS_PER_ALGO`, :data:`DEFAULT_SEEDS`) where none is given."""
    counts = {a: SEEDS_PER_ALGO.get(a, DEFAULT_SEEDS) for a in algos}
    for item in items:
        algo, sep, n = str(item).rpartition(":")
        if sep and algo not in ALGOS:
            raise ValueError(f"--n-seeds: unknown algorithm {algo!r} in {item!r}; choose from {list(ALGOS)}")
        try:
            value = int(n)
        except ValueError:
            value = 0
        if value < 1:
            raise ValueError(f"--n-seeds must be a positive integer or ALGO:N, got {item!r}")
        for a in [algo] if sep else algos:
            if a in counts:
                counts[a] = value
    return counts


ADDRESS = re.compile(r"local|auto|(ray://)?[\w.\-]+:\d{1,5}")


def _check_address(address: str | None, workers: int) -> None:
    if address is None:
        return
    if not ADDRESS.fullmatch(address):
        raise ValueError(f"--address takes local, auto, HOST:PORT or ray://HOST:PORT, got {address!r}")
    if address != "local" and workers != 1:
        raise ValueError("--workers sets the CPUs of --address local; a cluster runs one run per CPU it has")
    if importlib.util.find_spec("ray") is None:
        raise ValueError("--address needs Ray, which is not installed: pip install 'ray[default]'")


def make_plan(args: argparse.Namespace) -> Plan:
    """Validate the arguments and list the runs; ValueError (one line) on anything invalid, before
    any file is written."""
    s = _settings(args)
    env_ids = expand_env_ids(args.envs) if args.envs else list(DEFAULT_ENV_IDS[: 2 if args.quick else None])
    unknown = [e for e in env_ids if e not in gym.envs.registry]
    if unknown:
        raise ValueError(
            f"unknown env id(s) {unknown}; registered spine envs: "
            f"{sorted(i for i in gym.envs.registry if 'Spine' in i)}"
        )
    seeds = seed_counts(s["n_seeds"], args.algos)
    for name in ("eval_freq", "val_episodes", "reference_episodes", "bootstrap_reps"):
        _positive(f"--{name.replace('_', '-')}", s[name])
    _positive("--workers", args.workers)
    _check_address(args.address, args.workers)
    _positive("-n/--n-timesteps", s["n_timesteps"], allow_default=True)
    _positive("--n-envs", s["n_envs"], allow_default=True)
    if s["val_episodes"] > MAX_VALIDATION_EPISODES:
        raise ValueError(f"--val-episodes must be <= {MAX_VALIDATION_EPISODES}, got {s['val_episodes']}")
    if s["reference_episodes"] > s["val_episodes"]:
        raise ValueError(
            f"--reference-episodes must be <= --val-episodes ({s['val_episodes']}), "
            f"got {s['reference_episodes']}"
        )
    if s["bootstrap_reps"] < 100:
        raise ValueError(f"--bootstrap-reps must be >= 100, got {s['bootstrap_reps']}")
    budgets = _budgets(args.budget, env_ids)
    references = tuple(dict.fromkeys(("pid", *s["references"])))
    task_kwargs = dict(QUICK_ENV_KWARGS if args.quick else {}) | dict(args.env_kwargs or {})
    units, specs = {}, []
    for env_id in env_ids:
        table = registry_for(env_id)
        missing = [r for r in references if r not in table]
        if missing:
            raise ValueError(f"unknown reference(s) {missing} for {env_id}; choose from {sorted(table)}")
        check_env_kwargs(env_id, task_kwargs)
        try:
            units[env_id] = config_of(env_id, **task_kwargs).table().task.unit
        except TypeError as e:
            raise ValueError(f"--env-kwargs not accepted by {env_id}: {e}") from None
        for algo in args.algos:
            hyperparams = dict(QUICK_HYPERPARAMS[algo]) if args.quick else {}
            n = budgets.get(env_id, s["n_timesteps"])
            cfg = resolve_config(algo, env_id, n_envs=s["n_envs"], n_timesteps=n, hyperparams=hyperparams)
            specs += [
                RunSpec(
                    algo,
                    env_id,
                    seed,
                    cfg.n_timesteps,
                    s["n_envs"],
                    s["eval_freq"],
                    s["val_episodes"],
                    dict(task_kwargs),
                    hyperparams,
                )  # fmt: skip
                for seed in range(seeds[algo])
            ]
    return Plan(specs, env_ids, references, task_kwargs, s["val_episodes"], s["reference_episodes"],
                s["bootstrap_reps"], units)  # fmt: skip


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """Run the CLI; exit status 0 (the summary rows are ``table.csv``, :func:`write_report` returns
    them). Usage errors exit with status 2 before any folder is made."""
    t_start = time.perf_counter()
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    out = Path(args.out)
    with usage_errors(parser):
        check_out_dir(out)
        plan = make_plan(args)
        restore_records(out)  # the runs of out/records.tar.xz, if any, resume as run folders
        check_finished(plan.specs, out)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    torch.set_num_threads(1)
    out.mkdir(parents=True, exist_ok=True)
    argv = sys.argv[1:] if argv is None else list(argv)
    with open(out / "command.txt", "a") as f:
        f.write(f"{PROG} " + " ".join(shlex.quote(a) for a in argv) + "\n")
    references = {
        env_id: reference_scores(
            env_id, plan.references, plan.task_kwargs, plan.val_episodes, plan.reference_episodes, out,
            progress=args.progress,
        )  # fmt: skip
        for env_id in plan.env_ids
    }
    for env_id, refs in references.items():
        line = ", ".join(f"{n} {r['rmse']:.2f} {plan.units[env_id]}" for n, r in refs.items())
        print(f"references on {env_id}: {line}", flush=True)
    pending = [] if args.report_only else [s for s in plan.specs if not (out / s.folder / DONE).exists()]
    where = f"on Ray ({args.address})" if args.address else f"with {args.workers} worker(s)"
    print(f"{len(plan.specs)} runs, {len(plan.specs) - len(pending)} finished before (skipped), "
          f"{len(pending)} to run {where}", flush=True)  # fmt: skip
    failed = []
    with tqdm(total=len(pending), desc="runs", unit="run", disable=not (pending and args.progress)) as bar:
        for spec, record, error in execute(pending, out, args.workers, args.address if pending else None, args.progress):
            bar.update(1)
            if record is None:
                failed.append(spec.label)
                tqdm.write(f"FAILED {spec.label}: {error}")
            else:
                tqdm.write(
                    f"{spec.label}: RMSE {record['final_rmse']:.2f} {plan.units[spec.env_id]} after "
                    f"{record['steps']:,} steps in {stats.duration(record['wall_s'])}"
                )
    summary = write_report(out, plan.specs, references, plan.units, plan.bootstrap_reps)
    if summary:
        print((out / "table.md").read_text())
    print(f"wrote the table and curves to {out} ({time.perf_counter() - t_start:.0f} s in all)")
    if failed:
        raise SystemExit(f"{len(failed)} run(s) failed: {', '.join(failed)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
