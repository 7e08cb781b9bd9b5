"""Configuration, tables and batch of the spatial envs ``SmaSpine3D-v0`` and ``SmaSpineChain-v0``.

The physics is the wire- and module-generic core ``spine_gym.physics.spatial``
(SPATIAL.md) through :func:`spine_gym.physics.spatial.control.step_spine`, stepped with the
bookkeeping in one call (:func:`.step_kernels.spatial_step`); the bookkeeping
is the table-driven writer every env shares (:class:`.batch.TableBatch`). The env classes
(their docstrings are the documentation pages) are in :mod:`.spatial_env`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..layout import MAX_MODULES, SpineLayout
from ..params import ModelParams
from ..physics.spatial import columns as SL
from ..physics.spatial.control import record_many
from ..physics.spatial.integrate import init_state
from ..physics.spatial.record import record_size
from ..uncertainty import ParameterUncertainty
from . import readout as ro
from . import step_kernels as sk
from .batch import TableBatch
from .config import RATE_OBS_LIMIT, TARGET_REACH, BaseEnvConfig, _int, _pair, _real
from .drive import volt_coef
from .table import Entry, Table
from .targets_planar import ANGLE_LIMIT
from .targets_spatial import BEND_KINDS, BendTarget, ChainTarget, arc_tip_position

__all__ = [
    "SpatialConfig",
    "Spine3DConfig",
    "ChainConfig",
    "SpatialBatch",
    "Spine3DBatch",
    "ChainBatch",
    "workspace_radius_mm",
    "workspace_low_mm",
]

BEND_OBS_LIMIT = 180.0  # [deg] bound of the bending entries
POSITION_RATE_LIMIT = 5000.0  # [mm/s] bound of the tip-velocity entries


# ---------------------------------------------------------------- configuration
@dataclass(frozen=True)
class SpatialConfig(BaseEnvConfig):
    """Arguments the spatial envs share (layout-derived facts as properties)."""

    target_kinds: tuple[str, ...] = BEND_KINDS
    target_period_range: tuple[float, float] = (20.0, 60.0)
    wire_values: Any = None

    def _check_task(self) -> None:
        s = object.__setattr__
        s(self, "wire_values", self._check_wire_values())
        self._check_kinds(BEND_KINDS, "target_period_range")
        s(self, "_layout", self.layout_for(self.params))

    def _check_wire_values(self) -> tuple | None:
        """``wire_values`` (default: a spatial fit preset's), one mapping per wire, validated."""
        values = self.wire_values
        dr = self.domain_randomization
        if values is None and isinstance(dr, ParameterUncertainty):
            values = dr.wire_values
        if values is None:
            return None
        nw = SpineLayout.chain(self.n_modules, self.params).n_wires
        if not isinstance(values, list | tuple) or len(values) != nw:
            raise ValueError(
                f"wire_values must be a sequence of {nw} mappings (one per wire: lam_scale, T_shift, eps0), "
                f"got {values!r}" + (" from the fit preset" if self.wire_values is None else "")
            )
        try:
            SpineLayout.chain(self.n_modules, self.params).with_wire_values(list(values))
        except ValueError as e:
            raise ValueError(f"wire_values: {e}") from None
        return tuple(dict(v) for v in values)

    # ------------------------------------------------------------------ layout
    def layout_for(self, params: ModelParams) -> SpineLayout:
        """The spine of an episode with parameters ``params`` (``SpineLayout.chain``; one module is
        the seed's) and the nominal per-wire values ``wire_values``."""
        lay = SpineLayout.chain(self.n_modules, params)
        return lay if self.wire_values is None else lay.with_wire_values(list(self.wire_values))

    def initial_status(self, params: ModelParams, payload: float) -> int:
        layout = self.layout_for(params)
        kp, kw, km = layout.to_kernel()
        state = np.zeros(layout.state_size())
        vforce = self.initial_loads(params, payload)
        return init_state(state, kp, self.solver.to_kernel(), kw, km, vforce)

    @property
    def layout(self) -> SpineLayout:
        """The nominal layout."""
        return self._layout

    @property
    def n_modules(self) -> int:
        return 1

    @property
    def n_wires(self) -> int:
        return self._layout.n_wires

    @property
    def n_seg(self) -> int:
        return self._layout.n_seg

    @property
    def force_dim(self) -> int:
        return 3

    @property
    def volt_coef(self) -> np.ndarray:
        """(W,) volts per unit of (action + 1): ½ v_max × the wire's voltage scale (SPATIAL.md §6)."""
        return volt_coef(self.v_max, self._layout.voltage_scale)

    @property
    def wire_names(self) -> list[str]:
        """Suffixes of the per-wire observation names: ``"m<k>_<ψ>"`` (``"<ψ>"`` for one module)."""
        out = []
        for k, m in enumerate(self._layout.modules):
            for w in m.wires:
                out.append(f"{w.psi_deg:g}" if self.n_modules == 1 else f"m{k}_{w.psi_deg:g}")
        return out

    @property
    def energy_reference(self) -> float:
        """Largest electrical energy of one control period [J]: every wire at its full voltage,
        lowest nominal resistivity (the normaliser of the energy term)."""
        p = self.params
        lam = min(p.lam_A, p.lam_M)
        _, kw, _ = self._layout.to_kernel()
        v = self.v_max * self._layout.voltage_scale
        r = lam * kw[:, SL.W_L0] / p.wire_area
        return float(np.sum(kw[:, SL.W_NW] * v**2 / r) * self.control_period)

    def _max_lam_scale(self) -> float:
        """Largest per-wire resistivity scale, nominal or drawn (a fit's upper bounds)."""
        out = max(v["lam_scale"] for v in self._layout.wire_values)
        dr = self.domain_randomization
        if isinstance(dr, ParameterUncertainty):
            for name, hi in zip(dr.names, dr.upper, strict=True):
                if name.endswith(".lam_scale"):
                    out = max(out, float(hi))
        return out

    def resistance_bound(self) -> float:
        """Upper bound of the resistance entries [Ω]: 2x the largest one-wire resistance over the
        nominal and randomised parameters, plus 10 standard deviations of resistance noise."""
        cands = self.extreme_params()
        l0 = max(m.L0 for m in self._layout.modules) / self.params.L0  # wire length / the params' L0
        l0 *= self._max_lam_scale()
        r = max(max(p.lam_A, p.lam_M) * p.L0 * l0 / p.wire_area for p in cands)
        return float(2.0 * r + 10.0 * self.noise_sigma["resistance"])

    def _step_entries(self, unit: str, error_doc: str, dim: int) -> tuple[Entry, ...]:
        """The info-only entries every spatial env has (voltages, energy, reward terms, ...)."""
        names = self.wire_names
        return (
            Entry("voltage", "voltage", "V", "applied voltage", tuple(f"voltage_{n}" for n in names)),
            Entry(
                "power_W",
                "power",
                "W",
                "mean electrical power of the wire group",
                tuple(f"power_{n}" for n in names),
            ),
            Entry(
                f"tracking_error_{unit}",
                "error",
                unit,
                error_doc,
                tuple(f"error_{c}" for c in "xyz"[:dim]),
            ),
            Entry("energy_J", "energy", "J", "electrical energy of the step (all wires)", ("energy",)),
            Entry("cost", "cost", "K", "Σ over wires of max(0, T − temperature_limit)", ("cost",)),
            Entry("time", "time", "s", "time at the end of the step", ("time",)),
            Entry(
                "tip_force",
                "force",
                "N",
                "force on the top disk (events + payload weight), global x/y/z",
                ("fx", "fy", "fz"),
            ),
            *self.reward_entries(),
        )

    def table(self) -> Table:
        raise NotImplementedError


@dataclass(frozen=True)
class Spine3DConfig(SpatialConfig):
    """Validated arguments of ``SmaSpine3D-v0`` (see :class:`spine_gym.envs.SmaSpine3DEnv`)."""

    target_range: tuple[float, float] = (0.0, 45.0)

    def _check_task(self) -> None:
        super()._check_task()
        object.__setattr__(self, "target_range", _pair("target_range", self.target_range, 0.0, TARGET_REACH))

    def table(self) -> Table:
        """The declarative observation/info table of ``SmaSpine3D-v0`` (one place per entry)."""
        temp, prev, res = self.wire_entries(self.wire_names, "wire resistance (one wire of the group)")
        lim = (-ANGLE_LIMIT, ANGLE_LIMIT)
        entries = (
            Entry(
                "tip_bending_deg",
                "tip_bending",
                "deg",
                "tip bending vector (Θ cos β, Θ sin β)",
                ("bending_x", "bending_y"),
                (-BEND_OBS_LIMIT, BEND_OBS_LIMIT),
                noise="angle",
            ),
            Entry(
                "target_deg", "target", "deg", "target bending vector b*(t)", ("target_x", "target_y"), lim
            ),
            temp,
            Entry(
                "bending_rate",
                "rate",
                "deg/s",
                "rate of the measured bending vector",
                ("bending_rate_x", "bending_rate_y"),
                (-RATE_OBS_LIMIT, RATE_OBS_LIMIT),
                info=False,
            ),
            Entry(
                "target_preview_deg",
                "preview",
                "deg",
                "target b*(t + target_preview)",
                ("preview_x", "preview_y"),
                lim,
                info=False,
            ),
            prev,
            res,
            Entry(
                "tip_position_mm",
                "tip_position",
                "mm",
                "tip position, global x/y/z",
                ("tip_x", "tip_y", "tip_z"),
            ),
            *self._step_entries("deg", "target − tip bending vector", 2),
            *self.error_entries("deg", ("x", "y"), BEND_OBS_LIMIT + ANGLE_LIMIT),
        )
        return Table(entries, "tip_bending_deg", self.noise_sigma)


@dataclass(frozen=True)
class ChainConfig(SpatialConfig):
    """Validated arguments of ``SmaSpineChain-v0`` (see :class:`spine_gym.envs.SmaSpineChainEnv`)."""

    NOISE_KEYS = ("angle", "temperature", "resistance", "position")  # position: tip [mm]

    n_modules: int = 2
    module_bend_limit: float = 20.0
    error_scale: float = 20.0  # [mm]

    def _check_task(self) -> None:
        object.__setattr__(self, "n_modules", _int("n_modules", self.n_modules, 1, MAX_MODULES))
        super()._check_task()
        limit = TARGET_REACH / self.n_modules
        object.__setattr__(
            self, "module_bend_limit", _real("module_bend_limit", self.module_bend_limit, 0.0, limit)
        )

    @property
    def length_mm(self) -> float:
        return 1000.0 * self._layout.length

    def table(self) -> Table:
        """The declarative observation/info table of ``SmaSpineChain-v0`` (one place per entry)."""
        temp, prev, res = self.wire_entries(self.wire_names, "wire resistance (one wire of the group)")
        lp = (-self.length_mm, self.length_mm)
        xyz = ("x", "y", "z")
        mod = tuple(f"module{k}_bending_{c}" for k in range(self.n_modules) for c in ("x", "y"))
        entries = (
            Entry(
                "tip_position_mm",
                "tip_position",
                "mm",
                "tip position, global x/y/z",
                tuple(f"tip_{c}" for c in xyz),
                lp,
                noise="position",
            ),
            Entry(
                "target_mm",
                "target",
                "mm",
                "target tip position p*(t)",
                tuple(f"target_{c}" for c in xyz),
                lp,
            ),
            Entry(
                "module_bending_deg",
                "module_bending",
                "deg",
                "bending vector of each module in its base frame (bottom module first)",
                mod,
                (-BEND_OBS_LIMIT, BEND_OBS_LIMIT),
                noise="angle",
            ),
            temp,
            Entry(
                "tip_velocity",
                "rate",
                "mm/s",
                "rate of the measured tip position",
                tuple(f"tip_velocity_{c}" for c in xyz),
                (-POSITION_RATE_LIMIT, POSITION_RATE_LIMIT),
                info=False,
            ),
            Entry(
                "target_preview_mm",
                "preview",
                "mm",
                "target p*(t + target_preview)",
                tuple(f"preview_{c}" for c in xyz),
                lp,
                info=False,
            ),
            prev,
            res,
            Entry(
                "tip_bending_deg",
                "tip_bending",
                "deg",
                "tip bending vector (tip tangent, base frame)",
                ("bending_x", "bending_y"),
                noise="angle",
            ),
            *self._step_entries("mm", "target − tip position", 3),
            *self.error_entries("mm", xyz, 2.0 * self.length_mm),
        )
        return Table(entries, "tip_position_mm", self.noise_sigma)


# ---------------------------------------------------------------- the batch of spatial spines
def _numbers(value) -> np.ndarray | None:
    """``value`` as a float array, or None if it is not numeric."""
    if isinstance(value, str | bytes):
        return None
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None


class SpatialBatch(TableBatch):
    """:class:`TableBatch` over the spatial core (per-spine layout tables, for randomised parameters)."""

    PLANT_ARRAYS = ("kws", "kms")
    PLANT = sk.SPATIAL_PLANT

    def _alloc_plant(self, b: int) -> None:
        lay = self.cfg.layout
        kp, kw, km = lay.to_kernel()
        self.nominal_kp = kp
        self._nominal = (kw, km)
        self._drawn_layout = None  # a layout drawn by _draw_params for the episode set next
        self.states = np.zeros((b, lay.state_size()))
        self.kps = np.tile(kp, (b, 1))
        self.kws = np.tile(kw, (b, 1, 1))
        self.kms = np.tile(km, (b, 1, 1))
        nw, nm, ns = lay.n_wires, lay.n_modules, lay.n_seg
        head = SL.sens_offset(nw, nm, ns)
        cols = np.zeros(ro.N_R, dtype=np.int64)
        cols[ro.R_MODB] = head
        cols[ro.R_TIPB] = head + 2 * nm
        cols[ro.R_TIPP] = head + 2 * nm + 2
        cols[ro.R_RHO] = head + 2 * nm + 2 + 3 + 9
        cols[ro.R_TEMP] = SL.wire_offset(SL.F_T, nw)
        cols[ro.R_QJ] = SL.wire_offset(SL.F_QJ, nw)
        self.record_cols = cols
        self._record_size = record_size(nw, nm, ns)

    def record_size(self) -> int:
        return self._record_size

    def _draw_params(self, rng: np.random.Generator, opts: dict) -> tuple[ModelParams, np.ndarray | None]:
        """As :meth:`TableBatch._draw_params`; a fit preset with per-wire parameters draws the whole
        layout (params and per-wire values), which the episode set next (:meth:`_set_episode`) takes."""
        dr = self.cfg.domain_randomization
        self._drawn_layout = None
        if opts.get("params") is None and isinstance(dr, ParameterUncertainty) and dr.per_wire:
            self._drawn_layout = dr.draw_plant(rng, self.cfg.layout)
            return self._drawn_layout.params, None
        return super()._draw_params(rng, opts)

    def _set_episode(self, i: int, params: ModelParams, kp: np.ndarray | None) -> None:
        drawn, self._drawn_layout = self._drawn_layout, None
        if drawn is not None:
            kp, kw, km = drawn.to_kernel()
        elif kp is None:
            try:
                lay = self.cfg.layout_for(params)
            except ValueError as e:
                raise ValueError(f"the episode's parameters give an invalid spine: {e}") from None
            if lay.state_size() != self.states.shape[1]:
                raise ValueError(
                    f"options['params'] must keep the layout (n_seg = {self.cfg.params.n_seg}), got "
                    f"n_seg = {params.n_seg}"
                )
            kp, kw, km = lay.to_kernel()
        else:
            kw, km = self._nominal
        self.kps[i] = kp
        self.kws[i] = kw
        self.kms[i] = km
        area = params.wire_area
        self.ohm[i] = kw[:, SL.W_L0] / area
        self.wvol[i] = kw[:, SL.W_NW] * area * kw[:, SL.W_L0]

    def _init_state(self, i: int, vforce: np.ndarray) -> int:
        return init_state(self.states[i], self.kps[i], self.ks, self.kws[i], self.kms[i], vforce)

    def _step_kernel(self):
        return sk.spatial_step if self.parallel else sk.spatial_step_serial

    def _record(self, rows: np.ndarray) -> None:
        record_many(self.states, self.kps, self.kws, self.kms, rows, self.meas)

    def _probe(self, rows: np.ndarray) -> None:
        ro.spatial_probe(rows, self.meas, self.record_cols, self.ohm, self.wvol, self.probe_cols, self.probe)

    # ------------------------------------------------------------------ rendering
    def state_summary(self, i: int) -> dict:
        """What the renderer needs for environment ``i``."""
        cfg = self.cfg
        target, loads, params = self.episodes[i]
        k = int(self.mem.k[i])
        nw, nm, ns = cfg.n_wires, cfg.n_modules, cfg.n_seg
        oo = SL.omega_offset(nw, nm)
        return {
            "omega": self.states[i, oo : oo + 2 * ns].reshape(ns, 2).copy(),
            "kw": self.kws[i].copy(),
            "km": self.kms[i].copy(),
            "temperature": self.probe[
                i, self.probe_cols[ro.PB_TEMP] : self.probe_cols[ro.PB_TEMP] + nw
            ].copy(),
            "ambient": float(params.T_E),
            "target": self.targets[i, min(k, self.targets.shape[1] - 1)].copy(),
            "task": self.table.task.key,
            "tip_force": self.forces[i, min(k, cfg.n_steps - 1)].copy(),
            "time": k * cfg.control_period,
            "voltage": self.volts[i].copy() if k else np.zeros(nw),
            "length": cfg.layout.length,
        }


class Spine3DBatch(SpatialBatch):
    """The batch of ``SmaSpine3D-v0``: targets are :class:`BendTarget` s."""

    def _parse_target(self, target) -> BendTarget:
        if isinstance(target, BendTarget):
            return target
        b = _numbers(target)
        if b is None or b.shape != (2,) or not np.isfinite(b).all():
            raise ValueError(
                f"options['target'] must be a BendTarget or a bending vector (b1, b2) [deg], got {target!r}"
            )
        return BendTarget.constant(float(b[0]), float(b[1]))

    def _sample_target(self, rng: np.random.Generator) -> BendTarget:
        cfg = self.cfg
        return BendTarget.sample(
            rng, cfg.episode_duration, cfg.target_range, cfg.target_kinds, cfg.target_period_range
        )

    def _target_grid(self, i: int, target: BendTarget) -> np.ndarray:
        return target(self.time_grid)


class ChainBatch(SpatialBatch):
    """The batch of ``SmaSpineChain-v0``: targets are :class:`ChainTarget` s (tip positions [mm])."""

    def _parse_target(self, target) -> ChainTarget:
        k = self.cfg.n_modules
        if not isinstance(target, ChainTarget):
            b = _numbers(target)
            if b is None or b.shape != (k, 2) or not np.isfinite(b).all():
                raise ValueError(
                    f"options['target'] must be a ChainTarget or ({k}, 2) module bending vectors [deg], "
                    f"got {target!r}"
                )
            target = ChainTarget.constant(b)
        if target.n_modules != k:
            raise ValueError(f"options['target'] must have n_modules = {k} modules, got {target.n_modules}")
        return target

    def _sample_target(self, rng: np.random.Generator) -> ChainTarget:
        cfg = self.cfg
        return ChainTarget.sample(
            rng,
            cfg.episode_duration,
            cfg.n_modules,
            cfg.module_bend_limit,
            cfg.target_kinds,
            cfg.target_period_range,
        )

    def _target_grid(self, i: int, target: ChainTarget) -> np.ndarray:
        return target.position(self.time_grid, self.kms[i])


def workspace_radius_mm(cfg: ChainConfig) -> float:
    """Largest horizontal tip distance of the workspace [mm]: every module bent by
    ``module_bend_limit`` in the same direction (the arcs add up)."""
    _, _, km = cfg.layout.to_kernel()
    bends = np.tile([cfg.module_bend_limit, 0.0], (cfg.n_modules, 1))
    return float(math.hypot(*arc_tip_position(bends, km)[:2]))


def workspace_low_mm(cfg: ChainConfig) -> float:
    """Lowest tip height of the workspace [mm]: every module bent by ``module_bend_limit`` the same way."""
    _, _, km = cfg.layout.to_kernel()
    bends = np.tile([cfg.module_bend_limit, 0.0], (cfg.n_modules, 1))
    return float(arc_tip_position(bends, km)[2])
