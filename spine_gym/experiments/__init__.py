"""Reproduction of the seed paper's experiments against the reference values of MODEL.md §10.

Runs, with the baseline parameters of MODEL.md §7:

* the **hysteresis run** (§10.2): right wire at 3.2 V for 0–20 s, then 0 V, 50 s in all;
* the **alternate drive** (§10.3): right wire at 3.2 V for 0–20 s, left wire at 3.2 V for 20–40 s;
* the **capacity protocol** and both **design studies** (§10.4): wire offset ``a`` from 6 to 14 mm,
  and 1–3 wires per side,

and compares every number with the reference solution values listed in MODEL.md §10. The seed
paper's own result tables were lost (MODEL.md, header); the seed reports maximum simulation-vs-
experiment errors of 3.57° (hysteresis) and 4.94° (alternate drive), which are quoted for scale.

Command line::

    python -m spine_gym.experiments [-o/--out DIR] [--quick] [--method newton|illinois|bisect]
                                    [--strict] [--progress/--no-progress]
    spine-gym reproduce ...         # the same command

It shows progress (tqdm, on stderr), prints the comparison tables (markdown) and writes to ``DIR``
(default ``runs/experiments``): ``reproduction.md`` (the tables), ``reproduction.json`` (every
row, machine-readable), ``hysteresis.csv`` / ``alternate.csv`` (trajectories) and the PNG plots
``hysteresis_angle.png``, ``alternate_angle.png``, ``hysteresis_states.png``,
``capacity_vs_a.png`` (seed Fig. 15-like) and ``capacity_vs_wires.png`` (seed Fig. 16-like).

The capacity numbers come from the library function :func:`spine_gym.capacity.capacity_metrics`;
the event times of the hysteresis and alternate runs
(onset, 90 % rise, relaxation, zero crossing, swing duration) are the library functions
:func:`hysteresis_events` and :func:`alternate_events`.

Modules: :mod:`.references` (reference values, drives, runs, event times), :mod:`.tables` (the
comparison tables) and :mod:`.reproduction` (the whole run, its files and the command line).
"""

from .references import (
    ALTERNATE_REFERENCE,
    ALTERNATE_SWING_TIMES,
    ANGLE_TOL_DEG,
    CAPACITY_REFERENCE,
    HYSTERESIS_REFERENCE,
    SEED_MAX_ERROR_DEG,
    SWING_TOL_DEG,
    alternate_events,
    alternate_voltages,
    crossing_time,
    hysteresis_events,
    hysteresis_voltages,
    run_alternate,
    run_hysteresis,
)
from .reproduction import Reproduction, build_parser, main, reproduce
from .tables import (
    Row,
    Section,
    capacity_cases,
    compare_alternate,
    compare_capacity,
    compare_experiments,
    compare_hysteresis,
    format_section,
)

__all__ = [
    "HYSTERESIS_REFERENCE",
    "ALTERNATE_REFERENCE",
    "ALTERNATE_SWING_TIMES",
    "ANGLE_TOL_DEG",
    "CAPACITY_REFERENCE",
    "SEED_MAX_ERROR_DEG",
    "SWING_TOL_DEG",
    "Row",
    "Section",
    "Reproduction",
    "crossing_time",
    "hysteresis_voltages",
    "alternate_voltages",
    "run_hysteresis",
    "run_alternate",
    "hysteresis_events",
    "alternate_events",
    "compare_hysteresis",
    "compare_alternate",
    "capacity_cases",
    "compare_capacity",
    "compare_experiments",
    "format_section",
    "reproduce",
    "build_parser",
    "main",
]
