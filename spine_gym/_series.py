"""Input series and the simulation error shared by the planar and the spatial ``simulate``."""

from __future__ import annotations

import numpy as np

from .physics import layout as L

V_MAX_ALLOWED = 100.0  # [V] sanity bound on a wire voltage


class SimulationError(RuntimeError):
    """The model could not advance (a solver did not converge, a non-finite value appeared…)."""

    def __init__(self, status: int, time: float):
        self.status = int(status)
        self.time = float(time)
        super().__init__(f"simulation failed at t = {time:.4f} s: {L.STATUS_TEXT.get(status, status)}")


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
