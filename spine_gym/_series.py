"""Input series and the simulation error shared by the planar and the spatial ``simulate``."""

from __future__ import annotations

import math

import numpy as np

from .physics import columns as L

V_MAX_ALLOWED = 100.0  # [V] sanity bound on a wire voltage


class SimulationError(RuntimeError):
    """The model could not advance (a solver did not converge, a non-finite value appeared…)."""

    def __init__(self, status: int, time: float):
        self.status = int(status)
        self.time = float(time)
        super().__init__(f"simulation failed at t = {time:.4f} s: {L.STATUS_TEXT.get(status, status)}")


def output_steps(duration, dt) -> int:
    """Output steps of a run of ``duration`` seconds at ``dt`` (at least one); ValueError unless
    ``dt`` is in (0, 1] s and ``duration`` a finite number > 0 s."""
    if not (isinstance(dt, int | float) and math.isfinite(dt) and 0.0 < dt <= 1.0):
        raise ValueError(f"dt must be in (0, 1] s, got {dt!r}")
    if not (isinstance(duration, int | float) and math.isfinite(duration) and duration > 0.0):
        raise ValueError(f"duration must be a finite number > 0 s, got {duration!r}")
    return max(1, int(round(duration / dt)))


def as_series(name: str, value, n: int, dt: float, shape: tuple[int, ...]) -> np.ndarray:
    """Constant, array sampled at dt (n rows), or callable of t → array of shape (n, *shape)."""
    if callable(value):
        arr = np.array([np.asarray(value(k * dt), dtype=float) for k in range(n)], dtype=float)
        if arr.shape != (n, *shape):
            raise ValueError(f"{name}(t) must return shape {shape or 'scalar'}, got {arr.shape[1:]}")
    else:
        arr = np.asarray(value, dtype=float)
        if arr.shape == shape:
            arr = np.broadcast_to(arr, (n, *shape))
        elif arr.shape != (n, *shape):
            raise ValueError(
                f"{name} must be a constant of shape {shape or '()'}, an array of shape {(n, *shape)} "
                f"sampled at dt, or a callable of time; got shape {arr.shape}"
            )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got NaN or inf")
    return np.ascontiguousarray(arr)


def vertex_loads(n_seg: int, n: int, dt: float, dim: int, tip_force=None, vertex_forces=None) -> np.ndarray:
    """Vertex-force programme (n or 1, N, dim) [N] from a tip force and/or forces at every vertex.

    ``tip_force``: None, (dim,), (n, dim) or callable t → (dim,) — global force on the top disk.
    ``vertex_forces``: None, (N, dim), (n, N, dim) or callable t → (N, dim) — force at vertex P_k,
    k = 0 (the tip) … N−1 (the base P_N is clamped). One row when both are constant, else n rows.
    """
    constant = (tip_force is None or np.shape(tip_force) == (dim,)) and (
        vertex_forces is None or np.shape(vertex_forces) == (n_seg, dim)
    )
    rows = 1 if constant else n
    loads = np.zeros((rows, n_seg, dim))
    if vertex_forces is not None:
        loads += as_series("vertex_forces", vertex_forces, rows, dt, (n_seg, dim))
    if tip_force is not None:
        loads[:, 0, :] += as_series("tip_force", tip_force, rows, dt, (dim,))
    return loads


class Trajectory:
    """What the planar and the spatial results share: time-indexed numpy trajectories."""

    def to_dict(self) -> dict[str, np.ndarray]:
        """The trajectories as a dict of numpy arrays (scalars, params and the final state left out)."""
        return {k: v for k, v in self.__dict__.items() if isinstance(v, np.ndarray) and k != "final_state"}

    def at(self, t: float) -> int:
        """Row index of the sample nearest to time ``t`` [s]."""
        return int(np.argmin(np.abs(self.time - t)))

    def __len__(self) -> int:
        return self.time.shape[0]
