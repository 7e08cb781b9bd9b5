"""Numbers as the package's report CSVs write them (:func:`spine_gym.agents.evaluation.write_csv`:
the evaluation's and the benchmark's tables): a float to 12 significant digits, so that a sum of time
steps reads ``3.2``, not ``3.1999999999999993``; everything else as ``str`` does. Files that are read
back as data (a sweep, a calibration experiment, a benchmark run's ``curve.csv``) keep every digit."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

__all__ = ["SIGNIFICANT_DIGITS", "csv_number", "csv_cells", "csv_row"]

#: significant digits of a float in a CSV (double precision carries ~15.9; the simulated values are
#: far from that accurate, and 12 keeps every value the package writes apart from its neighbours)
SIGNIFICANT_DIGITS = 12


def csv_number(value: object) -> object:
    """``value`` for a CSV cell: a float (Python or NumPy) as the shortest text of its value rounded to
    :data:`SIGNIFICANT_DIGITS` significant digits (fewer for a narrower NumPy float: a float32 to 7;
    ``nan``/``inf`` unchanged), anything else as is."""
    if not isinstance(value, float | np.floating):
        return value
    digits = SIGNIFICANT_DIGITS
    if isinstance(value, np.floating):
        digits = min(digits, np.finfo(value.dtype).precision + 1)
    x = float(value)
    if not math.isfinite(x):
        return repr(x)
    return repr(float(f"{x:.{digits}g}"))


def csv_cells(values: Iterable[object]) -> list[object]:
    """:func:`csv_number` of each value of a row."""
    return [csv_number(v) for v in values]


def csv_row(row: dict) -> dict:
    """:func:`csv_number` of each value of a dict row (``csv.DictWriter``)."""
    return {k: csv_number(v) for k, v in row.items()}

