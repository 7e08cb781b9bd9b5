"""``simulate()``: run the spine model over a voltage and load programme (MODEL.md §6).

The time loop runs inside numba (:func:`spine_gym.physics.planar.run.run`); this module only turns
user inputs (constants, arrays sampled at ``dt`` or callables of time) into arrays, validates them,
and wraps the record in a :class:`SimulationResult`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ._series import V_MAX_ALLOWED, SimulationError, Trajectory, as_series, output_steps, vertex_loads
from .layout import SpineLayout
from .params import ModelParams, SolverOptions
from .physics import columns as L
from .physics.planar import record, run
from .physics.planar import columns as PL
from .physics.planar.integrate import init_state
from .simulate_spatial import SpatialResult, simulate_spatial

__all__ = ["SimulationError", "SimulationResult", "simulate", "initial_state", "build_loads"]


@dataclass
class SimulationResult(Trajectory):
    """Trajectory of one simulation, sampled every ``dt`` (row 0 is t = 0).

    Per side (``_right`` / ``_left``): temperature [K], stress [Pa], strain [-], phase fractions
    x+, x-, x_A [-], resistance of one wire [Ω], applied voltage [V], electrical power of the side
    [W], cumulative Joule energy of the side [J]. Spine: bending angle [deg] (positive toward the
    right wire), wire moment [N m], tip position [m].
    """

    time: np.ndarray
    angle_deg: np.ndarray
    moment: np.ndarray
    tip_x: np.ndarray
    tip_y: np.ndarray
    temperature_right: np.ndarray
    temperature_left: np.ndarray
    stress_right: np.ndarray
    stress_left: np.ndarray
    strain_right: np.ndarray
    strain_left: np.ndarray
    x_plus_right: np.ndarray
    x_minus_right: np.ndarray
    x_austenite_right: np.ndarray
    x_plus_left: np.ndarray
    x_minus_left: np.ndarray
    x_austenite_left: np.ndarray
    resistance_right: np.ndarray
    resistance_left: np.ndarray
    voltage_right: np.ndarray
    voltage_left: np.ndarray
    power_right: np.ndarray
    power_left: np.ndarray
    joule_energy_right: np.ndarray
    joule_energy_left: np.ndarray
    convective_loss_right: np.ndarray
    convective_loss_left: np.ndarray
    latent_heat_right: np.ndarray
    latent_heat_left: np.ndarray
    params: ModelParams = field(repr=False)
    substeps: int = 0
    shape_passes: int = 0
    final_state: np.ndarray = field(default=None, repr=False)


def build_loads(n_seg: int, n: int, dt: float, tip_force=None, vertex_forces=None) -> np.ndarray:
    """Vertex-force programme (n or 1, N, 2) [N] from a tip force and/or forces at every vertex.

    ``tip_force``: None, (2,), (n, 2) or callable t → (2,) — global (x, y) force on the top disk.
    ``vertex_forces``: None, (N, 2), (n, N, 2) or callable t → (N, 2) — force at vertex P_k,
    k = 0 (top) … N−1 (the base P_N is clamped).
    """
    return vertex_loads(n_seg, n, dt, 2, tip_force, vertex_forces)


def initial_state(params: ModelParams, solver: SolverOptions | None = None, loads=None) -> np.ndarray:
    """The MODEL.md §3.10 initial state, solved under ``loads`` ((N, 2) vertex forces; default none)."""
    solver = solver or SolverOptions()
    state = np.zeros(PL.state_size(params.n_seg))
    vf = np.zeros((params.n_seg, 2)) if loads is None else np.asarray(loads, dtype=float)
    st = init_state(state, params.to_kernel(), solver.to_kernel(), vf)
    if st != L.OK:
        raise SimulationError(st, 0.0)
    return state


def _check_voltages(series: dict[str, np.ndarray]) -> None:
    """ValueError naming the first of the voltage ``series`` [V] with a value outside [0, 100] V."""
    for name, v in series.items():
        if v.min() < 0.0 or v.max() > V_MAX_ALLOWED:
            raise ValueError(
                f"{name} must be in [0, {V_MAX_ALLOWED:g}] V, got values in [{v.min():g}, {v.max():g}]"
            )


def _start_state(state, params: ModelParams, solver: SolverOptions, loads: np.ndarray) -> np.ndarray:
    """A copy of the given ``state`` (shape checked), or the §3.10 initial state under ``loads``."""
    if state is None:
        return initial_state(params, solver, loads)
    state = np.array(state, dtype=float)
    if state.shape != (PL.state_size(params.n_seg),):
        raise ValueError(f"state must have shape ({PL.state_size(params.n_seg)},), got {state.shape}")
    return state


def simulate(
    duration: float,
    voltage_right: float | np.ndarray | Callable[[float], float],
    voltage_left: float | np.ndarray | Callable[[float], float] | None = None,
    *,
    dt: float = 0.01,
    tip_force=None,
    vertex_forces=None,
    params: ModelParams | None = None,
    solver: SolverOptions | None = None,
    state: np.ndarray | None = None,
    layout: SpineLayout | None = None,
) -> SimulationResult | SpatialResult:
    """Simulate the SMA spine for ``duration`` seconds.

    Planar (MODEL.md) by default. With ``layout=`` (a :class:`SpineLayout`: spatial four-wire
    module, chain of modules) it runs the spatial core instead (SPATIAL.md) and returns a
    :class:`SpatialResult`: then the second argument holds the voltages of all W wire groups
    ((W,), (n, W) or a callable t → (W,)), ``voltage_left`` and ``params`` must be omitted (the
    layout carries its params) and forces are 3-vectors (see :func:`simulate_spatial`).

    Inputs are held constant over each output step [t_k, t_k + dt) (zero-order hold). Where they
    stay the same over consecutive output steps, the sub-steps run across the output points and
    the outputs in between are interpolated (``SolverOptions.dense_output``, MODEL.md §6.5).
    (This function is long for its docstring; the body is the spatial hand-off, the input checks
    and one kernel call.)

    Args:
        duration: simulated time [s], > 0; rounded to a whole number of steps.
        voltage_right, voltage_left: voltage on each wire of a side [V], in [0, 100]: a constant,
            an array of ``round(duration/dt)`` samples, or a callable of time.
        dt: output step [s], in (0, 1].
        tip_force: force on the top disk, global (x, y) [N] (see :func:`build_loads`).
        vertex_forces: forces at the ring vertices (see :func:`build_loads`).
        params: model parameters (default: MODEL.md §7 baseline).
        solver: numerical options (default :class:`SolverOptions`).
        state: start from this state (e.g. ``previous.final_state``) instead of §3.10.
        layout: run the spatial core on this layout (see above).

    Returns:
        A :class:`SimulationResult` (planar) or a :class:`SpatialResult` (``layout`` given).

    Raises:
        ValueError: an input out of range (the message names it).
        SimulationError: the model could not advance (``status`` a ``layout`` code), e.g. a load
            past buckling (``ERR_BUCKLING``, see :func:`spine_gym.buckling.critical_load`); never
            returns NaN.
    """
    if layout is not None:
        if voltage_left is not None or params is not None:
            raise ValueError(
                "with layout=, pass the voltages of all wire groups as the second argument and no "
                f"voltage_left or params (the layout carries its params); got voltage_left={voltage_left!r}, "
                f"params={params!r}"
            )
        return simulate_spatial(
            duration,
            voltage_right,
            layout=layout,
            dt=dt,
            tip_force=tip_force,
            vertex_forces=vertex_forces,
            solver=solver,
            state=state,
        )
    if voltage_left is None:
        raise ValueError(
            "voltage_left is required for the planar model (or pass layout= for the spatial one)"
        )
    params = params or ModelParams()
    solver = solver or SolverOptions()
    if not isinstance(params, ModelParams):
        raise ValueError(f"params must be a ModelParams, got {type(params).__name__}")
    if not isinstance(solver, SolverOptions):
        raise ValueError(f"solver must be a SolverOptions, got {type(solver).__name__}")
    n = output_steps(duration, dt)
    v_r = as_series("voltage_right", voltage_right, n, dt, ())
    v_l = as_series("voltage_left", voltage_left, n, dt, ())
    _check_voltages({"voltage_right": v_r, "voltage_left": v_l})
    loads = build_loads(params.n_seg, n, dt, tip_force, vertex_forces)
    kp = params.to_kernel()
    ks = solver.to_kernel()
    state = _start_state(state, params, solver, loads[0])
    t0 = state[PL.X_TIME]
    out = run.empty_record(n)
    st, k, nsub, npass = run.run(state, kp, ks, v_r, v_l, loads, dt, out)
    if st != L.OK:
        raise SimulationError(st, t0 + k * dt)
    return _result(out, v_r, v_l, dt, t0, params, nsub, npass, state)


def _result(out, v_r, v_l, dt, t0, params: ModelParams, nsub, npass, state) -> SimulationResult:
    n = v_r.shape[0]
    vol = params.wire_volume * params.n_w  # [m^3] of one side
    r_wire = out[:, record.OUT_RES_R] * params.L0 / params.wire_area
    l_wire = out[:, record.OUT_RES_L] * params.L0 / params.wire_area
    # voltage of a sample = the one applied over the step that ends there (row 0: the first one)
    vr = np.concatenate([v_r[:1], v_r])
    vl = np.concatenate([v_l[:1], v_l])
    x = out
    return SimulationResult(
        time=t0 + dt * np.arange(n + 1),
        angle_deg=np.degrees(x[:, record.OUT_ANGLE]),
        moment=x[:, PL.X_MW].copy(),
        tip_x=x[:, record.OUT_TIP_X].copy(),
        tip_y=x[:, record.OUT_TIP_Y].copy(),
        temperature_right=x[:, PL.X_TR].copy(),
        temperature_left=x[:, PL.X_TL].copy(),
        stress_right=x[:, PL.X_SR].copy(),
        stress_left=x[:, PL.X_SL].copy(),
        strain_right=x[:, PL.X_ER].copy(),
        strain_left=x[:, PL.X_EL].copy(),
        x_plus_right=x[:, PL.X_PR].copy(),
        x_minus_right=x[:, PL.X_MR].copy(),
        x_austenite_right=1.0 - x[:, PL.X_PR] - x[:, PL.X_MR],
        x_plus_left=x[:, PL.X_PL].copy(),
        x_minus_left=x[:, PL.X_ML].copy(),
        x_austenite_left=1.0 - x[:, PL.X_PL] - x[:, PL.X_ML],
        resistance_right=r_wire,
        resistance_left=l_wire,
        voltage_right=vr,
        voltage_left=vl,
        power_right=params.n_w * vr**2 / r_wire,
        power_left=params.n_w * vl**2 / l_wire,
        joule_energy_right=x[:, PL.X_QJR] * vol,
        joule_energy_left=x[:, PL.X_QJL] * vol,
        convective_loss_right=x[:, PL.X_QCR] * vol,
        convective_loss_left=x[:, PL.X_QCL] * vol,
        latent_heat_right=x[:, PL.X_QLR] * vol,
        latent_heat_left=x[:, PL.X_QLL] * vol,
        params=params,
        substeps=int(nsub),
        shape_passes=int(npass),
        final_state=state,
    )
