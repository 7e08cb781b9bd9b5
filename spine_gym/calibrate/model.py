"""The model side of a fit: simulate an experiment, weighted residuals, candidates in parallel.

Candidates are simulated on a thread pool: the time loop (:func:`spine_gym.physics.planar.run.run`) is
a ``nogil`` numba kernel, so threads run it on all cores while only the short Python set-up of
each run holds the GIL. Every simulation is independent and deterministic, so a fit gives the same
numbers with one worker or many.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..layout import SpineLayout
from ..params import ModelParams, SolverOptions
from ..simulate import SimulationError, SimulationResult, simulate
from ..simulate_spatial import SpatialResult, simulate_spatial
from ..uncertainty import apply_offsets
from .data import CHANNELS, Experiment, noise_levels
from .parameters import FitParameter
from .spatial_data import SPATIAL_DEFAULT_NOISE, SpatialExperiment, spatial_channels

__all__ = [
    "simulate_experiment",
    "synthetic_experiment",
    "synthetic_spatial_experiment",
    "Evaluator",
    "PENALTY",
]

PENALTY = 1e3  # residual (in noise units) given to every sample of a candidate the model cannot run
_ATTRIBUTE = {"angle": "angle_deg"}  # SimulationResult attribute per channel (others: same name)
# SpatialResult (attribute, column) per spatial channel kind
_SPATIAL = {"bend_1": ("tip_bending_deg", 0), "bend_2": ("tip_bending_deg", 1), "tip_x": ("tip_position", 0),
            "tip_y": ("tip_position", 1), "tip_z": ("tip_position", 2)}  # fmt: skip


def simulate_experiment(
    params: ModelParams | SpineLayout,
    exp: Experiment | SpatialExperiment,
    solver: SolverOptions | None = None,
) -> SimulationResult | SpatialResult:
    """Run the model over the experiment's inputs, one output step per sample (zero-order hold).

    A :class:`SpatialExperiment` needs a :class:`SpineLayout` with as many wires as it has voltage
    columns; a planar :class:`Experiment` a ModelParams."""
    tip = None if exp.tip_force is None else exp.tip_force[:-1]
    if isinstance(exp, SpatialExperiment):
        if not isinstance(params, SpineLayout) or params.n_wires != exp.n_wires:
            raise ValueError(
                f"{exp.name}: a spatial experiment with {exp.n_wires} voltage columns needs a SpineLayout "
                f"with {exp.n_wires} wires as the start, got {_describe(params)}"
            )
        return simulate_spatial(
            exp.n_samples * exp.dt - exp.dt,
            exp.voltages[:-1],
            layout=params,
            dt=exp.dt,
            tip_force=tip,
            solver=solver,
        )
    if not isinstance(params, ModelParams):
        raise ValueError(
            f"{exp.name}: a planar experiment needs a ModelParams start, got {_describe(params)}"
        )
    return simulate(
        exp.n_samples * exp.dt - exp.dt,
        exp.voltage_right[:-1],
        exp.voltage_left[:-1],
        dt=exp.dt,
        tip_force=tip,
        params=params,
        solver=solver,
    )


def _describe(params) -> str:
    if isinstance(params, SpineLayout):
        return f"a SpineLayout with {params.n_wires} wires"
    return type(params).__name__


def channel(result: SimulationResult | SpatialResult, name: str) -> np.ndarray:
    """The simulated trace of a measured channel."""
    if isinstance(result, SpatialResult):
        if name in _SPATIAL:
            attr, col = _SPATIAL[name]
            return getattr(result, attr)[:, col]
        kind, j = name.rsplit("_", 1)
        return getattr(result, kind)[:, int(j)]
    return getattr(result, _ATTRIBUTE.get(name, name))


def synthetic_spatial_experiment(
    layout: SpineLayout,
    time: np.ndarray,
    voltages,
    *,
    channels: Sequence[str] = ("bend_1", "bend_2"),
    noise: dict[str, float] | None = None,
    rng: np.random.Generator | None = None,
    tip_force: np.ndarray | None = None,
    name: str = "synthetic",
) -> SpatialExperiment:
    """A "measured" spatial experiment made by the model with ``layout`` plus Gaussian noise.

    ``voltages``: a (W,) constant or an (n, W) array on ``time``; ``channels`` among
    :func:`~spine_gym.calibrate.spatial_data.spatial_channels`; ``noise`` maps channels or kinds
    (``bend``, ``tip``, ``temperature``, ``resistance``) to standard deviations (default
    :data:`~spine_gym.calibrate.spatial_data.SPATIAL_DEFAULT_NOISE`); ``rng`` draws the noise (default
    seed 0).
    """
    time = np.asarray(time, dtype=float)
    n, nw = time.shape[0], layout.n_wires
    volts = np.broadcast_to(np.asarray(voltages, dtype=float), (n, nw)).copy()
    table = spatial_channels(nw)
    unknown = set(channels) - set(table)
    if unknown:
        raise ValueError(f"channels: unknown channel(s) {sorted(unknown)}; valid: {list(table)}")
    levels = noise_levels(name, noise or {}, channels, table, SPATIAL_DEFAULT_NOISE)
    blank = {"bend_1": np.zeros(n), "bend_2": np.zeros(n)}
    res = simulate_experiment(layout, SpatialExperiment(name, time, volts, blank, tip_force=tip_force))
    rng = rng or np.random.default_rng(0)
    measured = {c: channel(res, c) + rng.normal(0.0, levels[c], n) for c in channels}
    return SpatialExperiment(name, time, volts, measured, tip_force=tip_force, noise=levels)


def synthetic_experiment(
    params: ModelParams,
    time: np.ndarray,
    voltage_right,
    voltage_left,
    *,
    channels: Sequence[str] = ("angle",),
    noise: dict[str, float] | None = None,
    rng: np.random.Generator | None = None,
    tip_force: np.ndarray | None = None,
    name: str = "synthetic",
) -> Experiment:
    """A "measured" experiment made by the model with ``params`` plus Gaussian noise.

    ``voltage_*`` are constants or (n,) arrays on ``time``; ``noise`` maps channels or kinds
    (``angle``, ``temperature``, ``resistance``) to standard deviations (default
    :data:`~spine_gym.calibrate.data.DEFAULT_NOISE`); ``rng`` draws the noise (default seed 0).
    """
    time = np.asarray(time, dtype=float)
    n = time.shape[0]
    v_r = np.broadcast_to(np.asarray(voltage_right, dtype=float), (n,)).copy()
    v_l = np.broadcast_to(np.asarray(voltage_left, dtype=float), (n,)).copy()
    chans = tuple(dict.fromkeys(("angle", *channels)))
    unknown = set(chans) - set(CHANNELS)
    if unknown:
        raise ValueError(f"channels: unknown channel(s) {sorted(unknown)}; valid: {list(CHANNELS)}")
    levels = noise_levels(name, noise or {}, chans)
    inputs = Experiment(name, time, v_r, v_l, {"angle": np.zeros(n)}, tip_force=tip_force)
    res = simulate_experiment(params, inputs)
    rng = rng or np.random.default_rng(0)
    measured = {c: channel(res, c) + rng.normal(0.0, levels[c], n) for c in chans}
    return Experiment(name, time, v_r, v_l, measured, tip_force=tip_force, noise=levels)


class Evaluator:
    """Weighted residuals of candidate parameter vectors, simulated in parallel.

    Candidates are vectors ``u`` in the unit box: parameter j is ``lower_j + u_j (upper_j −
    lower_j)``. The residual vector stacks, per experiment and measured channel, (model −
    measurement) / noise × sqrt(weight). ``on_simulation`` (if given) is called after every
    simulation with the number finished so far (progress bars).
    """

    def __init__(
        self,
        experiments: Sequence[Experiment | SpatialExperiment],
        parameters: Sequence[FitParameter],
        start: ModelParams | SpineLayout,
        solver: SolverOptions | None = None,
        n_workers: int | None = None,
        on_simulation=None,
    ):
        kind = SpatialExperiment if isinstance(start, SpineLayout) else Experiment
        if not experiments or not all(isinstance(e, kind) for e in experiments):
            raise ValueError(
                f"experiments must be a non-empty sequence of {kind.__name__} objects (a "
                f"{'SpineLayout' if kind is SpatialExperiment else 'ModelParams'} start)"
            )
        if kind is SpatialExperiment:
            for e in experiments:
                if e.n_wires != start.n_wires:
                    raise ValueError(
                        f"{e.name}: has {e.n_wires} voltage columns, the start layout {start.n_wires} wires"
                    )
        names = [e.name for e in experiments]
        if len(set(names)) != len(names):
            raise ValueError(f"experiment names must be unique, got {names}")
        n_workers = (os.cpu_count() or 1) if n_workers is None else n_workers
        if not (isinstance(n_workers, int) and 1 <= n_workers <= 256):
            raise ValueError(f"n_workers must be an integer in [1, 256], got {n_workers!r}")
        self.experiments = tuple(experiments)
        self.parameters = tuple(parameters)
        self.start = start
        self.solver = solver or SolverOptions()
        self.n_workers = n_workers
        self.lower = np.array([p.lower for p in parameters])
        self.upper = np.array([p.upper for p in parameters])
        self.start_values = np.array([p.value(start) for p in parameters])
        self.on_simulation = on_simulation
        self.n_simulations = 0
        self.n_failed = 0
        self.best_cost = np.inf
        self.best_u = self.to_unit(self.start_values)
        self._pool = ThreadPoolExecutor(n_workers) if n_workers > 1 else None
        self._cache: dict[bytes, np.ndarray] = {}

    # ------------------------------------------------------------------ coordinates
    def to_unit(self, values) -> np.ndarray:
        return (np.asarray(values, dtype=float) - self.lower) / (self.upper - self.lower)

    def to_values(self, u) -> np.ndarray:
        return self.lower + np.asarray(u, dtype=float) * (self.upper - self.lower)

    def params_at(self, u) -> ModelParams | SpineLayout:
        """The ModelParams (or SpineLayout) of unit-box point ``u`` (ValueError if it leaves the
        model's range)."""
        off = self.to_values(u) - self.start_values
        return apply_offsets(self.start, [p.direction for p in self.parameters], off)

    @property
    def n_residuals(self) -> int:
        return sum(e.n_samples * len(e.measured) for e in self.experiments)

    # ------------------------------------------------------------------ evaluation
    def _residual_block(self, params, exp) -> tuple[np.ndarray, bool]:
        m = exp.n_samples * len(exp.measured)
        if params is None:
            return np.full(m, PENALTY), False
        try:
            res = simulate_experiment(params, exp, self.solver)
        except SimulationError:
            return np.full(m, PENALTY), False
        w = np.sqrt(exp.weight)
        r = [(channel(res, c) - exp.measured[c]) * (w / exp.noise[c]) for c in exp.measured]
        return np.concatenate(r), True

    def _task(self, args) -> tuple[np.ndarray, bool]:
        return self._residual_block(*args)

    def residuals_many(self, us) -> np.ndarray:
        """(k, m) residuals of k candidates; all k × n_experiments simulations run in parallel."""
        us = np.atleast_2d(np.asarray(us, dtype=float))
        params = []
        for u in us:
            try:
                params.append(self.params_at(u))
            except ValueError:  # e.g. eps_T <= dsigma/E_M: a candidate outside the model's range
                params.append(None)
        tasks = [(p, e) for p in params for e in self.experiments]
        mapper = self._pool.map if self._pool is not None else map
        blocks = []
        for r, ok in mapper(self._task, tasks):
            blocks.append(r)
            self.n_simulations += 1
            self.n_failed += not ok
            if self.on_simulation is not None:
                self.on_simulation(self.n_simulations)
        ne = len(self.experiments)
        out = np.stack([np.concatenate(blocks[i * ne : (i + 1) * ne]) for i in range(len(us))])
        for u, r in zip(us, out, strict=True):
            cost = 0.5 * float(r @ r)
            self._cache[u.tobytes()] = r
            if cost < self.best_cost:
                self.best_cost, self.best_u = cost, u.copy()
        return out

    def residuals(self, u) -> np.ndarray:
        """(m,) residuals of one candidate (cached: the Jacobian at the same point reuses it)."""
        u = np.asarray(u, dtype=float)
        hit = self._cache.get(u.tobytes())
        return hit.copy() if hit is not None else self.residuals_many(u[None])[0]

    def jacobian(self, u, step=0.02, central: bool = False) -> np.ndarray:
        """(m, n) finite-difference Jacobian in unit-box coordinates, all columns in parallel.

        ``step``: a scalar or one step per parameter. Forward differences (backward where
        ``u + step`` leaves the box), or central differences (two-sided, clipped to the box; used
        for the covariance at the optimum).
        """
        u = np.asarray(u, dtype=float)
        n = u.shape[0]
        eye = np.diag(np.broadcast_to(np.asarray(step, dtype=float), (n,)))
        if central:
            lo = np.clip(u - eye, 0.0, 1.0)
            hi = np.clip(u + eye, 0.0, 1.0)
            r = self.residuals_many(np.vstack([hi, lo]))
            h = np.diag(hi - lo)
            return ((r[:n] - r[n:]) / h[:, None]).T
        sign = np.where(u + np.diag(eye) <= 1.0, 1.0, -1.0)
        pts = u + eye * sign[:, None]
        r0 = self.residuals(u)
        r = self.residuals_many(pts)
        return ((r - r0) / (np.diag(eye) * sign)[:, None]).T

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
