"""Buckling margin of a spine: the critical tip force and payload in a given state (MODEL.md §4.9).

The model's shape is an equilibrium of the segmented line (§4) with the wire moment following the
shape (§5). Whether it is stable is decided from the linearisation of the shape map (see
:mod:`spine_gym.physics.stability`); the solver reports an unstable equilibrium as
``layout.ERR_BUCKLING``. This module answers the design question behind it: how much more load
does a spine in a given state carry before it buckles?

At a frozen shape the Jacobian J of the shape map is affine in the loads, J(P) = J₀ + P J₁ for an
extra force P along a direction at the top disk, so the critical P is the smallest positive root
of det(I − J₀ − P J₁) = 0: a generalised eigenvalue problem (linearised buckling about the current
configuration). For the straight spine under vertical loads this is exactly the bifurcation load
of the segmented model; for a bent spine it is the classical estimate that ignores the further
change of shape under the extra load. Without wires and for the straight tube it converges, as the
segments get shorter, to the Euler column of §4.9: π² E I / (4 L²) reduced by the tube's own
weight and the top disk.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .params import ModelParams, SolverOptions
from .physics import columns as L
from .physics.planar import columns as PL
from .physics.planar.stability import equilibrium_jacobian
from .physics.planar.tube import shape_jacobian
from .physics.stability import euler_critical_load, unstable_modes
from .simulate import SimulationError, initial_state

__all__ = ["BucklingMargin", "critical_load", "euler_tip_load"]

GREENHILL = 7.837347  # critical q L³/(E I) of a clamped-free column under its own weight (§4.9)


@dataclass(frozen=True)
class BucklingMargin:
    """Extra load a spine carries at its current shape before it buckles.

    Attributes:
        tip_force: critical extra force [N] along ``direction`` on the top disk (``inf`` if the
            load never buckles it, e.g. a pull; 0 if the state is already unstable).
        payload: critical extra payload on the top disk [kg] (its weight, vertical down).
        stable: whether the given state itself is stable.
        direction: unit vector (x, y) of the extra tip force.
    """

    tip_force: float
    payload: float
    stable: bool
    direction: tuple[float, float]


def euler_tip_load(params: ModelParams) -> float:
    """MODEL.md §4.9 Euler value of the critical tip force [N] of the straight tube without wires.

    π² E I / (4 L²) for a clamped-free column of length L = N ls, reduced linearly by the share of
    the self-weight load q L³/(E I) in its critical 7.84 (the §4.9 reading: the contraction ratio
    adds the load ratios), minus the top-disk weight that already acts at the tip.
    """
    ei = params.E_t * params.I_tube
    length = params.n_seg * params.ls
    p_euler = euler_critical_load(length, ei)
    q = params.m_seg * params.g / params.ls
    return p_euler * (1.0 - q * length**3 / ei / GREENHILL) - params.m_top * params.g


def _jacobian(params, kp, dth, state, vforce, wires: bool) -> np.ndarray:
    n = params.n_seg
    jac = np.empty((n, n))
    if wires:
        xs = state[PL.X_PR], state[PL.X_MR], state[PL.X_PL], state[PL.X_ML]
        equilibrium_jacobian(dth, *xs, vforce, kp, jac)
    else:
        shape_jacobian(dth, vforce, kp, jac)
    return jac


def _critical_factor(a0: np.ndarray, j1: np.ndarray) -> float:
    """Smallest P > 0 with det(A₀ − P J₁) = 0 (inf if none): 1 / the largest real μ of A₀⁻¹ J₁."""
    mu = np.linalg.eigvals(np.linalg.solve(a0, j1))
    real = mu[(np.abs(mu.imag) <= 1e-9 * max(1.0, np.abs(mu).max())) & (mu.real > 0.0)].real
    return 1.0 / real.max() if real.size else math.inf


def critical_load(
    params: ModelParams | None = None,
    state: np.ndarray | None = None,
    loads=None,
    *,
    direction: tuple[float, float] = (0.0, -1.0),
    wires: bool = True,
) -> BucklingMargin:
    """Critical extra tip force and payload of a spine in a given state.

    Args:
        params: model parameters (default: MODEL.md §7 baseline).
        state: a model state (e.g. ``SimulationResult.final_state``); default the straight initial
            state of §3.10, whose wires sit at their stress-free length (each bending direction is
            then resisted by one wire only).
        loads: (N, 2) vertex forces [N] already acting in that state (default none); gravity is
            always included.
        direction: direction (x, y) of the extra tip force; normalised. Default straight down.
        wires: include the wires' tangent stiffness (False: the bare tube, the §4.9 column).

    Returns:
        A :class:`BucklingMargin`.

    Raises:
        ValueError: a wrong shape or a non-finite / zero input (the message names it).
        SimulationError: the default initial state could not be solved for another reason.
    """
    params = params or ModelParams()
    n = params.n_seg
    vforce = np.zeros((n, 2)) if loads is None else np.array(loads, dtype=float)
    if vforce.shape != (n, 2) or not np.all(np.isfinite(vforce)):
        raise ValueError(f"loads must be a finite array of shape ({n}, 2), got shape {vforce.shape}")
    d = np.asarray(direction, dtype=float)
    if d.shape != (2,) or not np.all(np.isfinite(d)) or np.hypot(*d) == 0.0:
        raise ValueError(f"direction must be a finite nonzero (x, y) pair, got {direction!r}")
    d = d / np.hypot(*d)
    unstable = BucklingMargin(0.0, 0.0, False, (float(d[0]), float(d[1])))
    if state is None:
        try:
            state = initial_state(params, SolverOptions(), vforce)
        except SimulationError as e:
            if e.status == L.ERR_BUCKLING:  # the straight spine cannot carry even these loads
                return unstable
            raise
    state = np.asarray(state, dtype=float)
    if state.shape != (PL.state_size(n),) or not np.all(np.isfinite(state)):
        raise ValueError(f"state must be a finite array of shape ({PL.state_size(n)},), got {state.shape}")
    kp = params.to_kernel()
    dth = np.ascontiguousarray(state[PL.X_HEAD : PL.X_HEAD + n])
    j0 = _jacobian(params, kp, dth, state, vforce, wires)
    a0 = np.eye(n) - j0
    extra = vforce.copy()

    def factor(unit: np.ndarray) -> float:
        extra[:] = vforce
        extra[0] += unit
        return _critical_factor(a0, _jacobian(params, kp, dth, state, extra, wires) - j0)

    stable = unstable_modes(j0, np.empty((n, n))) == 0
    if not stable:
        return unstable
    p_tip = factor(d)
    p_pay = factor(np.array([0.0, -1.0])) / params.g if params.g > 0.0 else math.inf
    return BucklingMargin(float(p_tip), float(p_pay), True, (float(d[0]), float(d[1])))
