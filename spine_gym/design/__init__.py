"""Design studies of the SMA spine (MODEL.md §9-§10.4): capacity sweeps, a constrained
optimiser, and scale-out through Optuna's shared storage.

* :func:`sweep` — capacity metrics over a grid of any ``ModelParams`` fields and the drive
  ``voltage``, serial or in parallel (process or thread pool), as a tidy :class:`SweepResult`
  (CSV, plots in :mod:`spine_gym.design.plots`).
* :class:`DesignProblem` + :func:`optimize` — maximise/minimise one metric under constraints with
  Optuna (TPE by default), optionally with several worker processes on one stored study.
* CLI: ``python -m spine_gym.design {params,sweep,optimize,best} --help``; user guide
  ``docs/design.md``.

Every design is scored by :func:`spine_gym.capacity.capacity_metrics`; nothing here touches the
physics. Matplotlib and Optuna are imported lazily (plots / optimiser only).
"""

from .optimizer import DesignProblem, OptimizationResult, load_result, optimize
from .space import (
    METRICS,
    Constraint,
    SearchDim,
    design_parameter_names,
    evaluate_design,
    make_design,
    parse_constraint,
    parse_search_spec,
    parse_sweep_spec,
)
from .sweeps import SweepResult, sweep

__all__ = [
    "METRICS",
    "Constraint",
    "DesignProblem",
    "OptimizationResult",
    "SearchDim",
    "SweepResult",
    "design_parameter_names",
    "evaluate_design",
    "load_result",
    "make_design",
    "optimize",
    "parse_constraint",
    "parse_search_spec",
    "parse_sweep_spec",
    "sweep",
]
