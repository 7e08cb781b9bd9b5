"""Measured experiments: a time base, the wire voltages and the traces a fit compares with the model.

One :class:`Experiment` is one run on the hardware, sampled on a uniform time grid. CSV columns
(header row, SI units except the angle):

| column | unit | required | meaning |
|---|---|---|---|
| ``time`` | s | yes | sample times, uniformly spaced (≤ 1 s apart) |
| ``voltage_right``, ``voltage_left`` | V | yes | voltage on each wire, held until the next row |
| ``angle`` | deg | yes | measured bending angle (positive toward the right wire) |
| ``temperature_right``, ``temperature_left`` | K | no | measured wire temperatures |
| ``resistance_right``, ``resistance_left`` | Ohm | no | measured resistance of one wire |
| ``tip_force_x``, ``tip_force_y`` | N | no | force on the top disk (global x, y), held like the voltages |

Bad input raises ``ValueError`` naming the source (file), the column and the row (the file's line
number for CSVs, the array index otherwise): missing or unknown columns, non-increasing or
non-uniform time, NaN/inf, and values whose magnitude says the unit is wrong (mV, °C, mN …).
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Self

import numpy as np

from ..simulate import V_MAX_ALLOWED

__all__ = ["Experiment", "CHANNELS", "DEFAULT_NOISE", "INPUTS", "Samples", "noise_levels", "read_table"]

# measured channels a fit can compare: column -> (unit, plausible range, hint when outside)
CHANNELS = {
    "angle": ("deg", (-180.0, 180.0), "is it in millidegrees?"),
    "temperature_right": ("K", (150.0, 2000.0), "is it in °C instead of K?"),
    "temperature_left": ("K", (150.0, 2000.0), "is it in °C instead of K?"),
    "resistance_right": ("Ohm", (1e-3, 1e3), "is it in mOhm or kOhm?"),
    "resistance_left": ("Ohm", (1e-3, 1e3), "is it in mOhm or kOhm?"),
}
# inputs: column -> (unit, plausible range, hint)
INPUTS = {
    "time": ("s", (-1e6, 1e6), ""),
    "voltage_right": ("V", (0.0, V_MAX_ALLOWED), "is it in mV?"),
    "voltage_left": ("V", (0.0, V_MAX_ALLOWED), "is it in mV?"),
    "tip_force_x": ("N", (-20.0, 20.0), "is it in mN?"),
    "tip_force_y": ("N", (-20.0, 20.0), "is it in mN?"),
}
REQUIRED = ("time", "voltage_right", "voltage_left", "angle")
# default noise level (standard deviation) per channel kind: angle [deg], temperature [K], resistance [Ohm]
DEFAULT_NOISE = {"angle": 0.5, "temperature": 1.0, "resistance": 0.01}
MAX_DT = 1.0  # [s] largest sample spacing (the simulator's output step limit)
UNIFORM_TOL = 1e-3  # relative deviation of a time step from the mean step that still counts as uniform


def _kind(channel: str) -> str:
    return channel.split("_")[0]


def noise_levels(source: str, noise, channels, table=None, defaults=None) -> dict[str, float]:
    """{channel: standard deviation} from a mapping keyed by channel or kind, defaults filled in.

    ``table`` (default :data:`CHANNELS`) names the valid channels, ``defaults`` (default
    :data:`DEFAULT_NOISE`) the level per kind (a channel's kind is its name up to the first ``_``).
    """
    table = CHANNELS if table is None else table
    defaults = DEFAULT_NOISE if defaults is None else defaults
    if not isinstance(noise, Mapping):
        raise ValueError(f"{source}: noise must be a mapping {{channel or kind: std}}, got {noise!r}")
    kinds = {_kind(c) for c in table}
    unknown = set(noise) - set(table) - kinds
    if unknown:
        raise ValueError(
            f"{source}: noise has unknown key(s) {sorted(unknown)}; valid: {sorted(kinds | set(table))}"
        )
    out = {}
    for ch in channels:
        v = noise.get(ch, noise.get(_kind(ch), defaults[_kind(ch)]))
        if isinstance(v, bool) or not (isinstance(v, int | float) and np.isfinite(v) and v > 0):
            raise ValueError(f"{source}: noise[{ch!r}] must be a finite number > 0, got {v!r}")
        out[ch] = float(v)
    return out


def read_table(path: Path, known, required) -> dict[str, np.ndarray]:
    """{column: values} of a CSV with a header row; ValueError naming the file, column and line for
    an empty file, unknown, missing or repeated columns, short rows and non-numbers."""
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise ValueError(f"{path}: empty file (expected a header row with {list(required)})") from None
        rows = list(reader)
    unknown = [h for h in header if h not in known]
    if unknown:
        raise ValueError(f"{path}: unknown column(s) {unknown}; valid columns: {sorted(known)}")
    missing = [c for c in required if c not in header]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing} (required: {list(required)})")
    if len(set(header)) != len(header):
        raise ValueError(f"{path}: repeated column names in the header {header}")
    data = {h: np.empty(len(rows)) for h in header}
    for i, row in enumerate(rows):
        if len(row) != len(header):
            raise ValueError(f"{path}: line {i + 2} has {len(row)} fields, the header has {len(header)}")
        for h, cell in zip(header, row, strict=True):
            try:
                data[h][i] = float(cell)
            except ValueError:
                raise ValueError(f"{path}: column {h!r}, line {i + 2}: not a number: {cell!r}") from None
    return data


def write_table(path: Path, cols: dict[str, np.ndarray]) -> Path:
    """Write {column: values} as a CSV with a header row."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        w.writerows(np.column_stack(list(cols.values())).tolist())
    return path


class Samples:
    """Validation shared by the experiment kinds: a uniform time base and plausible columns.

    Subclasses are frozen dataclasses with ``name``, ``noise``, ``weight`` and ``rows`` fields and a
    ``time`` array, and define :meth:`column_table` ({column: (unit, plausible range, hint)}) and
    their CSV layout (:meth:`_csv_fields`, :meth:`_csv_columns`).
    """

    def column_table(self) -> dict:
        raise NotImplementedError

    @classmethod
    def _csv_fields(cls, path: Path) -> dict:
        """The fields of an experiment read from the CSV at ``path`` (all but name, noise, weight, rows)."""
        raise NotImplementedError

    def _csv_columns(self) -> dict[str, np.ndarray]:
        """{column: values} of the CSV layout :meth:`_csv_fields` reads."""
        raise NotImplementedError

    @classmethod
    def from_csv(
        cls,
        path: str | Path,
        *,
        noise: Mapping[str, float] | None = None,
        weight: float = 1.0,
        name: str | None = None,
    ) -> Self:
        """Read a CSV with the columns of the module table (header names exactly as listed)."""
        path = Path(path)
        fields = cls._csv_fields(path)
        return cls(name=name or str(path), **fields, noise=noise or {}, weight=weight, rows="line")

    def to_csv(self, path: str | Path) -> Path:
        """Write the experiment in the CSV layout :meth:`from_csv` reads."""
        return write_table(Path(path), self._csv_columns())

    def unit(self, channel: str) -> str:
        """Unit of a measured channel."""
        return self.column_table()[channel][0]

    def _row(self, i: int) -> str:
        return f"line {i + 2}" if self.rows == "line" else f"row {i}"

    def _column(self, name: str, values, n: int) -> np.ndarray:
        arr = np.asarray(values, dtype=float)
        if arr.ndim != 1 or arr.shape[0] != n:
            raise ValueError(
                f"{self.name}: column {name!r} must have {n} rows (like 'time'), got shape {arr.shape}"
            )
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(
                f"{self.name}: column {name!r}, {self._row(bad[0])}: value is {float(arr[bad[0]])} (NaN/inf)"
            )
        unit, (lo, hi), hint = self.column_table()[name]
        out = np.flatnonzero((arr < lo) | (arr > hi))
        if out.size:
            i = out[0]
            raise ValueError(
                f"{self.name}: column {name!r}, {self._row(i)}: {arr[i]:g} {unit} is outside the plausible "
                f"range [{lo:g}, {hi:g}] {unit}; {hint}".rstrip("; ")
            )
        return np.ascontiguousarray(arr)

    def _check_time(self, t: np.ndarray) -> None:
        if t.shape[0] < 2:
            raise ValueError(f"{self.name}: column 'time' needs at least 2 rows, got {t.shape[0]}")
        d = np.diff(t)
        bad = np.flatnonzero(d <= 0.0)
        if bad.size:
            i = bad[0] + 1
            raise ValueError(
                f"{self.name}: column 'time', {self._row(i)}: time must increase, "
                f"got {t[i]:g} s after {t[i - 1]:g} s"
            )
        dt = (t[-1] - t[0]) / (t.shape[0] - 1)
        if dt > MAX_DT:
            raise ValueError(
                f"{self.name}: column 'time': sample spacing {dt:g} s exceeds {MAX_DT:g} s; is time in ms?"
            )
        off = np.flatnonzero(np.abs(d - dt) > UNIFORM_TOL * dt)
        if off.size:
            i = off[0] + 1
            raise ValueError(
                f"{self.name}: column 'time', {self._row(i)}: samples must be uniformly spaced "
                f"(mean step {dt:g} s, this step {d[i - 1]:g} s); resample the data first"
            )

    @property
    def dt(self) -> float:
        """Sample spacing [s]."""
        return float((self.time[-1] - self.time[0]) / (self.time.shape[0] - 1))

    @property
    def duration(self) -> float:
        """Span of the record [s]."""
        return float(self.time[-1] - self.time[0])

    @property
    def n_samples(self) -> int:
        return int(self.time.shape[0])


@dataclass(frozen=True)
class Experiment(Samples):
    """One measured run of the planar spine.

    Attributes:
        name: label used in reports and error messages (the file name for CSVs).
        time: (n,) sample times [s], uniformly spaced.
        voltage_right, voltage_left: (n,) wire voltages [V]; row k is held over [t_k, t_k+1).
        measured: {channel: (n,) trace}; must contain ``"angle"`` (see :data:`CHANNELS`).
        tip_force: (n, 2) global force on the top disk [N] (held like the voltages) or None.
        noise: {channel: standard deviation}; residuals are divided by it (default
            :data:`DEFAULT_NOISE` by channel kind).
        weight: extra weight of the whole experiment in the fit (> 0).
        rows: how error messages name rows: ``"line"`` (CSV line = index + 2) or ``"index"``.
    """

    name: str
    time: np.ndarray
    voltage_right: np.ndarray
    voltage_left: np.ndarray
    measured: Mapping[str, np.ndarray]
    tip_force: np.ndarray | None = None
    noise: Mapping[str, float] = field(default_factory=dict)
    weight: float = 1.0
    rows: str = "index"

    def __post_init__(self):
        s = object.__setattr__
        cols = {"time": self.time, "voltage_right": self.voltage_right, "voltage_left": self.voltage_left}
        unknown = set(self.measured) - set(CHANNELS)
        if unknown:
            raise ValueError(
                f"{self.name}: unknown measured column(s) {sorted(unknown)}; valid: {list(CHANNELS)}"
            )
        if "angle" not in self.measured:
            raise ValueError(f"{self.name}: missing column 'angle' (the measured bending angle [deg])")
        cols.update(self.measured)
        if self.tip_force is not None:
            tf = np.asarray(self.tip_force, dtype=float)
            if tf.ndim != 2 or tf.shape[1] != 2:
                raise ValueError(f"{self.name}: tip_force must have shape (n, 2), got {tf.shape}")
            cols.update(tip_force_x=tf[:, 0], tip_force_y=tf[:, 1])
        n = len(np.asarray(self.time))
        arrays = {k: self._column(k, v, n) for k, v in cols.items()}
        self._check_time(arrays["time"])
        s(self, "time", arrays["time"])
        s(self, "voltage_right", arrays["voltage_right"])
        s(self, "voltage_left", arrays["voltage_left"])
        s(self, "measured", {k: arrays[k] for k in CHANNELS if k in self.measured})
        if self.tip_force is not None:
            s(self, "tip_force", np.column_stack([arrays["tip_force_x"], arrays["tip_force_y"]]))
        s(self, "noise", noise_levels(self.name, self.noise, self.measured))
        if not (isinstance(self.weight, int | float) and np.isfinite(self.weight) and self.weight > 0):
            raise ValueError(f"{self.name}: weight must be a finite number > 0, got {self.weight!r}")

    def column_table(self) -> dict:
        return CHANNELS | INPUTS

    # ------------------------------------------------------------------ I/O
    @classmethod
    def _csv_fields(cls, path: Path) -> dict:
        data = read_table(path, set(CHANNELS) | set(INPUTS), REQUIRED)
        if ("tip_force_x" in data) != ("tip_force_y" in data):
            raise ValueError(f"{path}: give both tip_force_x and tip_force_y, or neither")
        tip = np.column_stack([data["tip_force_x"], data["tip_force_y"]]) if "tip_force_x" in data else None
        return dict(
            time=data["time"],
            voltage_right=data["voltage_right"],
            voltage_left=data["voltage_left"],
            measured={c: data[c] for c in CHANNELS if c in data},
            tip_force=tip,
        )

    def _csv_columns(self) -> dict[str, np.ndarray]:
        cols = {"time": self.time, "voltage_right": self.voltage_right, "voltage_left": self.voltage_left}
        cols.update(self.measured)
        if self.tip_force is not None:
            cols.update(tip_force_x=self.tip_force[:, 0], tip_force_y=self.tip_force[:, 1])
        return cols
