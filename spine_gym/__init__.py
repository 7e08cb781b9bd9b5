"""spine_gym: a physically faithful SMA-actuated robotic spine for control and RL research.

``spine_gym.simulate`` runs the jitted model (MODEL.md); ``import spine_gym`` also registers the
Gymnasium environment ``SmaSpine-v0``.
"""

from . import _kernel_cache  # noqa: F401 -- first: clears stale numba caches before any kernel loads
from .layout import Module, SpineLayout, WireGroup
from .params import ModelParams, SolverOptions, alternative, baseline
from .simulate import SimulationError, SimulationResult, simulate
from .simulate_spatial import SpatialResult
from . import envs  # noqa: F401 - registers SmaSpine-v0

__all__ = [
    "ModelParams",
    "Module",
    "SpatialResult",
    "SpineLayout",
    "WireGroup",
    "SolverOptions",
    "SimulationError",
    "SimulationResult",
    "alternative",
    "baseline",
    "simulate",
]
__version__ = "0.1.0"
