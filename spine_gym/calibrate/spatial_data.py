"""Measured experiments on a spatial spine (a four-wire module or a chain): one voltage per wire.

The spatial counterpart of :class:`~spine_gym.calibrate.data.Experiment`, with the same
conventions (header names exactly as listed, SI units except angles, zero-order-hold inputs, a
uniform time base) and the same named errors. Wires are numbered in the layout's voltage order
(:attr:`spine_gym.SpineLayout.wire_labels`; the seed module: wire j at azimuth 90° j):

| column | unit | required | meaning |
|---|---|---|---|
| ``time`` | s | yes | sample times, uniformly spaced (≤ 1 s apart) |
| ``voltage_0`` … ``voltage_<W-1>`` | V | yes, all W | voltage on wire j, held until the next row |
| ``bend_1``, ``bend_2`` | deg | both, or the tip | tip bending vector (Θ cos β, Θ sin β), SPATIAL.md §2 |
| ``tip_x``, ``tip_y``, ``tip_z`` | m | all three, or the bend | tip position (global frame, z up) |
| ``temperature_<j>`` | K | no | temperature of wire j (any subset of wires) |
| ``resistance_<j>`` | Ohm | no | resistance of one wire of group j |
| ``tip_force_x``, ``tip_force_y``, ``tip_force_z`` | N | no | force on the top disk, held like the voltages |

Bad input raises ``ValueError`` naming the source, the column and the row, as the planar CSVs:
missing, misspelled or repeated columns, voltage columns that do not run 0 … W−1, non-increasing
or non-uniform time, NaN/inf, non-numbers, and magnitudes that betray a wrong unit (voltages above
100 V: mV?, temperatures below 150 K: °C?, |bend| above 180°, |tip| above 2 m: mm?, forces above
20 N: mN?, resistances outside 1 mΩ–1 kΩ, a spacing above 1 s: ms?).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .data import CHANNELS, INPUTS, Samples, noise_levels, read_table

__all__ = ["SpatialExperiment", "SPATIAL_DEFAULT_NOISE", "spatial_channels"]

# default noise level (standard deviation) per channel kind: bend [deg], tip [m], temperature [K],
# resistance [Ohm]
SPATIAL_DEFAULT_NOISE = {"bend": 0.5, "tip": 1e-3, "temperature": 1.0, "resistance": 0.01}
BEND = ("bend_1", "bend_2")
TIP = ("tip_x", "tip_y", "tip_z")
FORCE = ("tip_force_x", "tip_force_y", "tip_force_z")
MAX_WIRES = 400  # the layout's limit (100 modules of at most 4 wires in the factories)
_WIRE_COLUMN = re.compile(r"^(voltage|temperature|resistance)_(\d+)$")


def spatial_channels(n_wires: int) -> dict:
    """{measured channel: (unit, plausible range, hint)} of a spine with ``n_wires`` wires."""
    out = {
        "bend_1": ("deg", (-180.0, 180.0), "is it in millidegrees?"),
        "bend_2": ("deg", (-180.0, 180.0), "is it in millidegrees?"),
        "tip_x": ("m", (-2.0, 2.0), "is it in mm?"),
        "tip_y": ("m", (-2.0, 2.0), "is it in mm?"),
        "tip_z": ("m", (-2.0, 2.0), "is it in mm?"),
    }
    for j in range(n_wires):
        out[f"temperature_{j}"] = CHANNELS["temperature_right"]
        out[f"resistance_{j}"] = CHANNELS["resistance_right"]
    return out


def _inputs(n_wires: int) -> dict:
    out = {"time": INPUTS["time"]}
    for j in range(n_wires):
        out[f"voltage_{j}"] = INPUTS["voltage_right"]
    for c in FORCE:
        out[c] = ("N", (-20.0, 20.0), "is it in mN?")
    return out


@dataclass(frozen=True)
class SpatialExperiment(Samples):
    """One measured run of a spatial spine.

    Attributes:
        name: label used in reports and error messages (the file name for CSVs).
        time: (n,) sample times [s], uniformly spaced.
        voltages: (n, W) voltage on each wire [V]; row k is held over [t_k, t_k+1).
        measured: {channel: (n,) trace}; the bending vector (``bend_1`` and ``bend_2``) or the tip
            position (``tip_x``, ``tip_y``, ``tip_z``) or both, plus any ``temperature_<j>`` and
            ``resistance_<j>`` (see :func:`spatial_channels`).
        tip_force: (n, 3) global force on the top disk [N] (held like the voltages) or None.
        noise: {channel or kind: standard deviation}; kinds ``bend``, ``tip``, ``temperature``,
            ``resistance`` (defaults :data:`SPATIAL_DEFAULT_NOISE`).
        weight: extra weight of the whole experiment in the fit (> 0).
        rows: how error messages name rows: ``"line"`` (CSV line = index + 2) or ``"index"``.
    """

    name: str
    time: np.ndarray
    voltages: np.ndarray
    measured: Mapping[str, np.ndarray]
    tip_force: np.ndarray | None = None
    noise: Mapping[str, float] = field(default_factory=dict)
    weight: float = 1.0
    rows: str = "index"

    def __post_init__(self):
        s = object.__setattr__
        n = len(np.asarray(self.time))
        volts = np.asarray(self.voltages, dtype=float)
        if volts.ndim != 2 or volts.shape[0] != n or not 1 <= volts.shape[1] <= MAX_WIRES:
            raise ValueError(
                f"{self.name}: voltages must have shape ({n}, W) with 1 <= W <= {MAX_WIRES} (one column per "
                f"wire), got {volts.shape}"
            )
        nw = volts.shape[1]
        table = spatial_channels(nw)
        unknown = set(self.measured) - set(table)
        if unknown:
            raise ValueError(
                f"{self.name}: unknown measured column(s) {sorted(unknown)} for {nw} wires; valid: "
                f"bend_1, bend_2, tip_x, tip_y, tip_z, temperature_<j>, resistance_<j> with j in 0..{nw - 1}"
            )
        self._check_outputs(set(self.measured))
        cols = {"time": self.time, **{f"voltage_{j}": volts[:, j] for j in range(nw)}, **self.measured}
        if self.tip_force is not None:
            tf = np.asarray(self.tip_force, dtype=float)
            if tf.ndim != 2 or tf.shape[1] != 3:
                raise ValueError(f"{self.name}: tip_force must have shape (n, 3), got {tf.shape}")
            cols.update(zip(FORCE, tf.T, strict=True))
        s(self, "voltages", volts)  # column_table needs the wire count
        arrays = {k: self._column(k, v, n) for k, v in cols.items()}
        self._check_time(arrays["time"])
        s(self, "time", arrays["time"])
        s(self, "voltages", np.column_stack([arrays[f"voltage_{j}"] for j in range(nw)]))
        s(self, "measured", {k: arrays[k] for k in table if k in self.measured})
        if self.tip_force is not None:
            s(self, "tip_force", np.column_stack([arrays[c] for c in FORCE]))
        s(self, "noise", noise_levels(self.name, self.noise, self.measured, table, SPATIAL_DEFAULT_NOISE))
        if not (isinstance(self.weight, int | float) and np.isfinite(self.weight) and self.weight > 0):
            raise ValueError(f"{self.name}: weight must be a finite number > 0, got {self.weight!r}")

    def _check_outputs(self, have: set) -> None:
        for group in (BEND, TIP):
            if have & set(group) and not set(group) <= have:
                raise ValueError(
                    f"{self.name}: missing column(s) {[c for c in group if c not in have]} (give all of "
                    f"{list(group)} or none)"
                )
        if not (set(BEND) <= have or set(TIP) <= have):
            raise ValueError(
                f"{self.name}: missing column(s): the bending vector {list(BEND)} [deg] or the tip "
                f"position {list(TIP)} [m] (at least one of the two)"
            )

    def column_table(self) -> dict:
        nw = self.n_wires
        return spatial_channels(nw) | _inputs(nw)

    @property
    def n_wires(self) -> int:
        return int(np.shape(self.voltages)[1])

    # ------------------------------------------------------------------ I/O
    @classmethod
    def _csv_fields(cls, path: Path) -> dict:
        nw = _wire_count(path)
        data = read_table(path, set(spatial_channels(nw)) | set(_inputs(nw)), ("time", "voltage_0"))
        got = [c for c in FORCE if c in data]
        if got and len(got) != 3:
            raise ValueError(f"{path}: give all of {list(FORCE)}, or none")
        return dict(
            time=data["time"],
            voltages=np.column_stack([data[f"voltage_{j}"] for j in range(nw)]),
            measured={c: data[c] for c in spatial_channels(nw) if c in data},
            tip_force=np.column_stack([data[c] for c in FORCE]) if got else None,
        )

    def _csv_columns(self) -> dict[str, np.ndarray]:
        cols = {"time": self.time, **{f"voltage_{j}": self.voltages[:, j] for j in range(self.n_wires)}}
        cols.update(self.measured)
        if self.tip_force is not None:
            cols.update(zip(FORCE, self.tip_force.T, strict=True))
        return cols


def _wire_count(path: Path) -> int:
    """W from the header's voltage columns, which must be voltage_0 … voltage_<W-1>."""
    with path.open(newline="") as fh:
        header = [h.strip() for h in fh.readline().split(",")]
    if header == [""]:
        raise ValueError(f"{path}: empty file (expected a header row with ['time', 'voltage_0', ...])")
    idx = sorted(int(m.group(2)) for h in header if (m := _WIRE_COLUMN.match(h)) and m.group(1) == "voltage")
    if not idx:
        raise ValueError(f"{path}: missing column(s) ['voltage_0', ...] (one voltage column per wire)")
    if idx != list(range(len(idx))):
        missing = sorted(set(range(max(idx) + 1)) - set(idx))
        raise ValueError(
            f"{path}: missing column(s) {[f'voltage_{j}' for j in missing]} (voltage columns must run "
            f"voltage_0 … voltage_<W-1>, one per wire)"
        )
    return len(idx)
