"""Constrained design optimisation with Optuna (MODEL.md §9 "design optimisation").

A :class:`DesignProblem` says which design parameters to search (ranges or choices), which
capacity metric to maximise or minimise, and which constraints must hold (e.g. maximise the stable
angle subject to ``actuating_ability >= 0.15`` and ``responding_time_s <= 36``). Every trial is
one :func:`spine_gym.capacity.capacity_metrics` run.

Constraints use Optuna's native mechanism, not penalties: each trial stores its constraint values
``g_i`` (``g_i <= 0`` = satisfied, see :meth:`~.space.Constraint.violation`) with
``trial.set_constraint(name, g_i)`` (Optuna >= 5.0; it replaces the samplers' deprecated
``constraints_func`` argument). TPE and NSGA-II read them from the trial: they model feasible and
infeasible trials separately and rank infeasible ones by total violation; ``study.best_trial``
and the summary here only consider feasible trials. The objective value is the raw metric, never
a penalised one. ``inf`` metrics are
handled explicitly: an unreached responding time violates a ``<=`` constraint by a finite
:data:`~.space.INF_VIOLATION`; failed simulations become FAIL trials (``user_attrs["status"]``).

Scale-out uses Optuna's storage as the shared engine: a journal file
(``JournalStorage(JournalFileBackend(path))``; a plain path) or any RDB URL (``sqlite:///...``,
``postgresql+psycopg2://...``, ``mysql+pymysql://...``). Every worker process, on this machine
(``n_workers``) or on others, opens the same study by name and asks the storage for its next
trial. The problem definition is stored in the study (``user_attrs["spine_gym_problem"]``), and a
worker that joins with a different definition is refused.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import multiprocessing
import os
import socket
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from ..capacity import CapacityProtocol
from ..layout import SpineLayout
from ..params import ModelParams, SolverOptions
from .space import (
    METRICS,
    SearchDim,
    design_params,
    evaluate_design,
    make_design,
    parse_constraint,
    parse_search_spec,
    resolve_metric,
)
from .sweeps import MP_CONTEXTS, resolve_workers

__all__ = [
    "DesignProblem",
    "OptimizationResult",
    "SAMPLERS",
    "load_result",
    "make_sampler",
    "display_storage",
    "make_storage",
    "optimize",
]

SAMPLERS = ("tpe", "nsga2", "random")
CONFIG_KEY = "spine_gym_problem"


@dataclass(frozen=True)
class DesignProblem:
    """A constrained single-objective design problem.

    Args:
        space: search dimensions (:class:`~.space.SearchDim` or spec strings ``"a=6e-3:14e-3"``,
            ``"eps0=0.03:0.06"``, ``"n_w=1,2,3"``, ``"n_modules=1,2,3"``: a chained layout).
        metric: objective metric (name or alias, see :data:`~.space.METRICS`).
        maximize: True to maximise, False to minimise.
        constraints: :class:`~.space.Constraint` or strings ``"actuating_ability>=0.15"``.
        base: base design (default MODEL.md §7 baseline, planar; or a ``SpineLayout.chain``).
        protocol: capacity protocol (default MODEL.md §10.4).
        solver: solver options (None = defaults).
        fixed: fixed overrides of the base design (``{"E_t": 30e6}``).

    Raises:
        ValueError: unknown parameter or metric, a bound outside the parameter's range, a
            parameter both searched and fixed (messages name the parameter).
    """

    space: tuple
    metric: str = "stable_angle_deg"
    maximize: bool = True
    constraints: tuple = ()
    base: ModelParams | SpineLayout = field(default_factory=ModelParams)
    protocol: CapacityProtocol = field(default_factory=CapacityProtocol)
    solver: SolverOptions | None = None
    fixed: dict = field(default_factory=dict)

    def __post_init__(self):
        space = tuple(parse_search_spec(d) if isinstance(d, str) else d for d in self.space)
        if not space:
            raise ValueError("space must hold at least one search dimension")
        names = [d.name for d in space]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"search parameter(s) {sorted(dup)} given twice")
        clash = set(names) & set(self.fixed)
        if clash:
            raise ValueError(f"parameter(s) {sorted(clash)} are both searched and fixed")
        cons = tuple(parse_constraint(c) if isinstance(c, str) else c for c in self.constraints)
        object.__setattr__(self, "space", space)
        object.__setattr__(self, "constraints", cons)
        object.__setattr__(self, "metric", resolve_metric(self.metric))
        object.__setattr__(self, "fixed", dict(self.fixed))
        base, proto = make_design(self.fixed, self.base, self.protocol)
        object.__setattr__(self, "base", base)
        object.__setattr__(self, "protocol", proto)
        # Each bound / choice must be a valid design on its own (fail here, not in a worker).
        for d in space:
            for v in d.choices if d.choices is not None else (d.low, d.high):
                make_design({d.name: v}, base, proto)

    @property
    def direction(self) -> str:
        return "maximize" if self.maximize else "minimize"

    def to_config(self) -> dict[str, Any]:
        """JSON-safe description (stored in the study; equal configs = same problem)."""
        cfg = {
            "space": [d.to_dict() for d in self.space],
            "metric": self.metric,
            "direction": self.direction,
            "constraints": [str(c) for c in self.constraints],
            "base_params": dataclasses.asdict(design_params(self.base)),
            "base_n_modules": self.base.n_modules if isinstance(self.base, SpineLayout) else None,
            "protocol": dataclasses.asdict(self.protocol),
            "solver": None if self.solver is None else dataclasses.asdict(self.solver),
            "fixed": self.fixed,
        }
        return json.loads(json.dumps(cfg))

    @classmethod
    def from_config(cls, cfg: dict[str, Any]) -> DesignProblem:
        """Inverse of :meth:`to_config`."""
        space = []
        for d in cfg["space"]:
            choices = None if d["choices"] is None else tuple(d["choices"])
            space.append(SearchDim(d["name"], d["low"], d["high"], d["log"], choices))
        return cls(
            space=tuple(space),
            metric=cfg["metric"],
            maximize=cfg["direction"] == "maximize",
            constraints=tuple(cfg["constraints"]),
            base=_base_from_config(cfg),
            protocol=CapacityProtocol(**cfg["protocol"]),
            solver=None if cfg["solver"] is None else SolverOptions(**cfg["solver"]),
            fixed=cfg["fixed"],
        )

    def evaluate(self, overrides: dict[str, Any]) -> dict[str, Any]:
        """Metrics record of one design (see :func:`~.space.evaluate_design`) plus violations."""
        params, proto = make_design(overrides, self.base, self.protocol)
        rec = evaluate_design(params, proto, self.solver)
        rec["constraint_violations"] = [c.violation(rec[c.metric]) for c in self.constraints]
        return rec

    def objective(self, trial, worker: str = "") -> float:
        """Optuna objective: suggest a design, run the capacity protocol, store the metrics.

        Returns the raw metric (may be ``inf``); NaN for a failed or invalid design, which Optuna
        records as a FAIL trial (reason in ``user_attrs["status"]``).
        """
        overrides = {d.name: d.suggest(trial) for d in self.space}
        trial.set_user_attr("worker", worker)
        try:
            rec = self.evaluate(overrides)
        except ValueError as e:  # a combination that violates a cross-field rule of ModelParams
            trial.set_user_attr("status", f"invalid: {e}")
            return math.nan
        trial.set_user_attr("status", rec["status"])
        trial.set_user_attr("metrics", {k: rec[k] for k in METRICS})
        if rec["status"] != "ok":
            return math.nan
        for c, g in zip(self.constraints, rec["constraint_violations"], strict=True):
            trial.set_constraint(str(c), g)
        return rec[self.metric]


def _base_from_config(cfg: dict[str, Any]) -> ModelParams | SpineLayout:
    """The base design of a stored problem (configs written before layouts have no n_modules)."""
    params = ModelParams(**cfg["base_params"])
    n = cfg.get("base_n_modules")
    return params if n is None else SpineLayout.chain(n, params)


def make_sampler(name: str, seed: int | None, n_startup_trials: int = 10):
    """An Optuna sampler: ``tpe`` (default) or ``nsga2`` (both use the trials' constraint values
    to guide the search) or ``random`` (constraints only used to pick the best trial)."""
    import optuna

    if name == "tpe":
        return optuna.samplers.TPESampler(seed=seed, n_startup_trials=n_startup_trials)
    if name == "nsga2":
        return optuna.samplers.NSGAIISampler(seed=seed)
    if name == "random":
        return optuna.samplers.RandomSampler(seed=seed)
    raise ValueError(f"sampler must be one of {SAMPLERS}, got {name!r}")


def make_storage(url: str | None):
    """Optuna storage from a string.

    * None: in-memory (one process only);
    * a string containing ``://``: an RDB URL (``sqlite:///study.db``,
      ``postgresql+psycopg2://user:pw@host/db``, ``mysql+pymysql://user:pw@host/db``);
    * anything else: a journal file path (``JournalStorage(JournalFileBackend(path))``), safe for
      several processes on one machine or on a shared file system.
    """
    import optuna
    from optuna.storages.journal import JournalFileBackend, JournalStorage

    if url is None:
        return optuna.storages.InMemoryStorage()
    if "://" in url:
        kw = {}
        if url.startswith("sqlite:///") and url != "sqlite:///:memory:":
            Path(url[len("sqlite:///") :]).parent.mkdir(parents=True, exist_ok=True)
            # a generous lock timeout: several workers write to the same file
            kw = {"connect_args": {"timeout": 60}}
        try:
            return optuna.storages.RDBStorage(url, engine_kwargs=kw)
        except Exception as e:  # bad URL, missing DB driver, server unreachable, ...
            reason = " ".join(str(getattr(e, "orig", None) or e).split())  # the driver's words, one line
            raise ValueError(
                f"cannot open storage {_hide_password(url)}: {type(e).__name__}: {reason}"
            ) from e
    Path(url).parent.mkdir(parents=True, exist_ok=True)
    return JournalStorage(JournalFileBackend(str(url)))


def display_storage(url: str | None) -> str | None:
    """``url`` as it may be printed or written to a file: an RDB URL with its password as ``***``."""
    return _hide_password(url) if url is not None and "://" in url else url


def _hide_password(url: str) -> str:
    try:
        from sqlalchemy.engine import make_url

        return make_url(url).render_as_string(hide_password=True)
    except Exception:  # not parseable: show the scheme only
        return url.split("://", 1)[0] + "://..."


def _open_study(problem: DesignProblem, storage, study_name: str, sampler=None):
    import optuna

    study = optuna.create_study(
        study_name=study_name,
        storage=storage,
        direction=problem.direction,
        sampler=sampler,
        load_if_exists=True,
    )
    cfg = problem.to_config()
    stored = study.user_attrs.get(CONFIG_KEY)
    if stored is None:
        study.set_user_attr(CONFIG_KEY, cfg)
    elif stored != cfg:
        diff = sorted(k for k in cfg if cfg.get(k) != stored.get(k))
        raise ValueError(
            f"study {study_name!r} in this storage holds a different design problem "
            f"(differs in {diff}); use another --study-name or the same settings"
        )
    if study.direction.name.lower() != problem.direction:
        raise ValueError(f"study {study_name!r} has direction {study.direction.name.lower()}")
    return study


def _worker(
    problem: DesignProblem,
    storage_url: str | None,
    study_name: str,
    n_trials: int,
    seed: int | None,
    sampler: str,
    worker_index: int,
    n_startup_trials: int,
    max_total_trials: int | None,
    timeout: float | None,
    study=None,
    callbacks=(),
) -> int:
    """Run ``n_trials`` trials of the study (one worker process; also the serial path)."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    s = make_sampler(sampler, seed, n_startup_trials)
    if study is None:
        study = _open_study(problem, make_storage(storage_url), study_name, s)
    else:
        study.sampler = s
    cbs = list(callbacks)
    if max_total_trials is not None:
        cbs.append(optuna.study.MaxTrialsCallback(max_total_trials, states=None))
    worker = f"{socket.gethostname()}/{os.getpid()}/w{worker_index}"
    study.optimize(
        partial(problem.objective, worker=worker),
        n_trials=n_trials,
        timeout=timeout,
        callbacks=cbs,
        catch=(),
    )
    return worker_index


@dataclass
class OptimizationResult:
    """Summary of a study.

    Attributes:
        study_name, storage: where the study lives (storage None = in memory).
        problem: the design problem.
        best: best feasible trial as a dict (``number``, ``params`` — the searched values,
            ``metrics``, ``value``, ``constraint_violations``) or None if no trial is feasible.
        least_violating: when nothing is feasible, the trial with the smallest total violation.
        trials: one record per finished trial.
        elapsed_s: wall-clock time of this run [s] (NaN when loaded from storage).
    """

    study_name: str
    storage: str | None
    problem: DesignProblem
    best: dict[str, Any] | None
    least_violating: dict[str, Any] | None
    trials: list[dict[str, Any]]
    elapsed_s: float = math.nan

    def best_params(self) -> ModelParams | None:
        """The complete ModelParams of the best design (None if none feasible)."""
        model = self.best_design()
        return None if model is None else design_params(model)

    def best_design(self) -> ModelParams | SpineLayout | None:
        """The best design: its ModelParams, or its SpineLayout for a chained design (None if none
        feasible)."""
        if self.best is None:
            return None
        return make_design(self.best["params"], self.problem.base, self.problem.protocol)[0]

    def to_dict(self) -> dict[str, Any]:
        return {
            "study_name": self.study_name,
            "storage": display_storage(self.storage),
            "problem": self.problem.to_config(),
            "best": self.best,
            "least_violating": self.least_violating,
            "n_trials": len(self.trials),
            "n_complete": sum(t["state"] == "COMPLETE" for t in self.trials),
            "n_feasible": sum(bool(t["feasible"]) for t in self.trials),
            "elapsed_s": self.elapsed_s,
        }

    def write_json(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), indent=2) + "\n")
        return path

    def write_trials_csv(self, path: str | Path) -> Path:
        """One row per trial: searched values, metrics (``inf`` written as ``inf``), constraint
        values, ``feasible``, ``state``, ``status``, ``worker``."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        names = [d.name for d in self.problem.space]
        cons = [str(c) for c in self.problem.constraints]
        header = [
            "number",
            "state",
            *names,
            *METRICS,
            *(f"g[{c}]" for c in cons),
            "feasible",
            "status",
            "worker",
        ]
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(header)
            for t in self.trials:
                m = t["metrics"] or {}
                g = t["constraint_violations"] or [math.nan] * len(cons)
                w.writerow(
                    [
                        t["number"],
                        t["state"],
                        *(_cell(t["params"].get(n)) for n in names),
                        *(_cell(m.get(k)) for k in METRICS),
                        *(_cell(v) for v in g),
                        t["feasible"],
                        t["status"],
                        t["worker"],
                    ]
                )
        return path

    def summary(self) -> str:
        """Human-readable best design and its metrics."""
        p = self.problem
        lines = [
            f"study {self.study_name!r}: {p.direction} {p.metric}"
            + (f" subject to {', '.join(map(str, p.constraints))}" if p.constraints else ""),
            f"trials: {len(self.trials)} finished, "
            f"{sum(t['state'] == 'COMPLETE' for t in self.trials)} complete, "
            f"{sum(bool(t['feasible']) for t in self.trials)} feasible",
        ]
        shown = self.best or self.least_violating
        if shown is None:
            lines.append("no completed trial")
            return "\n".join(lines)
        lines.append(
            ("best feasible design" if self.best else "NO FEASIBLE DESIGN; least violating")
            + f" (trial {shown['number']}):"
        )
        for k, v in shown["params"].items():
            lines.append(f"  {k:<24} = {v!r}")
        for k, v in shown["metrics"].items():
            lines.append(f"  {k:<24} : {v:.6g}")
        for c, g in zip(p.constraints, shown["constraint_violations"], strict=True):
            lines.append(f"  constraint {str(c):<32} {'ok' if g <= 0 else 'VIOLATED'} (g = {g:.4g})")
        return "\n".join(lines)


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if math.isnan(v) else repr(v)
    return str(v)


def _summarise(study, problem: DesignProblem, storage_url: str | None, elapsed: float) -> OptimizationResult:
    import optuna

    finished = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL)
    records = []
    keys = [str(c) for c in problem.constraints]
    for t in study.get_trials(deepcopy=False, states=finished):
        stored = t.constraints
        g = [float(stored[k]) for k in keys] if all(k in stored for k in keys) else None
        value = t.value if t.state == optuna.trial.TrialState.COMPLETE else None
        feasible = (
            t.state == optuna.trial.TrialState.COMPLETE
            and value is not None
            and not math.isnan(value)
            and g is not None
            and all(v <= 0.0 for v in g)
        )
        records.append(
            {
                "number": t.number,
                "state": t.state.name,
                "params": dict(t.params),
                "metrics": t.user_attrs.get("metrics"),
                "value": value,
                "constraint_violations": g,
                "feasible": feasible,
                "status": t.user_attrs.get("status", ""),
                "worker": t.user_attrs.get("worker", ""),
            }
        )
    records.sort(key=lambda r: r["number"])
    feas = [r for r in records if r["feasible"]]
    best = None
    if feas:
        sign = 1.0 if problem.maximize else -1.0
        best = max(feas, key=lambda r: (sign * r["value"], -r["number"]))
    least = None
    done = [r for r in records if r["state"] == "COMPLETE" and r["metrics"] is not None]
    if best is None and done:
        least = min(done, key=lambda r: (sum(max(v, 0.0) for v in r["constraint_violations"]), r["number"]))
    return OptimizationResult(study.study_name, storage_url, problem, best, least, records, elapsed)


def optimize(
    problem: DesignProblem,
    *,
    n_trials: int,
    storage: str | None = None,
    study_name: str = "spine-design",
    n_workers: int = 1,
    seed: int | None = 0,
    sampler: str = "tpe",
    n_startup_trials: int = 10,
    max_total_trials: int | None = None,
    timeout: float | None = None,
    mp_context: str = "spawn",
    progress: bool = False,
) -> OptimizationResult:
    """Run (or continue) a study of ``problem`` and return the best feasible design.

    Args:
        problem: the design problem.
        n_trials: trials run by this call, split evenly across ``n_workers`` processes.
        storage: None (in memory), a journal file path, or an RDB URL (see :func:`make_storage`).
            A study with the same name is continued (and must hold the same problem).
        study_name: study name in the storage.
        n_workers: worker processes on this machine, all on the same study (needs ``storage``).
        seed: base sampler seed; worker ``i`` uses ``seed + i`` (None: random). A study with one
            worker and a seed is reproducible; with several, trial order depends on timing.
        sampler: ``"tpe"``, ``"nsga2"`` or ``"random"``.
        n_startup_trials: random trials before TPE starts modelling (per worker).
        max_total_trials: stop every worker once the study holds this many trials (any state),
            a global budget when several machines share one study.
        timeout: per-worker time limit [s].
        mp_context: ``"spawn"`` or ``"forkserver"``.
        progress: progress bar (trials finished in the study during this call).

    Returns:
        OptimizationResult over every finished trial of the study (including earlier runs).
    """
    import optuna
    from tqdm.auto import tqdm

    n_workers = _checked_workers(n_trials, n_workers, sampler, mp_context, storage, max_total_trials)
    optuna.logging.set_verbosity(optuna.logging.WARNING)

    storage_obj = make_storage(storage)
    study = _open_study(problem, storage_obj, study_name)  # validates/records the problem once
    fin = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL, optuna.trial.TrialState.PRUNED)
    n_before = len(study.get_trials(deepcopy=False, states=fin))
    common = dict(
        problem=problem,
        storage_url=storage,
        study_name=study_name,
        sampler=sampler,
        n_startup_trials=n_startup_trials,
        max_total_trials=max_total_trials,
        timeout=timeout,
    )
    t0 = time.perf_counter()
    with tqdm(total=n_trials, desc="optimise", unit="trial", disable=not progress) as bar:
        if n_workers == 1:

            def _tick(_study, _trial):
                bar.update()

            _worker(n_trials=n_trials, seed=seed, worker_index=0, study=study, callbacks=(_tick,), **common)
        else:
            _run_workers(study, (fin, n_before), n_trials, n_workers, seed, mp_context, bar, common)
    elapsed = time.perf_counter() - t0
    return _summarise(study, problem, storage, elapsed)


def _checked_workers(n_trials, n_workers, sampler, mp_context, storage, max_total_trials) -> int:
    """The worker processes :func:`optimize` starts, after checking its run options (ValueError)."""
    if isinstance(n_trials, bool) or int(n_trials) != n_trials or n_trials < 1:
        raise ValueError(f"n_trials must be an integer >= 1, got {n_trials!r}")
    n_workers = resolve_workers(n_workers)
    if sampler not in SAMPLERS:
        raise ValueError(f"sampler must be one of {SAMPLERS}, got {sampler!r}")
    if mp_context not in MP_CONTEXTS:
        raise ValueError(f"mp_context must be one of {MP_CONTEXTS}, got {mp_context!r}")
    if n_workers > 1 and storage is None:
        raise ValueError("n_workers > 1 needs a shared storage (a journal file path or an RDB URL)")
    if max_total_trials is not None and max_total_trials < 1:
        raise ValueError(f"max_total_trials must be >= 1, got {max_total_trials!r}")
    return min(n_workers, int(n_trials))


def _run_workers(study, finished, n_trials, n_workers, seed, mp_context, bar, common) -> None:
    """The trials of :func:`optimize` on ``n_workers`` processes (``n_trials`` split evenly, worker
    i seeded ``seed + i``); ``bar`` follows the study's trials in the states ``finished[0]`` beyond
    the ``finished[1]`` it held at the start."""
    states, n_before = finished
    shares = [n_trials // n_workers + (i < n_trials % n_workers) for i in range(n_workers)]
    ctx = multiprocessing.get_context(mp_context)
    with ProcessPoolExecutor(max_workers=n_workers, mp_context=ctx) as ex:
        futs = [
            ex.submit(
                _worker,
                n_trials=shares[i],
                seed=None if seed is None else seed + i,
                worker_index=i,
                **common,
            )
            for i in range(n_workers)
        ]
        while not all(f.done() for f in futs):
            time.sleep(0.5)
            done = len(study.get_trials(deepcopy=False, states=states)) - n_before
            bar.update(max(0, min(done, n_trials) - bar.n))
        for f in futs:
            f.result()  # re-raise a worker's error
    done = len(study.get_trials(deepcopy=False, states=states)) - n_before
    bar.update(max(0, min(done, n_trials) - bar.n))


def load_result(storage: str, study_name: str = "spine-design") -> OptimizationResult:
    """Summary of a stored study (e.g. after workers on several machines have finished)."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    try:
        study = optuna.load_study(study_name=study_name, storage=make_storage(storage))
    except KeyError:
        raise ValueError(f"no study named {study_name!r} in {display_storage(storage)}") from None
    cfg = study.user_attrs.get(CONFIG_KEY)
    if cfg is None:
        raise ValueError(f"study {study_name!r} was not created by spine_gym.design")
    return _summarise(study, DesignProblem.from_config(cfg), storage, math.nan)
