"""``simulate`` of a spatial or chained spine (SPATIAL.md): a :class:`SpineLayout`, one voltage per wire.

The time loop runs inside numba (:func:`spine_gym.physics.spatial.run.run`); this module turns
user inputs into arrays, validates them and wraps the record in a :class:`SpatialResult`.
:func:`spine_gym.simulate` dispatches here when it is given ``layout=``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ._series import V_MAX_ALLOWED, SimulationError, Trajectory, as_series, output_steps, vertex_loads
from .layout import SpineLayout
from .params import SolverOptions
from .physics import columns as L
from .physics._jit import jit
from .physics.spatial import columns as SL
from .physics.spatial.integrate import init_state
from .physics.spatial.record import record_size
from .physics.spatial.run import run

__all__ = ["SpatialResult", "simulate_spatial", "initial_state_spatial", "build_loads_3d"]


@dataclass
class SpatialResult(Trajectory):
    """Trajectory of one spatial simulation, sampled every ``dt`` (row 0 is t = 0).

    Per wire group (arrays (n + 1, W), columns in the layout's wire order, see
    :attr:`SpineLayout.wire_labels`): temperature [K], stress [Pa], strain [-], phase fractions
    x+, x-, x_A [-], resistance of one wire [Ω], applied voltage [V], electrical power of the
    group [W], cumulative Joule energy, convective loss and latent heat of the group [J].

    Per module (arrays (n + 1, K, 2)): the wire moment M_w [N m] and the bending vector
    (Θ cos β, Θ sin β) [deg] of the module's top tangent in its base frame (SPATIAL.md §2).
    Spine: the tip bending vector [deg] (tip tangent in the global base frame), the tip position
    [m] (global x, y, z), the tip frame (rows d1, d2, t in global coordinates) and the segment
    rotation vectors ω (n + 1, N, 2) [rad] (segment 0 at the top).
    """

    time: np.ndarray
    tip_bending_deg: np.ndarray
    tip_position: np.ndarray
    tip_frame: np.ndarray
    module_bending_deg: np.ndarray
    moment: np.ndarray
    omega: np.ndarray
    temperature: np.ndarray
    stress: np.ndarray
    strain: np.ndarray
    x_plus: np.ndarray
    x_minus: np.ndarray
    x_austenite: np.ndarray
    resistance: np.ndarray
    voltage: np.ndarray
    power: np.ndarray
    joule_energy: np.ndarray
    convective_loss: np.ndarray
    latent_heat: np.ndarray
    layout: SpineLayout = field(repr=False)
    substeps: int = 0
    shape_passes: int = 0
    final_state: np.ndarray = field(default=None, repr=False)

    @property
    def tip_theta_deg(self) -> np.ndarray:
        """Polar angle Θ of the tip tangent from the vertical [deg] (>= 0)."""
        return np.hypot(self.tip_bending_deg[:, 0], self.tip_bending_deg[:, 1])

    @property
    def tip_azimuth_deg(self) -> np.ndarray:
        """Azimuth β of the tip bend in the base frame [deg], in (−180, 180] (0 where Θ = 0)."""
        return np.degrees(np.arctan2(self.tip_bending_deg[:, 1], self.tip_bending_deg[:, 0]))


def build_loads_3d(n_seg: int, n: int, dt: float, tip_force=None, vertex_forces=None) -> np.ndarray:
    """Vertex-force programme (n or 1, N, 3) [N] from a tip force and/or forces at every vertex.

    ``tip_force``: None, (3,), (n, 3) or callable t → (3,) — global (x, y, z) force on the top disk.
    ``vertex_forces``: None, (N, 3), (n, N, 3) or callable t → (N, 3) — force at vertex P_j,
    j = 0 (the tip) … N−1 (the base P_N is clamped), as the planar :func:`build_loads`.
    """
    return vertex_loads(n_seg, n, dt, 3, tip_force, vertex_forces)


def initial_state_spatial(layout: SpineLayout, solver: SolverOptions | None = None, loads=None) -> np.ndarray:
    """The MODEL.md §3.10 initial state of every wire, solved under ``loads`` ((N, 3); default none)."""
    solver = solver or SolverOptions()
    vf = np.zeros((layout.n_seg, 3)) if loads is None else np.asarray(loads, dtype=float)
    return _initial_state(layout, layout.to_kernel(), solver.to_kernel(), vf)


def _initial_state(layout: SpineLayout, tables, ks: np.ndarray, loads: np.ndarray) -> np.ndarray:
    """:func:`initial_state_spatial` from the kernel tables (kp, kw, km) and options the caller has."""
    kp, kw, km = tables
    state = np.zeros(layout.state_size())
    st = init_state(state, kp, ks, kw, km, loads)
    if st != L.OK:
        raise SimulationError(st, 0.0)
    return state


def simulate_spatial(
    duration: float,
    voltages: np.ndarray | Callable[[float], np.ndarray],
    *,
    layout: SpineLayout,
    dt: float = 0.01,
    tip_force=None,
    vertex_forces=None,
    solver: SolverOptions | None = None,
    state: np.ndarray | None = None,
) -> SpatialResult:
    """Simulate a spatial or chained spine for ``duration`` seconds (SPATIAL.md §1–§5, MODEL.md §6).

    Inputs are held constant over each output step [t_k, t_k + dt) (zero-order hold). Where they
    stay the same over consecutive output steps, the sub-steps run across the output points and
    the outputs in between are interpolated (``SolverOptions.dense_output``, MODEL.md §6.5).

    Args:
        duration: simulated time [s], > 0; rounded to a whole number of steps.
        voltages: voltage on each wire of every wire group [V], in [0, 100]: a (W,) constant,
            an array (round(duration/dt), W) sampled at dt, or a callable t → (W,).
        layout: the :class:`SpineLayout` (modules, wires, material and tube parameters).
        dt: output step [s], in (0, 1].
        tip_force: global (x, y, z) force on the top disk [N] (see :func:`build_loads_3d`).
        vertex_forces: forces at the vertices (see :func:`build_loads_3d`).
        solver: numerical options; only ``method="newton"`` exists for the spatial core (its
            safeguard replaces the planar bracket).
        state: start from this state (e.g. ``previous.final_state``) instead of §3.10.

    Raises:
        ValueError: an input out of range (the message names it).
        SimulationError: the model could not advance; never returns NaN.
    """
    solver = solver or SolverOptions()
    if not isinstance(layout, SpineLayout):
        raise ValueError(f"layout must be a SpineLayout, got {type(layout).__name__}")
    if not isinstance(solver, SolverOptions):
        raise ValueError(f"solver must be a SolverOptions, got {type(solver).__name__}")
    if solver.method != "newton":
        raise ValueError(f"solver.method must be 'newton' for a spatial layout, got {solver.method!r}")
    n = output_steps(duration, dt)
    nw = layout.n_wires
    volts = as_series("voltages", voltages, n, dt, (nw,))
    if volts.min(initial=0.0) < 0.0 or volts.max(initial=0.0) > V_MAX_ALLOWED:
        raise ValueError(
            f"voltages must be in [0, {V_MAX_ALLOWED:g}] V, got values in [{volts.min():g}, {volts.max():g}]"
        )
    loads = build_loads_3d(layout.n_seg, n, dt, tip_force, vertex_forces)
    tables = kp, kw, km = layout.to_kernel()
    ks = solver.to_kernel()
    if state is None:
        state = _initial_state(layout, tables, ks, loads[0])
    else:
        state = np.array(state, dtype=float)
        if state.shape != (layout.state_size(),):
            raise ValueError(f"state must have shape ({layout.state_size()},), got {state.shape}")
    t0 = state[SL.S_TIME]
    out = np.empty((n + 1, record_size(nw, layout.n_modules, layout.n_seg)))
    st, k, nsub, npass = run(state, kp, ks, kw, km, volts, loads, dt, out)
    if st != L.OK:
        raise SimulationError(st, t0 + k * dt)
    return _result(out, volts, dt, t0, layout, kw, nsub, npass, state)


def _result(out, volts, dt, t0, layout: SpineLayout, kw, nsub, npass, state) -> SpatialResult:
    """The record's columns as arrays of the result: views into ``out`` where no unit changes (the
    record is this result's alone; a copy of each block cost as much as the rest of the wrapping).
    ``kw`` is the layout's wire-group table (:meth:`SpineLayout.to_kernel`) the run used."""
    p = layout.params
    nw, nm, ns = layout.n_wires, layout.n_modules, layout.n_seg
    rows = out.shape[0]

    def wires(f):
        o = SL.S_HEAD + f * nw
        return out[:, o : o + nw]

    o = SL.S_HEAD + SL.N_WIRE_FIELDS * nw
    moment = out[:, o : o + 2 * nm].reshape(rows, nm, 2)
    o += 2 * nm
    omega = out[:, o : o + 2 * ns].reshape(rows, ns, 2)
    o += 2 * ns
    o_bend = o  # module bending (2 nm), tip bending (2) [rad]: converted to degrees below
    o += 2 * nm + 2
    tip_position = out[:, o : o + 3]
    o += 3
    tip_frame = out[:, o : o + 9].reshape(rows, 3, 3)
    o += 9
    l0, n_w = kw[:, SL.W_L0].copy(), kw[:, SL.W_NW].copy()
    vol = p.wire_area * l0 * n_w  # [m^3] of each group
    bend, resistance, v, power, xa, heats = _derived(
        out, volts, o_bend, nm, o, SL.S_HEAD + SL.F_XP * nw, SL.S_HEAD + SL.F_XM * nw,
        SL.S_HEAD + SL.F_QJ * nw, SL.S_HEAD + SL.F_QC * nw, SL.S_HEAD + SL.F_QL * nw,
        l0, p.wire_area, n_w, vol,
    )  # fmt: skip
    module_bending = bend[:, : 2 * nm].reshape(rows, nm, 2)
    tip_bending = bend[:, 2 * nm :]
    xp, xm = wires(SL.F_XP), wires(SL.F_XM)
    return SpatialResult(
        time=t0 + dt * np.arange(rows),
        tip_bending_deg=tip_bending,
        tip_position=tip_position,
        tip_frame=tip_frame,
        module_bending_deg=module_bending,
        moment=moment,
        omega=omega,
        temperature=wires(SL.F_T),
        stress=wires(SL.F_SIG),
        strain=wires(SL.F_EPS),
        x_plus=xp,
        x_minus=xm,
        x_austenite=xa,
        resistance=resistance,
        voltage=v,
        power=power,
        joule_energy=heats[0],
        convective_loss=heats[1],
        latent_heat=heats[2],
        layout=layout,
        substeps=int(nsub),
        shape_passes=int(npass),
        final_state=state,
    )


@jit
def _derived(out, volts, o_bend, nm, o_rho, o_xp, o_xm, o_qj, o_qc, o_ql, l0, area, n_w, vol):
    """The result's converted columns in one pass over the record's rows (row by row: the record is
    row-major and wide, so a NumPy operation on a column block strides through a cache line per
    sample, ~15 µs per block on a 20-s run): bending [deg], resistance ρ L0/A [Ω], the voltage over
    the step that ends at each sample (the first step's at t0) [V], power n_w V²/R [W], x_A [-] and
    the Joule, convective and latent heats times the group volume [J] (``l0`` [m] and ``vol``
    [m^3] per wire group, ``area`` the wire section [m^2])."""
    rows, nw = out.shape[0], l0.shape[0]
    bend = np.empty((rows, 2 * nm + 2))
    res = np.empty((rows, nw))
    v = np.empty((rows, nw))
    power = np.empty((rows, nw))
    xa = np.empty((rows, nw))
    heats = np.empty((3, rows, nw))
    for r in range(rows):
        for c in range(2 * nm + 2):
            bend[r, c] = math.degrees(out[r, o_bend + c])
        for j in range(nw):
            res[r, j] = out[r, o_rho + j] * l0[j] / area
            v[r, j] = volts[max(r - 1, 0), j]
            power[r, j] = n_w[j] * (v[r, j] * v[r, j]) / res[r, j]
            xa[r, j] = 1.0 - out[r, o_xp + j] - out[r, o_xm + j]
            heats[0, r, j] = out[r, o_qj + j] * vol[j]
            heats[1, r, j] = out[r, o_qc + j] * vol[j]
            heats[2, r, j] = out[r, o_ql + j] * vol[j]
    return bend, res, v, power, xa, heats
