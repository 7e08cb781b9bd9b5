"""The runs of the benchmark (:mod:`spine_gym.agents.benchmark`): what one is, training and
validating it, and running many (in this process, a process pool or on a Ray cluster).

* :class:`RunSpec` — one run's settings (stored in its ``done.json`` by :meth:`RunSpec.settings`);
  :func:`check_finished` refuses a finished run made with other settings.
* :func:`run_one` — train and validate one run into its folder (``curve.csv``, model,
  ``meta.json``, ``done.json`` last); :class:`ValidationCallback` runs the validation episodes
  during training; :func:`read_curve` reads a ``curve.csv`` back.
* :func:`execute` — many runs, yielding each result as it ends; :func:`execute_on_ray`,
  :func:`run_files` and :func:`write_run` for ``--address`` (the files travel as bytes).
"""

from __future__ import annotations

import copy
import csv
import json
import logging
import multiprocessing
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.utils import set_random_seed
from tqdm import tqdm

from . import benchmark_stats as stats
from .benchmark_records import DONE
from .runtime import OBSERVATION_KWARGS, SavedPolicy, validation_metrics, wrap_policy
from .training import build_envs, build_model, lagrangian_callbacks, resolve_config
from .zoo_config import load_hyperparams

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
    specs: list[RunSpec], out: Path, workers: int, address: str | None = None, progress: bool = True
) -> Iterator[tuple[RunSpec, dict | None, str]]:
    """Run ``specs``, yielding ``(spec, record, error)`` as each finishes (``record`` None and the
    error's text if it failed; the others go on).

    Without ``address``: ``workers`` 1 runs them in this process (with a step progress bar if
    ``progress``), more in a pool of that many spawned processes (one torch thread each). With a Ray
    ``address``: one
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
                yield spec, run_one(spec, out, progress=progress), ""
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


def read_curve(path: Path) -> dict[str, np.ndarray]:
    """The columns of a run's ``curve.csv``."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in CURVE_COLUMNS}


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
