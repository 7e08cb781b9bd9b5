"""Classical controllers for the spatial spines ``SmaSpine3D-v0`` and ``SmaSpineChain-v0``.

The planar baselines (:mod:`.planar`) generalised to any :class:`~spine_gym.layout.SpineLayout`
— one four-wire module, or a chain of them — on the same SB3 ``predict`` interface:

* :class:`SpatialStepController` — the paper's open-loop step voltage per bending axis;
* :class:`SpatialBangBangController` — a relay with hysteresis per wire;
* :class:`SpatialPIDController` — a PID per module and bending axis.

**Bending axes and the wire split.** Heating wire j (azimuth ψ_j in its module) bends that module
toward azimuth ψ_j (SPATIAL.md §3: a tighter wire 0 bends toward +d1), so its bend direction is
e_j = (cos ψ_j, sin ψ_j) in the module's base frame. A controller computes, per module k, a signed
command vector u_k = (u_x, u_y) on the module's two bending axes (x = toward wire 0, y = toward
wire 1); wire j of module k gets ``max(u_k · e_j, 0)``. For the seed's four wires 90° apart this
is exactly the planar antagonistic split on each axis: u_x > 0 heats wire 0 (0°), u_x < 0 wire 2
(180°), u_y > 0 wire 1 (90°), u_y < 0 wire 3 (270°).

**References.** ``SmaSpine3D-v0`` tracks a tip bending vector b* [deg] (one module: the module's
bending is the tip's). ``SmaSpineChain-v0`` tracks a tip position p* [mm]; the reference of each
module is then the bending vector from the constant-curvature inverse kinematics
:func:`spine_gym.kinematics.arc_chain_ik` (all modules in the vertical plane through the target,
bends linear along the chain), and each module's PID tracks its own reference on the module's
measured bending vector (per-module bending is observed). An optional integral action on the
tip-position error (``tip_ki``) shifts the IK target (by at most :data:`TIP_OFFSET_MM` per axis)
to remove the offset that gravity's sag leaves (the modules are not exact arcs under load).

**Voltages.** Wires of a shorter module heat like the seed's wire at a voltage scaled by
:attr:`SpineLayout.voltage_scale` (MODEL.md §3.7, SPATIAL.md §6); the controllers compute in
seed-equivalent volts and multiply by that scale, and the action of wire j is
``2 V_j / v_max_j − 1`` with the env's per-wire full scale ``v_max_j``.

Which observation entries are read is given by a :class:`SpatialSignals` (built from the env's
observation table by :meth:`SpatialSignals.from_env`), never by fixed indices.
"""

from __future__ import annotations

import dataclasses
import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from ..envs.drive import check_v_max
from ..kinematics import arc_chain_ik
from ..layout import SpineLayout
from .base import (
    BaseController,
    PIDGains,
    check_range,
    checked_relay,
    observation_batch,
    relay_config,
    volts_to_action,
)
from .steady_state import SteadyStateMap, steady_state_map

__all__ = [
    "SpatialSignals",
    "SpatialStepController",
    "SpatialBangBangController",
    "SpatialPIDController",
    "TASKS",
]

TASKS = ("tip_bending", "tip_position")  # what the env tracks: a bending vector [deg] or a position [mm]
TIP_OFFSET_MM = 30.0  # [mm] bound of the tip-error integral added to the IK target (anti-windup)


def _indices(name: str, idx, size: int | None) -> np.ndarray:
    arr = np.asarray(idx if not isinstance(idx, slice) else range(idx.start, idx.stop), dtype=np.int64)
    if arr.ndim != 1 or (size is not None and arr.size != size) or np.any(arr < 0):
        raise ValueError(
            f"{name} must be {size if size is not None else 'some'} observation indices >= 0, got {idx!r}"
        )
    return arr


@dataclass(frozen=True)
class SpatialSignals:
    """The spine and the observation entries a spatial controller reads.

    Attributes:
        layout: the controlled layout (wire azimuths, modules, lengths, voltage scale).
        task: ``"tip_bending"`` (target = tip bending vector [deg]) or ``"tip_position"``
            (target = tip position [mm]).
        bending: (2K,) indices of the K module bending vectors [deg], module by module (for one
            module: the tip bending vector).
        target: indices of the target (2 for ``tip_bending``, 3 for ``tip_position``).
        temperature: (W,) indices of the wire temperatures [K] (layout wire order).
        preview: indices of the look-ahead target (same size as ``target``), or None.
        tip_position: (3,) indices of the measured tip position [mm] (``tip_ki``), or None.
        v_max: (W,) full-scale voltage of every wire [V] (action +1).
    """

    layout: SpineLayout
    task: str
    bending: np.ndarray
    target: np.ndarray
    temperature: np.ndarray
    v_max: np.ndarray
    preview: np.ndarray | None = None
    tip_position: np.ndarray | None = None

    def __post_init__(self):
        if not isinstance(self.layout, SpineLayout):
            raise ValueError(f"layout must be a SpineLayout, got {type(self.layout).__name__}")
        if self.task not in TASKS:
            raise ValueError(f"task must be one of {TASKS}, got {self.task!r}")
        k, w = self.layout.n_modules, self.layout.n_wires
        dim = 2 if self.task == "tip_bending" else 3
        if self.task == "tip_bending" and k != 1:
            raise ValueError(f"task 'tip_bending' needs a one-module layout, got {k} modules")
        s = object.__setattr__
        s(self, "bending", _indices("bending", self.bending, 2 * k))
        s(self, "target", _indices("target", self.target, dim))
        s(self, "temperature", _indices("temperature", self.temperature, w))
        if self.preview is not None:
            s(self, "preview", _indices("preview", self.preview, dim))
        if self.tip_position is not None:
            s(self, "tip_position", _indices("tip_position", self.tip_position, 3))
        vm = np.broadcast_to(np.asarray(self.v_max, dtype=np.float64), (w,)).copy()
        s(self, "v_max", np.array([check_v_max(v, f"v_max[{j}]") for j, v in enumerate(vm)]))

    @classmethod
    def from_env(cls, env) -> SpatialSignals:
        """:meth:`from_config` of a spatial env's configuration."""
        return cls.from_config(getattr(env, "unwrapped", env).config)

    @classmethod
    def from_config(cls, cfg) -> SpatialSignals:
        """Read the layout, the task, the per-wire full scale and the indices from a spatial env's
        configuration (its declarative observation table, entries found by their source; e.g.
        :func:`spine_gym.envs.config_of`, no env needed)."""
        table = cfg.table()
        task = table.task.source

        def index(source):
            keys = [e.key for e in table.entries if e.source == source and e.obs is not None]
            return table.obs_index(keys[0]) if keys else None

        return cls(
            layout=cfg.layout,
            task=task,
            bending=index("tip_bending" if task == "tip_bending" else "module_bending"),
            target=index("target"),
            temperature=index("temperature"),
            v_max=2.0 * np.asarray(cfg.volt_coef, dtype=np.float64),  # volts = (a + 1) · volt_coef
            preview=index("preview"),
            tip_position=index("tip_position") if task == "tip_position" else None,
        )

    # ------------------------------------------------------------------ derived geometry
    @property
    def n_modules(self) -> int:
        return self.layout.n_modules

    @property
    def wire_module(self) -> np.ndarray:
        return self.layout.wire_module

    @property
    def wire_dir(self) -> np.ndarray:
        """(W, 2) bend direction (cos ψ, sin ψ) of every wire in its module's base frame."""
        psi = np.radians([w.psi_deg for m in self.layout.modules for w in m.wires])
        return np.stack([np.cos(psi), np.sin(psi)], axis=1)

    @property
    def module_lengths(self) -> np.ndarray:
        return np.array([m.length for m in self.layout.modules])

    @property
    def max_index(self) -> int:
        parts = [self.bending, self.target, self.temperature]
        parts += [p for p in (self.preview, self.tip_position) if p is not None]
        return int(max(p.max() for p in parts))


class _IKCache:
    """Memoised :func:`arc_chain_ik` per target (targets repeat while a setpoint holds)."""

    def __init__(self, lengths: np.ndarray, size: int = 4096):
        self.lengths = lengths
        self.size = size
        self._memo: OrderedDict = OrderedDict()

    def __call__(self, target_mm: np.ndarray) -> np.ndarray:
        """(K, 2) module bending vectors [deg] for a tip position [mm]."""
        key = tuple(np.round(target_mm, 6))
        hit = self._memo.get(key)
        if hit is None:
            hit = np.degrees(arc_chain_ik(np.asarray(target_mm) / 1000.0, self.lengths).bending)
            self._memo[key] = hit
            if len(self._memo) > self.size:
                self._memo.popitem(last=False)
        return hit


class SpatialController(BaseController):
    """Common part of the spatial controllers: observation checks, references, the wire split,
    the temperature guard and per-wire action scaling (see the module docstring).

    Args:
        signals: what to read (:class:`SpatialSignals`).
        dt: control period [s], in (0, 10].
        temperature_limit: wires observed at or above it [K] get 0 V (None: no guard).
    """

    def __init__(self, signals: SpatialSignals, *, dt: float = 0.1, temperature_limit: float | None = None):
        if not isinstance(signals, SpatialSignals):
            raise ValueError(f"signals must be a SpatialSignals, got {type(signals).__name__}")
        # computations are in seed-equivalent volts: the full scale of wire j is v_max_j / scale_j
        seed_v_max = float((signals.v_max / signals.layout.voltage_scale).min())
        super().__init__(v_max=seed_v_max, dt=dt, temperature_limit=temperature_limit)
        self.signals = signals
        self.scale = signals.layout.voltage_scale
        self._dir = signals.wire_dir
        self._mod = signals.wire_module
        self._ik = _IKCache(signals.module_lengths) if signals.task == "tip_position" else None

    @classmethod
    def from_env(cls, env, **kwargs):
        """Build for a spatial env (its signals, control period)."""
        return cls.from_config(getattr(env, "unwrapped", env).config, **kwargs)

    @classmethod
    def from_config(cls, cfg, **kwargs):
        """Build for a spatial env's configuration (:func:`spine_gym.envs.config_of`; no env needed)."""
        return cls(SpatialSignals.from_config(cfg), dt=float(cfg.control_period), **kwargs)

    # ---- observation and references
    def _check_obs(self, observation) -> tuple[np.ndarray, bool]:
        obs, single = observation_batch(observation, self.signals.max_index + 1)
        if not np.all(np.isfinite(obs)):
            raise ValueError("observation must be finite, got NaN or inf")
        return obs, single

    def _bending(self, obs: np.ndarray) -> np.ndarray:
        """(n, K, 2) measured module bending vectors [deg]."""
        return obs[:, self.signals.bending].reshape(obs.shape[0], -1, 2)

    def _reference(self, obs: np.ndarray, idx: np.ndarray, offset: np.ndarray | None = None) -> np.ndarray:
        """(n, K, 2) module reference bending vectors [deg] from the target entries ``idx``."""
        tgt = obs[:, idx]
        if self._ik is None:
            return tgt.reshape(obs.shape[0], 1, 2)
        if offset is not None:
            tgt = tgt + offset
        return np.stack([self._ik(t) for t in tgt])

    def _temperatures(self, obs):
        return obs[:, self.signals.temperature]

    def reference(self, observation) -> np.ndarray:
        """(n, K, 2) module reference bending vectors [deg] of observation(s) (the target itself
        for a bending task, its inverse kinematics for a tip-position task)."""
        obs, _ = self._check_obs(observation)
        return self._reference(obs, self.signals.target)

    # ---- output
    def _split(self, u: np.ndarray) -> np.ndarray:
        """(n, W) wire voltages [V] from (n, K, 2) axis commands in seed-equivalent volts."""
        return np.maximum(np.einsum("nwc,wc->nw", u[:, self._mod, :], self._dir), 0.0)

    def _action(self, obs, volts):
        volts = volts * self.scale
        if self.temperature_limit is not None:
            volts = np.where(self._temperatures(obs) >= self.temperature_limit, 0.0, volts)
        volts = np.clip(volts, 0.0, self.signals.v_max)
        return volts_to_action(volts, self.signals.v_max)

    def _seed_length(self) -> float:
        p = self.signals.layout.params
        return p.n_seg * p.ls


# --------------------------------------------------------------------------- step voltage
class SpatialStepController(SpatialController):
    """Open-loop step voltage per bending axis (the paper's drive on each axis).

    Wire j of module k gets the planar steady-state voltage (:func:`.steady_state.steady_state_map`
    of the layout's params) of the bend ``max(r_k · e_j, 0) · L_seed / L_k`` (a module of length
    L_k reaches the curvature of the seed's bend Θ at Θ L_k / L_seed), scaled by the wire's voltage
    scale; r_k is the module's reference (the IK's for a tip-position task). Superposing the two
    axes is an approximation of the model's coupled steady state (it is exact on each axis alone).

    Args:
        signals: see :class:`SpatialSignals`.
        ss_map: planar steady-state map (default: of ``signals.layout.params`` up to v_max).
        **kwargs: ``dt``, ``temperature_limit``.
    """

    name = "step"

    def __init__(self, signals: SpatialSignals, ss_map: SteadyStateMap | None = None, **kwargs):
        super().__init__(signals, **kwargs)
        if ss_map is not None and not isinstance(ss_map, SteadyStateMap):
            raise ValueError(f"ss_map must be a SteadyStateMap, got {type(ss_map).__name__}")
        self.ss_map = ss_map or steady_state_map(signals.layout.params, v_max=self.v_max)
        self._stretch = self._seed_length() / signals.module_lengths  # (K,)

    def _volts(self, obs, mem):
        ref = self._reference(obs, self.signals.target)  # (n, K, 2)
        along = np.einsum("nwc,wc->nw", ref[:, self._mod, :], self._dir)  # (n, W) [deg]
        seed_deg = np.maximum(along, 0.0) * self._stretch[self._mod]
        return self.ss_map.voltage_for(seed_deg)


# --------------------------------------------------------------------------- bang-bang
class SpatialBangBangController(SpatialController):
    """A relay with hysteresis per wire on the error along the wire's bend direction.

    With e_j = (r_k − b_k) · e_j [deg] (reference minus measured bending of the wire's module,
    projected on the wire's direction), wire j switches on at ``v_on`` when e_j > ``band`` and off
    when e_j < −``release``; a wire that is off gets ``v_hold`` if no antagonist (a wire of the same
    module pointing the opposite way) is on. For an antagonistic pair this is the planar
    three-level relay of :class:`.planar.BangBangController` on that axis.

    Args:
        v_on, band, release, v_hold: as the planar relay ([V], [deg], [deg], [V]).
        **kwargs: ``dt``, ``temperature_limit``.
    """

    name = "bang_bang"

    def __init__(
        self,
        signals: SpatialSignals,
        v_on: float = 3.5,
        band: float = 1.0,
        release: float = 0.0,
        v_hold: float = 0.0,
        **kwargs,
    ):
        super().__init__(signals, **kwargs)
        relay = checked_relay(v_on, band, release, v_hold, self.v_max)
        self.v_on, self.band, self.release, self.v_hold = relay
        same = self._mod[:, None] == self._mod[None, :]
        self._antagonist = same & (self._dir @ self._dir.T < -0.5)  # (W, W)
        self.state_size = signals.layout.n_wires

    def _volts(self, obs, mem):
        err = self._reference(obs, self.signals.target) - self._bending(obs)
        e = np.einsum("nwc,wc->nw", err[:, self._mod, :], self._dir)
        on = np.where(e > self.band, 1.0, np.where(e < -self.release, 0.0, mem))
        mem[:] = on
        opposed = (on @ self._antagonist.T.astype(float)) > 0.0
        return np.where(on > 0, self.v_on, np.where(opposed, 0.0, self.v_hold))

    def config(self) -> dict:
        return {**relay_config(self), **super().config()}


# --------------------------------------------------------------------------- PID
class SpatialPIDController(SpatialController):
    """A PID per module and bending axis, its output split over that axis' antagonistic wires.

    On each axis of each module, as the planar :class:`.planar.PIDController`:
    ``u = ff(r) + kp e + I + D`` [V] with ``e = r − b`` [deg] (reference minus measured bending),
    ``D`` the filtered derivative of −b, ``ff`` the planar steady-state voltage of the reference
    component (signed, times ``feedforward``), ``r`` blended with the previewed target
    (``preview``), back-calculation anti-windup on ``u_sat = clip(u, ±(v_max − bias))``. Wire j
    gets ``max(u_k · e_j, 0) + bias``. For a tip-position task the reference r_k comes from the
    inverse kinematics of the (previewed) target plus ``tip_ki`` × the integrated tip error.

    Args:
        kp, ki, kd, tau_d, bias, kaw, feedforward, preview: see :class:`.base.PIDGains`.
        tip_ki: integral gain on the tip-position error [1/s] (tip-position task only; 0: off),
            in [0, 10].
        ss_map: planar steady-state map for the feedforward.
        **kwargs: ``dt``, ``temperature_limit``.
    """

    name = "pid"

    def __init__(
        self,
        signals: SpatialSignals,
        kp: float = PIDGains.kp,
        ki: float = PIDGains.ki,
        kd: float = PIDGains.kd,
        tau_d: float = PIDGains.tau_d,
        bias: float = PIDGains.bias,
        kaw: float = PIDGains.kaw,
        feedforward: float = PIDGains.feedforward,
        preview: float = PIDGains.preview,
        tip_ki: float = 0.0,
        *,
        ss_map: SteadyStateMap | None = None,
        **kwargs,
    ):
        super().__init__(signals, **kwargs)
        self.gains = PIDGains.checked(kp, ki, kd, tau_d, bias, kaw, feedforward, preview, v_max=self.v_max)
        self.tip_ki = check_range("tip_ki", tip_ki, 0.0, 10.0)
        if self.gains.preview > 0.0 and signals.preview is None:
            raise ValueError("preview > 0 needs a target preview in the observation (signals.preview)")
        if self.tip_ki > 0.0 and signals.tip_position is None:
            raise ValueError("tip_ki > 0 needs the tip position in the observation (signals.tip_position)")
        if ss_map is not None and not isinstance(ss_map, SteadyStateMap):
            raise ValueError(f"ss_map must be a SteadyStateMap, got {type(ss_map).__name__}")
        self.ss_map = ss_map
        if self.gains.feedforward > 0.0 and self.ss_map is None:
            self.ss_map = steady_state_map(signals.layout.params, v_max=self.v_max)
        self._stretch = (self._seed_length() / signals.module_lengths)[None, :, None]
        self._na = 2 * signals.n_modules  # axes
        self.state_size = 3 * self._na + 3  # I, D, previous bending per axis; tip integrator (3)

    @classmethod
    def from_gains(cls, signals: SpatialSignals, gains: PIDGains | dict, **kwargs) -> SpatialPIDController:
        g = dataclasses.asdict(gains) if isinstance(gains, PIDGains) else dict(gains)
        return cls(signals, **g, **kwargs)

    def _initial_state(self, n):
        mem = np.zeros((n, self.state_size))
        mem[:, 2 * self._na : 3 * self._na] = np.nan
        return mem

    def _ref(self, obs, mem) -> np.ndarray:
        sig, g = self.signals, self.gains
        offset = None
        if self.tip_ki > 0.0:
            offset = mem[:, 3 * self._na :]
            step = self.dt * self.tip_ki * (obs[:, sig.target] - obs[:, sig.tip_position])
            mem[:, 3 * self._na :] = np.clip(offset + step, -TIP_OFFSET_MM, TIP_OFFSET_MM)
        ref = self._reference(obs, sig.target, offset)
        if g.preview > 0.0:
            ref = (1.0 - g.preview) * ref + g.preview * self._reference(obs, sig.preview, offset)
        return ref

    def _volts(self, obs, mem):
        g, n, na = self.gains, obs.shape[0], self._na
        ref = self._ref(obs, mem).reshape(n, na)
        meas = self._bending(obs).reshape(n, na)
        integ, dfilt, prev = mem[:, :na], mem[:, na : 2 * na], mem[:, 2 * na : 3 * na]
        e = ref - meas
        first = np.isnan(prev)
        rate = np.where(first, 0.0, (meas - np.where(first, meas, prev)) / self.dt)
        alpha = 1.0 if g.tau_d <= 0.0 else 1.0 - math.exp(-self.dt / g.tau_d)
        d = np.where(first, 0.0, dfilt + alpha * (-g.kd * rate - dfilt))
        ff = 0.0
        if g.feedforward > 0.0:
            seed_ref = (ref.reshape(n, -1, 2) * self._stretch).reshape(n, na)
            ff = g.feedforward * np.sign(ref) * self.ss_map.voltage_for(seed_ref)
        u = ff + g.kp * e + integ + d
        u_hi = self.v_max - g.bias
        u_sat = np.clip(u, -u_hi, u_hi)
        mem[:, :na] = integ + self.dt * (g.ki * e + g.kaw * (u_sat - u))
        mem[:, na : 2 * na] = d
        mem[:, 2 * na : 3 * na] = meas
        return self._split(u_sat.reshape(n, -1, 2)) + g.bias

    def config(self) -> dict:
        return {**dataclasses.asdict(self.gains), "tip_ki": self.tip_ki, **super().config()}
