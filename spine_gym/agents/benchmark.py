"""Benchmark RL algorithms on the spine envs at fixed step budgets, against the tuned PID and the MPC.

Example (``spine-gym benchmark`` is the same command)::

    python -m spine_gym.agents.benchmark --workers 2                 # every algorithm on the default env ids
    python -m spine_gym.agents.benchmark --quick --out /tmp/bench    # the smoke run of CI (under 2 min on 2 cores)
    python -m spine_gym.agents.benchmark --address HOST:6379         # one run per Ray task on a Ray cluster

Every algorithm (PPO, SAC, TD3, TQC) trains on every env id with every seed, with the
hyperparameters of ``spine_gym/agents/hyperparams/{algo}.yml`` (the entry of the env id; its
``n_timesteps`` is the budget unless ``-n``/``--budget`` set one), through
:mod:`spine_gym.agents.train`'s own construction (:func:`~spine_gym.agents.training.resolve_config`,
:func:`~spine_gym.agents.training.build_envs`, :func:`~spine_gym.agents.training.build_model`). Every ``--eval-freq`` env
steps (and at step 0 and at the budget) the policy runs the validation episodes: the env's own
sampled tasks with reset seeds ``VALIDATION_SEED_BASE + i`` (:func:`spine_gym.agents.runtime.validation_metrics`),
disjoint from the training seeds and from the evaluation suite's (``EVAL_SEED_BASE`` and above,
never used here). Recorded: the mean tracking RMSE (the env's unit: deg, or mm for the chain's tip
position), electrical energy [J] and time over the temperature limit [s] per episode, and the
training wall and CPU time (validation excluded).

The reference controllers (the tuned ``pid``, ``mpc_estimated``, ``mpc_oracle`` of
:func:`spine_gym.agents.registry.registry_for`) run the same validation episodes once per env id (the PID
all of them, the MPC the first ``--reference-episodes``); they are cached in the output folder.

Output folder (``--out``, default ``results/benchmark``):

* ``runs/<env id>/<algo>/seed_<k>/`` — ``curve.csv`` (one row per evaluation, appended as it
  comes), ``model.zip`` + ``vecnormalize.pkl`` + ``meta.json`` (loadable with
  :func:`spine_gym.agents.runtime.load_policy`), ``done.json`` (the run's settings and result; a run that
  has it is skipped on the next invocation, one without it starts over);
* ``references/<env id>.json`` — the reference controllers' validation episodes;
* ``evaluations.csv`` (every evaluation of every finished run), ``learning_curves.csv`` (IQM and
  CI over seeds per evaluation), ``curves_<env id>.png``;
* ``table.csv`` (per algorithm x env id: IQM and 95 % stratified bootstrap CI over seeds of the
  final validation metrics, from ``rliable``; the references' means), ``runs.csv`` (per run: wall
  and CPU time, steps, steps and wall time to reach the PID's validation RMSE), ``table.md``,
  ``table.png``; ``command.txt`` (every invocation).

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
import copy
import csv
import importlib.util
import json
import logging
import multiprocessing
import os
import re
import shlex
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.utils import set_random_seed
from tqdm import tqdm

from spine_gym.cli_conventions import (
    ENV_IDS,
    Parser,
    add_env_kwargs,
    add_out,
    add_progress,
    add_workers,
    check_env_kwargs,
)
from spine_gym.cli_conventions import env_id as env_id_type
from spine_gym.envs import BENCHMARK_IDS

from . import benchmark_stats as stats
from .evaluate import write_csv
from .registry import registry_for
from .runtime import (
    MAX_VALIDATION_EPISODES,
    OBSERVATION_KWARGS,
    SavedPolicy,
    build_controller,
    make_env,
    validation_metrics,
    wrap_policy,
)
from .training import build_envs, build_model, lagrangian_callbacks, resolve_config
from .zoo_config import ALGOS, load_hyperparams

DEFAULT_ENV_IDS = BENCHMARK_IDS  # the Easy and Hard tiers of -v1 of every family
REFERENCES = ("pid", "mpc_estimated", "mpc_oracle")
SEEDS_PER_ALGO = {"ppo": 5}  # seeds of each algorithm by default; DEFAULT_SEEDS for the others
DEFAULT_SEEDS = 3
DONE = "done.json"

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
}
CURVE_COLUMNS = (
    "step",
    "train_wall_s",
    "train_cpu_s",
    "rmse",
    "energy_J",
    "time_over_limit_s",
    "eval_wall_s",
)


@dataclass
class RunSpec:
    """One training run of the benchmark (everything that decides its result).

    Attributes:
        algo, env_id, seed: what is trained where (training env seeds ``seed + i``).
        n_timesteps: the step budget; n_envs: sub-envs (-1: the YAML's).
        eval_freq: env steps between validation evaluations; val_episodes: episodes per evaluation.
        env_kwargs: env kwargs of training and validation (on top of the YAML entry's for training).
        hyperparams: overrides of the YAML entry.
    """

    algo: str
    env_id: str
    seed: int
    n_timesteps: int
    n_envs: int
    eval_freq: int
    val_episodes: int
    env_kwargs: dict = field(default_factory=dict)
    hyperparams: dict = field(default_factory=dict)

    @property
    def folder(self) -> Path:
        return Path("runs") / self.env_id / self.algo / f"seed_{self.seed}"

    @property
    def label(self) -> str:
        return f"{self.algo} {self.env_id} seed {self.seed}"

    def settings(self) -> dict:
        """The spec as stored with a finished run, JSON-normalised (tuples -> lists), with ``entry``:
        the hyperparameter entry the run trains with (the YAML's, as it is now, with the spec's
        overrides), so that a run finished before the YAML changed is not taken for a current one."""
        entry = load_hyperparams(self.algo, self.env_id) | self.hyperparams
        return json.loads(json.dumps({**asdict(self), "entry": entry}))


# --------------------------------------------------------------------------- one run
def validation_env_kwargs(task_kwargs: dict, training_kwargs: dict) -> dict:
    """The validation episodes' env kwargs of a policy: the benchmark's task distribution
    ``task_kwargs`` (the same for every method), observed as the policy was trained
    (:data:`spine_gym.agents.runtime.OBSERVATION_KWARGS` of its ``training_kwargs``, e.g. a target preview)."""
    own = {k: training_kwargs[k] for k in OBSERVATION_KWARGS if k in training_kwargs}
    return {**{k: v for k, v in task_kwargs.items() if k not in OBSERVATION_KWARGS}, **own}


def validation_means(rows: list[dict]) -> dict:
    """Means over the validation episodes of :func:`spine_gym.agents.metrics.episode_metrics` rows."""
    return {
        "rmse": float(np.mean([r["rmse_deg"] for r in rows])),  # the env's unit despite the key
        "energy_J": float(np.mean([r["energy_J"] for r in rows])),
        "time_over_limit_s": float(np.mean([r["time_over_limit_s"] for r in rows])),
    }


def live_policy(model, meta: dict) -> object:
    """The model being trained as a ``predict``-able controller: its current observation
    statistics (a copy) and the observation wrappers of ``meta`` (:func:`spine_gym.agents.runtime.wrap_policy`)."""
    vn = model.get_vec_normalize_env()
    rms = copy.deepcopy(vn.obs_rms) if vn is not None and vn.norm_obs else None
    clip, eps = (vn.clip_obs, vn.epsilon) if vn is not None else (10.0, 1e-8)
    return wrap_policy(SavedPolicy(model, rms, clip, eps, meta=meta, name=meta["algo"]))


class ValidationCallback(BaseCallback):
    """Runs ``evaluate()`` at step 0, every ``eval_freq`` env steps and at the end of training;
    appends each result with the step count and the training wall/CPU time so far (evaluation
    time excluded) to the CSV ``path``."""

    def __init__(self, evaluate: Callable[[], dict], eval_freq: int, path: Path, bar=None):
        super().__init__(verbose=0)
        self.evaluate, self.eval_freq, self.path, self.bar = evaluate, int(eval_freq), Path(path), bar
        self.rows: list[dict] = []
        self.next_eval = 0
        self.eval_wall = self.eval_cpu = 0.0
        self.t0 = self.c0 = 0.0

    def _on_training_start(self) -> None:
        self.t0, self.c0 = time.perf_counter(), time.process_time()
        with open(self.path, "w", newline="") as f:
            csv.writer(f).writerow(CURVE_COLUMNS)
        self._evaluate()

    def train_times(self) -> tuple[float, float]:
        """Training wall and CPU time so far [s], validation excluded."""
        return (
            time.perf_counter() - self.t0 - self.eval_wall,
            time.process_time() - self.c0 - self.eval_cpu,
        )

    def _evaluate(self) -> None:
        wall, cpu = self.train_times()
        t, c = time.perf_counter(), time.process_time()
        means = self.evaluate()
        dt = time.perf_counter() - t
        self.eval_wall += dt
        self.eval_cpu += time.process_time() - c
        row = {
            "step": int(self.num_timesteps),
            "train_wall_s": wall,
            "train_cpu_s": cpu,
            **means,
            "eval_wall_s": dt,
        }
        self.rows.append(row)
        with open(self.path, "a", newline="") as f:
            csv.writer(f).writerow([row[k] for k in CURVE_COLUMNS])
        while self.next_eval <= self.num_timesteps:
            self.next_eval += self.eval_freq

    def _on_step(self) -> bool:
        if self.bar is not None and self.n_calls % 64 == 0:
            self.bar.update(self.num_timesteps - self.bar.n)
        if self.num_timesteps >= self.next_eval:
            self._evaluate()
        return True

    def _on_training_end(self) -> None:
        if self.rows[-1]["step"] < self.num_timesteps:
            self._evaluate()  # the result at the budget
        if self.bar is not None:
            self.bar.update(self.num_timesteps - self.bar.n)


def run_one(spec: RunSpec, out: Path, progress: bool = False) -> dict:
    """Train and validate one run into ``out / spec.folder``; returns its record (the stored one,
    without training, if the folder holds a finished run)."""
    torch.set_num_threads(1)
    folder = Path(out) / spec.folder
    if (folder / DONE).exists():
        return json.loads((folder / DONE).read_text())["record"]
    if folder.exists():
        shutil.rmtree(folder)  # an interrupted run starts over
    folder.mkdir(parents=True)
    cfg = resolve_config(
        spec.algo, spec.env_id, n_envs=spec.n_envs, n_timesteps=spec.n_timesteps,
        hyperparams=spec.hyperparams, env_kwargs=spec.env_kwargs,
    )  # fmt: skip
    set_random_seed(spec.seed)
    envs = build_envs(cfg, spec.seed)
    model = build_model(cfg, envs.env, spec.seed)
    meta = {
        "algo": spec.algo,
        "env_id": spec.env_id,
        "env_kwargs": cfg.env_kwargs,
        "seed": spec.seed,
        "n_envs": cfg.n_envs,
        "n_timesteps": cfg.n_timesteps,
        "command": "python -m spine_gym.agents.benchmark (run " + spec.label + ")",
        **envs.meta,
    }
    val_kwargs = validation_env_kwargs(spec.env_kwargs, cfg.env_kwargs)

    def evaluate() -> dict:
        policy = live_policy(model, meta)
        return validation_means(validation_metrics(policy, spec.val_episodes, val_kwargs, spec.env_id))

    bar = tqdm(total=cfg.n_timesteps, desc=f"  {spec.label}", unit="step", leave=False, disable=not progress)
    cb = ValidationCallback(evaluate, spec.eval_freq, folder / "curve.csv", bar)
    model.learn(cfg.n_timesteps, callback=CallbackList([*lagrangian_callbacks(cfg, envs), cb]))
    bar.close()
    wall, cpu = cb.train_times()
    model.save(folder / "model.zip")
    if model.get_vec_normalize_env() is not None:
        model.get_vec_normalize_env().save(str(folder / "vecnormalize.pkl"))
    envs.env.close()
    final = cb.rows[-1]
    record = {
        "algo": spec.algo,
        "env_id": spec.env_id,
        "seed": spec.seed,
        "steps": int(model.num_timesteps),
        "wall_s": wall,
        "cpu_s": cpu,
        **{f"final_{m}": final[m] for m in stats.METRICS},
    }
    meta |= {
        "train_wall_time_s": round(wall, 1),
        "train_cpu_time_s": round(cpu, 1),
        "total_timesteps": record["steps"],
    }
    (folder / "meta.json").write_text(json.dumps(meta, indent=2))
    (folder / DONE).write_text(json.dumps({"settings": spec.settings(), "record": record}, indent=2))
    return record


def run_files(spec: RunSpec) -> tuple[dict, dict[str, bytes]]:
    """Train ``spec`` (:func:`run_one`) in a temporary folder; return its record and the files of
    its run folder (path relative to it -> bytes), which :func:`write_run` writes elsewhere. What a
    Ray task of ``--address`` runs: its results reach the driver without a shared file system."""
    with tempfile.TemporaryDirectory(prefix="spine_bench_") as tmp:
        record = run_one(spec, Path(tmp))
        folder = Path(tmp) / spec.folder
        paths = sorted(p for p in folder.rglob("*") if p.is_file())
        files = {p.relative_to(folder).as_posix(): p.read_bytes() for p in paths}
    return record, files


def write_run(out: Path, spec: RunSpec, files: dict[str, bytes]) -> None:
    """Write the files of a run (from :func:`run_files`) into ``out / spec.folder`` as
    :func:`run_one` leaves them; ``done.json`` last, so an interrupted write is a run to start over."""
    folder = Path(out) / spec.folder
    if folder.exists():
        shutil.rmtree(folder)
    for name in sorted(files, key=lambda n: n == DONE):
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(files[name])


def _worker_init() -> None:
    torch.set_num_threads(1)


def execute(
    specs: list[RunSpec], out: Path, workers: int, address: str | None = None
) -> Iterator[tuple[RunSpec, dict | None, str]]:
    """Run ``specs``, yielding ``(spec, record, error)`` as each finishes (``record`` None and the
    error's text if it failed; the others go on).

    Without ``address``: ``workers`` 1 runs them in this process (with a step progress bar), more in
    a pool of that many spawned processes (one torch thread each). With a Ray ``address``: one
    :func:`run_files` per Ray task (:func:`execute_on_ray`), the files written here by :func:`write_run`.
    """
    if address is not None:
        for spec, result, error in execute_on_ray(specs, address, workers):
            if result is None:
                yield spec, None, error
            else:
                record, files = result
                write_run(out, spec, files)
                yield spec, record, ""
        return
    if workers == 1:
        for spec in specs:
            try:
                yield spec, run_one(spec, out, progress=True), ""
            except Exception as e:  # noqa: BLE001 - one failed run must not stop the others
                yield spec, None, f"{type(e).__name__}: {e}"
        return
    ctx = multiprocessing.get_context("spawn")  # no fork of a process holding numba/torch threads
    with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_worker_init) as pool:
        futures = {pool.submit(run_one, spec, out): spec for spec in specs}
        for fut in as_completed(futures):
            try:
                yield futures[fut], fut.result(), ""
            except Exception as e:  # noqa: BLE001
                yield futures[fut], None, f"{type(e).__name__}: {e}"


def execute_on_ray(
    specs: list[RunSpec], address: str, local_cpus: int
) -> Iterator[tuple[RunSpec, tuple[dict, dict[str, bytes]] | None, str]]:
    """Run :func:`run_files` of each of ``specs`` as a Ray task of one CPU on the cluster at
    ``address`` (``local``: a Ray instance started in this process with ``local_cpus`` CPUs, shut
    down at the end); yield ``(spec, (record, files), "")``, or ``(spec, None, error)``, as each ends.

    Ray is imported here, not at the top: it is optional (``pip install 'ray[default]'``), needed only
    with ``--address``. Every node needs this package (and its dependencies) installed.
    """
    import ray  # optional dependency, see the docstring

    if address == "local":
        ray.init(address="local", num_cpus=local_cpus, include_dashboard=False, logging_level=logging.WARNING)
    else:
        ray.init(address=address, logging_level=logging.WARNING)
    try:
        cpus = int(ray.cluster_resources().get("CPU", 0))
        tqdm.write(f"Ray cluster at {address}: {cpus} CPU(s), one run per CPU at a time")
        task = ray.remote(num_cpus=1)(run_files)
        pending = {task.remote(spec): spec for spec in specs}
        while pending:
            [ref], _ = ray.wait(list(pending), num_returns=1)
            spec = pending.pop(ref)
            try:
                result = ray.get(ref)
            except ray.exceptions.RayTaskError as e:  # the run's own exception, raised on the node
                cause = e.cause if e.cause is not None else e
                yield spec, None, f"{type(cause).__name__}: {cause}"
            except ray.exceptions.RayError as e:  # a lost node or worker, after Ray's retries
                yield spec, None, f"{type(e).__name__}: {str(e).splitlines()[0]}"
            else:
                yield spec, result, ""
    finally:
        ray.shutdown()


# --------------------------------------------------------------------------- references
def reference_scores(
    env_id: str, names: tuple[str, ...], task_kwargs: dict, n_val: int, n_ref: int, out: Path
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
            desc = f"  reference {name} on {env_id}"
            rows = validation_metrics(ctrl, settings["n_episodes"], kw, env_id, progress=desc)
            cache[name] = {"settings": settings, "episodes": rows, "means": validation_means(rows)}
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(cache, indent=2))
        result[name] = {**cache[name]["means"], "n_episodes": settings["n_episodes"]}
    return result


# --------------------------------------------------------------------------- report
def read_curve(path: Path) -> dict[str, np.ndarray]:
    """The columns of a run's ``curve.csv``."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in CURVE_COLUMNS}


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
        pid = references[spec.env_id]["pid"]["rmse"]
        steps, wall = stats.time_to_level(curve["step"], curve["train_wall_s"], curve["rmse"], pid)
        runs.append({**record, "steps_to_pid": steps, "wall_to_pid_s": wall})
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
    curve_rows = []
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
        stats.plot_curves(out / f"curves_{env_id}.png", env_id, plotted, references[env_id], units[env_id])
    write_csv(out / "learning_curves.csv", curve_rows)
    summary = stats.summary_rows(runs, {k: v for k, v in references.items() if k in curves}, reps=reps)
    write_csv(out / "table.csv", summary)
    (out / "table.md").write_text(stats.markdown_table(summary, runs, units))
    stats.plot_table(out / "table.png", summary, units)
    return summary


# --------------------------------------------------------------------------- CLI
EXAMPLES = (
    "spine-gym benchmark --workers 2                  # every algorithm on the default env ids",
    "spine-gym benchmark --quick -o /tmp/bench        # the smoke run of CI",
    "spine-gym benchmark --algos ppo sac --env SmaSpine-v1 --n-seeds 10 -n 200000",
    "spine-gym benchmark --address HOST:6379          # one run per Ray task on a Ray cluster",
)


def build_parser(prog: str = "python -m spine_gym.agents.benchmark") -> argparse.ArgumentParser:
    p = Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES)
    p.add_argument("--algos", nargs="+", choices=ALGOS, default=list(ALGOS), help="algorithms (default: all)")
    p.add_argument(
        "--envs",
        "--env",
        nargs="+",
        type=env_id_type,
        choices=ENV_IDS,
        default=None,
        metavar="ID",
        help=f"env ids (default: {' '.join(DEFAULT_ENV_IDS)}; --quick: the first two); any of: {', '.join(ENV_IDS)}",
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
    env_ids = list(args.envs) if args.envs else list(DEFAULT_ENV_IDS[: 2 if args.quick else None])
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
            probe = make_env(task_kwargs, env_id=env_id)
        except TypeError as e:
            raise ValueError(f"--env-kwargs not accepted by {env_id}: {e}") from None
        units[env_id] = probe.config.table().task.unit
        probe.close()
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


def check_finished(specs: list[RunSpec], out: Path) -> None:
    """ValueError if a finished run in ``out`` was made with other settings than its spec now."""
    for spec in specs:
        done = out / spec.folder / DONE
        if done.exists():
            stored = json.loads(done.read_text())["settings"]
            diff = {k: (stored.get(k), v) for k, v in spec.settings().items() if stored.get(k) != v}
            if diff:
                k, (old, new) = next(iter(diff.items()))
                raise ValueError(
                    f"{out / spec.folder} finished with {k}={old!r}, now {new!r}; use another --out"
                )


def main(argv: list[str] | None = None, prog: str = "python -m spine_gym.agents.benchmark") -> list[dict]:
    """Run the CLI; returns the summary rows of the table. Usage errors exit with status 2 before any
    folder is made."""
    t_start = time.perf_counter()
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    out = Path(args.out)
    try:
        plan = make_plan(args)
        check_finished(plan.specs, out)
    except ValueError as e:
        parser.error(str(e))
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    torch.set_num_threads(1)
    out.mkdir(parents=True, exist_ok=True)
    argv = sys.argv[1:] if argv is None else list(argv)
    with open(out / "command.txt", "a") as f:
        f.write("python -m spine_gym.agents.benchmark " + " ".join(shlex.quote(a) for a in argv) + "\n")
    references = {
        env_id: reference_scores(
            env_id, plan.references, plan.task_kwargs, plan.val_episodes, plan.reference_episodes, out
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
        for spec, record, error in execute(pending, out, args.workers, args.address if pending else None):
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
    return summary


if __name__ == "__main__":
    # `python -m` runs this file as __main__, whose functions Ray would send by value (their code):
    # run the importable module's main instead, so that a Ray task names spine_gym.agents.benchmark.run_files
    from spine_gym.agents.benchmark import main as _main

    _main(sys.argv[1:])
