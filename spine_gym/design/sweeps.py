"""Grid sweeps of the capacity metrics over design parameters (MODEL.md §9 design studies, §10.4).

:func:`sweep` evaluates the Cartesian product of one or more parameter axes with
:func:`spine_gym.capacity.capacity_metrics`, serially or across cores, and returns a
:class:`SweepResult` (one tidy row per design) that writes a CSV and feeds :mod:`.plots`.

Parallelism: a :class:`concurrent.futures.ProcessPoolExecutor` with the ``spawn`` context
(default; workers import spine_gym and load the numba on-disk cache, ~0.5 s each) or a thread pool
(``backend="thread"``: the jitted time loop is compiled ``nogil``, so threads run the physics
concurrently without process start-up, while the Python glue of each run is serialised by the GIL).
Each design is an independent deterministic computation, so the serial and parallel results are
bit-identical; rows are stored in grid order, never in completion order.
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import json
import math
import multiprocessing
import os
import time
from collections.abc import Iterable, Mapping, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..capacity import CapacityProtocol
from ..layout import SpineLayout
from ..params import ModelParams, SolverOptions
from .space import (
    METRICS,
    Constraint,
    design_params,
    evaluate_design,
    is_integer_param,
    make_design,
    parse_sweep_spec,
)

__all__ = ["SweepResult", "sweep", "resolve_workers", "normalise_axes", "BACKENDS"]

BACKENDS = ("process", "thread")
MP_CONTEXTS = ("spawn", "forkserver")


def resolve_workers(n_workers: int | None) -> int:
    """Number of workers: ``None`` or ``-1`` = all cores (``os.cpu_count()``), else ``>= 1``."""
    if n_workers is None or n_workers == -1:
        return max(1, os.cpu_count() or 1)
    if isinstance(n_workers, bool) or int(n_workers) != n_workers or n_workers < 1:
        raise ValueError(f"n_workers must be an integer >= 1 (or -1 for all cores), got {n_workers!r}")
    return int(n_workers)


def normalise_axes(axes) -> dict[str, list]:
    """Accept ``{"a": [..], ...}``, ``[("a", [..]), ...]`` or spec strings ``["a=6e-3:14e-3:5"]``.

    Every value is validated against the field's range here (before any worker starts).
    """
    if isinstance(axes, str):
        axes = [axes]
    items: Iterable
    if isinstance(axes, Mapping):
        items = axes.items()
    else:
        items = []
        for entry in axes:
            if isinstance(entry, str):
                items.append(parse_sweep_spec(entry))
            else:
                name, values = entry
                items.append((name, values))
    out: dict[str, list] = {}
    for name, values in items:
        if isinstance(values, str):
            name, values = parse_sweep_spec(f"{name}={values}")
        else:
            vals = list(np.atleast_1d(np.asarray(values, dtype=float)))
            spec = ",".join(repr(float(v)) for v in vals)
            if not spec:
                raise ValueError(f"sweep axis {name!r} has no values")
            name, values = parse_sweep_spec(f"{name}={spec}")
        if name in out:
            raise ValueError(f"sweep parameter {name!r} given twice")
        out[name] = values
    if not out:
        raise ValueError("a sweep needs at least one parameter axis")
    return out


def _evaluate_task(
    task: tuple[ModelParams | SpineLayout, CapacityProtocol, SolverOptions | None],
) -> dict[str, Any]:
    """Worker entry point (top level so that spawned processes can import it)."""
    params, protocol, solver = task
    return evaluate_design(params, protocol, solver)


def _make_executor(backend: str, n_workers: int, mp_context: str) -> Executor:
    if backend == "thread":
        return ThreadPoolExecutor(max_workers=n_workers)
    return ProcessPoolExecutor(max_workers=n_workers, mp_context=multiprocessing.get_context(mp_context))


def _run_tasks(
    tasks, n_workers, backend, mp_context, progress, executor: Executor | None = None, desc="sweep"
) -> list[dict[str, Any]]:
    from tqdm.auto import tqdm

    results: list[dict[str, Any] | None] = [None] * len(tasks)
    with tqdm(total=len(tasks), desc=desc, unit="design", disable=not progress, leave=True) as bar:
        if executor is None and (n_workers == 1 or len(tasks) <= 1):
            for i, task in enumerate(tasks):
                results[i] = _evaluate_task(task)
                bar.update()
            return results  # type: ignore[return-value]
        own = executor is None
        ex = executor or _make_executor(backend, min(n_workers, len(tasks)), mp_context)
        futures: dict = {}
        try:
            for i, task in enumerate(tasks):
                futures[ex.submit(_evaluate_task, task)] = i
            for fut in as_completed(futures):
                results[futures[fut]] = fut.result()
                bar.update()
        except BaseException:
            for fut in futures:
                fut.cancel()
            if own:
                ex.shutdown(wait=True, cancel_futures=True)
            raise
        if own:
            ex.shutdown(wait=True)
    return results  # type: ignore[return-value]


@dataclass
class SweepResult:
    """Capacity metrics over a grid of designs: one row per design, in grid (C) order.

    Attributes:
        axes: parameter name -> values, in sweep order (the last axis varies fastest).
        rows: one dict per design: ``index``, the axis values, every metric of
            :data:`~spine_gym.design.space.METRICS` (``inf`` = level never reached, NaN = failed
            run) and ``status``.
        base: base design after fixed overrides (ModelParams, or a chained SpineLayout when
            ``n_modules`` is fixed).
        protocol: base capacity protocol (after fixed overrides).
        solver: solver options (None = defaults).
        fixed: fixed overrides applied to the base design.
        elapsed_s: wall-clock time of the evaluations [s].
        n_workers: workers used; backend: ``"process"`` or ``"thread"``.
    """

    axes: dict[str, list]
    rows: list[dict[str, Any]]
    base: ModelParams | SpineLayout = field(default_factory=ModelParams)
    protocol: CapacityProtocol = field(default_factory=CapacityProtocol)
    solver: SolverOptions | None = None
    fixed: dict[str, Any] = field(default_factory=dict)
    elapsed_s: float = math.nan
    n_workers: int = 1
    backend: str = "process"

    @property
    def param_names(self) -> list[str]:
        return list(self.axes)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self.axes.values())

    def __len__(self) -> int:
        return len(self.rows)

    def column(self, name: str) -> np.ndarray:
        """One column (parameter, metric or ``status``) as an array in row order."""
        if self.rows and name not in self.rows[0]:
            raise ValueError(f"no column {name!r}; columns: {list(self.rows[0])}")
        vals = [r[name] for r in self.rows]
        return np.asarray(vals, dtype=object if name == "status" else float)

    def grid(self, metric: str) -> np.ndarray:
        """A metric reshaped to the grid, shape ``self.shape`` (axis order = ``self.axes``)."""
        return self.column(metric).reshape(self.shape)

    def best(self, metric: str, maximize: bool = True, constraints: Sequence[Constraint] = ()) -> dict | None:
        """The best successful row under optional constraints (None if no row qualifies)."""
        ok = [
            r
            for r in self.rows
            if r["status"] == "ok" and all(c.violation(r[c.metric]) <= 0.0 for c in constraints)
        ]
        if not ok:
            return None
        key = (lambda r: r[metric]) if maximize else (lambda r: -r[metric])
        return max(ok, key=key)

    # ------------------------------------------------------------------------------ CSV
    @property
    def columns(self) -> list[str]:
        return ["index", *self.axes, *METRICS, "responding_reached", "status"]

    def to_csv(self, path: str | os.PathLike) -> Path:
        """Write the tidy CSV: one row per design.

        Floats are written with ``repr`` (exact round trip); ``inf`` is written as ``inf`` (level
        never reached); a failed run has empty metric cells and ``status = failed: ...``.
        ``responding_reached`` says explicitly whether reading (i) of the responding time is finite.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(self.columns)
            for r in self.rows:
                cells: list[str] = [str(r["index"])]
                cells += [_fmt(r[k]) for k in self.axes]
                cells += [_fmt(r[k]) for k in METRICS]
                t = r["responding_time_s"]
                cells.append("" if math.isnan(t) else str(bool(math.isfinite(t))))
                cells.append(r["status"])
                w.writerow(cells)
        return path

    @classmethod
    def from_csv(cls, path: str | os.PathLike) -> SweepResult:
        """Read a CSV written by :meth:`to_csv` (metadata, if present next to it, is not needed)."""
        with Path(path).open(newline="") as fh:
            reader = csv.reader(fh)
            header = next(reader)
            body = list(reader)
        try:
            first_metric = header.index(next(iter(METRICS)))
        except ValueError:
            raise ValueError(f"{path}: not a sweep CSV (no {next(iter(METRICS))} column)") from None
        names = header[1:first_metric]
        rows = []
        for cells in body:
            rec = dict(zip(header, cells, strict=True))
            row: dict[str, Any] = {"index": int(rec["index"])}
            for k in names:
                row[k] = int(rec[k]) if is_integer_param(k) else float(rec[k])
            for k in METRICS:
                row[k] = math.nan if rec[k] == "" else float(rec[k])
            row["status"] = rec["status"]
            rows.append(row)
        axes = {k: list(dict.fromkeys(r[k] for r in rows)) for k in names}
        return cls(axes=axes, rows=rows)

    def metadata(self) -> dict[str, Any]:
        """Everything needed to reproduce the sweep (JSON-safe; ``inf`` written as Infinity)."""
        return {
            "axes": self.axes,
            "fixed": self.fixed,
            "base_params": dataclasses.asdict(design_params(self.base)),
            "base_n_modules": self.base.n_modules if isinstance(self.base, SpineLayout) else None,
            "protocol": dataclasses.asdict(self.protocol),
            "solver": None if self.solver is None else dataclasses.asdict(self.solver),
            "n_designs": len(self.rows),
            "n_failed": sum(r["status"] != "ok" for r in self.rows),
            "n_workers": self.n_workers,
            "backend": self.backend,
            "elapsed_s": self.elapsed_s,
            "designs_per_s": len(self.rows) / self.elapsed_s if self.elapsed_s > 0 else None,
        }

    def write_metadata(self, path: str | os.PathLike, **extra) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.metadata() | extra, indent=2) + "\n")
        return path


def _fmt(v) -> str:
    if isinstance(v, int | np.integer):
        return str(int(v))
    v = float(v)
    if math.isnan(v):
        return ""
    return repr(v)  # 'inf' for infinity, shortest exact repr otherwise


def sweep(
    axes,
    *,
    base: ModelParams | None = None,
    protocol: CapacityProtocol | None = None,
    solver: SolverOptions | None = None,
    fixed: Mapping[str, float | int] | None = None,
    n_workers: int | None = 1,
    backend: str = "process",
    mp_context: str = "spawn",
    progress: bool = False,
    executor: Executor | None = None,
) -> SweepResult:
    """Evaluate the capacity metrics on the Cartesian product of parameter axes.

    Args:
        axes: ``{"a": [6e-3, 1e-2], "n_w": [1, 2]}``, ``[("a", [...]), ...]`` or spec strings
            ``["a=6e-3:14e-3:9", "n_w=1,2,3"]`` (grammar in :mod:`.space`). Names: any
            ``ModelParams`` field, ``voltage`` [V] or ``n_modules`` (the design then runs on
            ``SpineLayout.chain(n_modules, params)``). The last axis varies fastest.
        base: base design (default: MODEL.md §7 baseline, planar; or a ``SpineLayout.chain``).
        protocol: capacity protocol (default: MODEL.md §10.4, 60 + 60 + 30 s at 3.2 V).
        solver: solver options (default: ``SolverOptions()``).
        fixed: overrides applied to the base before sweeping (e.g. ``{"E_t": 30e6}``).
        n_workers: parallel workers (1 = serial in this process; ``None``/-1 = all cores).
        backend: ``"process"`` (process pool) or ``"thread"`` (thread pool; kernels are nogil).
        mp_context: start method of the process pool, ``"spawn"`` or ``"forkserver"``.
        progress: show a tqdm progress bar (stderr).
        executor: an existing ``concurrent.futures`` executor to reuse across sweeps (e.g. in a
            notebook, to pay the worker start-up once); it is not shut down here, and
            ``n_workers``/``backend``/``mp_context`` are then only recorded.

    Returns:
        SweepResult with one row per design in grid order (independent of ``n_workers``).

    Raises:
        ValueError: unknown parameter, malformed axis, or any grid point outside the valid range
            (raised before any worker starts; the message names the parameter and the range).
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if mp_context not in MP_CONTEXTS:
        raise ValueError(f"mp_context must be one of {MP_CONTEXTS}, got {mp_context!r}")
    n_workers = resolve_workers(n_workers)
    axes = normalise_axes(axes)
    fixed = dict(fixed or {})
    clash = set(fixed) & set(axes)
    if clash:
        raise ValueError(f"parameter(s) {sorted(clash)} are both swept and fixed")
    base, protocol = make_design(fixed, base, protocol)

    names = list(axes)
    points = list(itertools.product(*axes.values()))
    # Validate every design here, in the parent, so a bad point never reaches a worker.
    tasks = []
    for point in points:
        params, proto = make_design(dict(zip(names, point, strict=True)), base, protocol)
        tasks.append((params, proto, solver))

    t0 = time.perf_counter()
    records = _run_tasks(tasks, n_workers, backend, mp_context, progress, executor)
    elapsed = time.perf_counter() - t0

    rows = []
    for i, (point, rec) in enumerate(zip(points, records, strict=True)):
        rows.append({"index": i, **dict(zip(names, point, strict=True)), **rec})
    return SweepResult(
        axes=axes,
        rows=rows,
        base=base,
        protocol=protocol,
        solver=solver,
        fixed=fixed,
        elapsed_s=elapsed,
        n_workers=n_workers,
        backend=backend,
    )
