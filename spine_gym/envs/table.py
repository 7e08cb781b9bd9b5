"""The declarative observation/info table of an environment: one place per entry.

Each environment is described by one tuple of :class:`Entry` (built by a function of its
configuration, e.g. ``spatial.table_3d``). From that table follow

* the columns of the per-step quantity row the jitted writer (:func:`.readout.finish_rows`)
  fills, and which info keys it returns (:attr:`Table.info_keys`, :meth:`Table.info_dict`);
* the observation: names, indices (:meth:`Table.obs_index`), bounds (:attr:`Table.low`,
  :attr:`Table.high`) and the gather map the writer uses (:attr:`Table.spec`);
* the sensor channels (delay line and noise) and the docstring tables
  (:meth:`Table.markdown_observation`).

Adding an observation entry is one edit: give an entry ``obs=(low, high)`` (or add a new entry
with an existing ``source``). The ``source`` names what the writer computes (:data:`SOURCES`):
physics readings of the probe row (``readout.PB_*``, measured: delayed and noisy in the
observation, true in the info) or step quantities (target, voltage, energy, ...).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from . import readout as ro

__all__ = ["Entry", "Table", "SOURCES", "SENSOR_SOURCES"]

# source -> (writer id, kind): "probe" = a slice of the probe row (a sensor reading); else a step quantity
SENSOR_SOURCES = {
    "angle": ro.PB_TIPB,  # planar bending angle [deg] = component 0 of the tip bending vector
    "tip_bending": ro.PB_TIPB,
    "tip_position": ro.PB_TIPP,
    "module_bending": ro.PB_MODB,
    "temperature": ro.PB_TEMP,
    "resistance": ro.PB_RES,
}
STEP_SOURCES = {
    "voltage": ro.Q_VOLT,
    "power": ro.Q_POWER,
    "action": ro.Q_ACTION,
    "force": ro.Q_FORCE,
    "target": ro.Q_TARGET,
    "preview": ro.Q_PREVIEW,
    "error": ro.Q_ERROR,
    "rate": ro.Q_RATE,
    "energy": ro.Q_ENERGY,
    "cost": ro.Q_COST,
    "time": ro.Q_TIME,
    "reward": ro.Q_REWARD,
    "reward_tracking": ro.Q_R_TRACK,
    "reward_energy": ro.Q_R_ENERGY,
    "measured_error": ro.Q_MERROR,
    "measured_preview_error": ro.Q_MPREVIEW,
}
SOURCES = (*SENSOR_SOURCES, *STEP_SOURCES)


@dataclass(frozen=True)
class Entry:
    """One quantity of the step row.

    Attributes:
        key: info key (``info[key]``); also the docstring label.
        source: what the writer puts there (one of :data:`SOURCES`).
        unit: unit text.
        doc: one-line description (docstring tables).
        names: component names in the observation (one per component; its length is the size).
        obs: ``(low, high)`` bounds of the components if observed, else None.
        info: returned in ``info`` (False: only in the observation).
        noise: ``sensor_noise`` key of a sensor entry (its standard deviation per component).
    """

    key: str
    source: str
    unit: str
    doc: str
    names: tuple[str, ...]
    obs: tuple[float, float] | None = None
    info: bool = True
    noise: str | None = None

    def __post_init__(self):
        if self.source not in SOURCES:
            raise ValueError(f"Entry {self.key!r}: source must be one of {SOURCES}, got {self.source!r}")
        if not self.names:
            raise ValueError(f"Entry {self.key!r}: names must name at least one component")

    @property
    def size(self) -> int:
        return len(self.names)

    @property
    def sensor(self) -> bool:
        return self.source in SENSOR_SOURCES


class Table:
    """The resolved table of one environment (see the module docstring).

    Args:
        entries: the env's entries, in row (and observation) order.
        task: key of the sensor entry the task tracks (its size d is the target's size).
        noise_sigma: ``sensor_noise`` key -> standard deviation.
    """

    def __init__(self, entries: Sequence[Entry], task: str, noise_sigma: dict[str, float]):
        self.entries = tuple(entries)
        keys = [e.key for e in self.entries]
        if len(set(keys)) != len(keys):
            raise ValueError(f"table keys must be unique, got {keys}")
        self.cols: dict[str, slice] = {}
        c = 0
        for e in self.entries:
            self.cols[e.key] = slice(c, c + e.size)
            c += e.size
        self.width = c
        self.task = self._entry(task)
        if not self.task.sensor:
            raise ValueError(f"task must be a sensor entry, got {task!r}")
        self.task_dim = self.task.size
        observed = [e for e in self.entries if e.obs is not None]
        self.obs_names = tuple(n for e in observed for n in e.names)
        self.obs_dim = len(self.obs_names)
        self.obs_cols = np.array([c for e in observed for c in range(*self._range(e))], dtype=np.int64)
        self.low = np.array([e.obs[0] for e in observed for _ in e.names], dtype=np.float32)
        self.high = np.array([e.obs[1] for e in observed for _ in e.names], dtype=np.float32)
        sensors = [e for e in self.entries if e.sensor]
        self.n_channels = sum(e.size for e in sensors)
        self.info_keys = tuple(e.key for e in self.entries if e.info)
        infos = [e for e in self.entries if e.info]
        # the info entries' row columns: an index for a scalar, a slice for a vector
        self._info_cols = tuple(
            (e.key, self.cols[e.key].start if e.size == 1 else self.cols[e.key]) for e in infos
        )
        self._scalar_cols = np.array([c for _, c in self._info_cols if isinstance(c, int)], dtype=np.int64)
        self.info_key_set = frozenset(self.info_keys)
        self.info_index = tuple((slice(None), c) for _, c in self._info_cols)  # into a block (n, width)
        self._sensors = sensors
        self._noise_sigma = dict(noise_sigma)

    def _entry(self, key: str) -> Entry:
        for e in self.entries:
            if e.key == key:
                return e
        raise ValueError(f"no entry {key!r} in the table; keys: {[e.key for e in self.entries]}")

    def _range(self, e: Entry) -> tuple[int, int]:
        s = self.cols[e.key]
        return s.start, s.stop

    # ------------------------------------------------------------------ indices
    def obs_index(self, key: str) -> slice:
        """Observation indices of entry ``key`` (a slice; ValueError if it is not observed)."""
        start = 0
        for e in self.entries:
            if e.obs is None:
                continue
            if e.key == key:
                return slice(start, start + e.size)
            start += e.size
        raise ValueError(
            f"{key!r} is not an observed entry; observed: {[e.key for e in self.entries if e.obs]}"
        )

    def has_obs(self, key: str) -> bool:
        return any(e.key == key and e.obs is not None for e in self.entries)

    # ------------------------------------------------------------------ the writer's maps
    def spec_arrays(self, probe_offsets: dict[int, int]) -> dict[str, np.ndarray]:
        """Integer maps and noise of the jitted writer.

        Args:
            probe_offsets: ``PB_*`` id -> its column in this env's probe row.

        Returns:
            ``qcol`` (N_Q,) row column of each step quantity or -1; ``chan_src`` / ``chan_dst``
            (C,) probe column and row column of each sensor channel; ``sigma`` (C,) noise standard
            deviations; ``obs_cols``; ``task`` = [row column, channel, size] of the tracked entry.
        """
        qcol = np.full(ro.N_Q, -1, dtype=np.int64)
        for e in self.entries:
            if not e.sensor:
                qcol[STEP_SOURCES[e.source]] = self.cols[e.key].start
        src, dst, sigma = [], [], []
        task_chan = -1
        for e in self._sensors:
            if e is self.task:
                task_chan = len(src)
            p0 = probe_offsets[SENSOR_SOURCES[e.source]]
            s = self._noise_sigma.get(e.noise, 0.0) if e.noise else 0.0
            for q in range(e.size):
                src.append(p0 + q)
                dst.append(self.cols[e.key].start + q)
                sigma.append(s)
        task = np.array([self.cols[self.task.key].start, task_chan, self.task_dim], dtype=np.int64)
        return {
            "qcol": qcol,
            "chan_src": np.array(src, dtype=np.int64),
            "chan_dst": np.array(dst, dtype=np.int64),
            "sigma": np.array(sigma, dtype=np.float64),
            "obs_cols": self.obs_cols,
            "task": task,
        }

    def info_dict(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """Info arrays of the step rows ``rows`` (n, width): scalars (n,), vectors (n, size) (views)."""
        return {key: rows[ix] for key, ix in zip(self.info_keys, self.info_index, strict=True)}

    def row_dicts(self, rows: np.ndarray) -> list[dict]:
        """One info dict per step row of ``rows`` (n, width), as a single env returns it: scalars
        as Python floats, vectors as (size,) arrays. The vectors are views of ``rows``: pass a
        block that is not written again (a fresh copy)."""
        scalars = iter(rows[:, self._scalar_cols].T.tolist())  # per scalar key, its n values
        columns = [next(scalars) if isinstance(c, int) else list(rows[:, c]) for _, c in self._info_cols]
        keys = self.info_keys
        return [dict(zip(keys, values, strict=True)) for values in zip(*columns, strict=True)]

    def row_dict(self, row: np.ndarray) -> dict:
        """:meth:`row_dicts` of one step row ``row`` (width,)."""
        scalars = iter(row[self._scalar_cols].tolist())
        return {key: next(scalars) if isinstance(c, int) else row[c] for key, c in self._info_cols}

    # ------------------------------------------------------------------ documentation
    def markdown_observation(self) -> str:
        """The observation table (index, name, description, unit, low, high) as Markdown."""
        lines = [
            "| index | observation | description | unit | low | high |",
            "|-------|-------------|-------------|------|-----|------|",
        ]
        i = 0
        for e in self.entries:
            if e.obs is None:
                continue
            for n in e.names:
                lines.append(f"| {i} | ``{n}`` | {e.doc} | {e.unit} | {e.obs[0]:g} | {e.obs[1]:.4g} |")
                i += 1
        return "\n".join(lines)

    def markdown_info(self) -> str:
        """The info keys (key, shape, description, unit) as Markdown."""
        lines = ["| key | shape | description | unit |", "|-----|-------|-------------|------|"]
        for e in self.entries:
            if e.info:
                shape = "()" if e.size == 1 else f"({e.size},)"
                lines.append(f"| ``{e.key}`` | {shape} | {e.doc} | {e.unit} |")
        return "\n".join(lines)
