"""Wire and module layout of a spatial or chained spine (SPATIAL.md §1, §6): validated frozen dataclasses.

A :class:`SpineLayout` stacks :class:`Module` s bottom (index 0) to top; each module is a run of
segments between two disks with its own :class:`WireGroup` s (azimuth ψ in the tube's material
frame, offset a from the axis, n_w parallel wires in the pore), anchored at its two disks. The
material, wire diameter, pre-strain, tube section and modulus, mass per unit length of the tube
(``m_seg / ls`` of the params) and gravity come from ``params`` (a :class:`ModelParams`); the
geometry fields of ``params`` (``a``, ``n_w``, ``n_seg``, ``ls``, ``L0``, ``m_top``) are used only
by the factories below as the seed's defaults, never by the spatial kernels.

Factories:

* :meth:`SpineLayout.seed` (also ``SpineLayout()``): the seed's one four-wire module,
  ψ = 0°, 90°, 180°, 270° (wire 0 = planar "right", wire 2 = "left");
* :meth:`SpineLayout.planar`: the planar pair (0°, 180°) as a spatial layout (SPATIAL.md §7.1);
* :meth:`SpineLayout.chain`: ``n_modules`` four-wire modules sharing the seed's bending length and
  wire length (default 2 × 7 segments of 32.5 mm, wires of 230 mm), joint disks like the top disk.

Joule heating is V²/(ρ_e L0²) (MODEL.md §3.7): a module with shorter wires heats as the seed's
wire at a proportionally lower voltage, so the voltage of full drive should scale with the wire
length, :attr:`SpineLayout.voltage_scale` (= L0 of the wire's module / ``params.L0``).

Validation raises ``ValueError`` naming the field, the allowed range and the value: azimuths
outside [0°, 360°), wire groups closer than one wire diameter (overlapping pores), pores inside
the bore, a wire count of 0, and layouts whose straight column is past self-weight buckling
(:func:`spine_gym.physics.spatial.tube.straight_load_factor` ≥ 1).
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass, field

import numpy as np

from .params import ModelParams, _check
from .physics.spatial import columns as SL
from .physics.spatial.tube import straight_load_factor

MAX_MODULES = 100
MAX_WIRE_GROUPS = 64
SEED_AZIMUTHS_DEG = (0.0, 90.0, 180.0, 270.0)  # SPATIAL.md §1
PLANAR_AZIMUTHS_DEG = (0.0, 180.0)  # right, left (MODEL.md §4.3)


def _integer(name: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer) or int(value) != value:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
    if not lo <= int(value) <= hi:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
    return int(value)


def _unit(psi_deg: float) -> tuple[float, float]:
    """(−sin ψ, cos ψ), the material direction of a unit tension's moment (SPATIAL.md §3).

    Values within 1e-15 of 0 or ±1 are snapped, so that the quarter-turn azimuths give exact
    zeros (the planar layouts keep their d1 components exactly zero, SPATIAL.md §7.1–7.2).
    """
    r = math.radians(psi_deg)
    out = []
    for v in (-math.sin(r), math.cos(r)):
        for exact in (-1.0, 0.0, 1.0):
            if abs(v - exact) < 1e-15:
                v = exact
        out.append(v)
    return out[0], out[1]


WIRE_VALUES = ("lam_scale", "T_shift", "eps0")  # the per-wire material values of a WireGroup
WIRE_VALUE_RANGES = {"lam_scale": (0.2, 5.0), "T_shift": (-100.0, 100.0), "eps0": (0.0, 0.2)}
_WIRE_KEY = re.compile(r"^wire(\d+)\.(" + "|".join(WIRE_VALUES) + r")$")


def wire_key(name: str) -> tuple[int, str] | None:
    """(wire index, value) of a per-wire name ``wire<j>.<value>`` (a fit parameter or a direction
    key of :func:`spine_gym.uncertainty.apply_offsets`; j in voltage order), else None."""
    m = _WIRE_KEY.match(name)
    return (int(m.group(1)), m.group(2)) if m else None


@dataclass(frozen=True)
class WireGroup:
    """n_w parallel wires in one pore at azimuth ``psi_deg`` and offset ``a`` (SPATIAL.md §1).

    A wire batch is never uniform, so each group may differ from the layout's ``params`` in three
    material values (defaults: no difference):

    * ``lam_scale`` [-]: its resistivities are ``lam_scale`` × λ_A, λ_M of the params (Joule
      heating and resistance);
    * ``T_shift`` [K]: its transformation temperatures are shifted by ``T_shift``, exactly as the
      params' ``T_low`` and ``T_high`` moved together (σ_A(T) and σ_M(T) move along T at unchanged
      slope: Δu grows by Δη·``T_shift``, MODEL.md §3.1);
    * ``eps0`` [-]: its pre-strain (None: the params' ``eps0``).
    """

    psi_deg: float  # [deg] azimuth in the material frame, in [0, 360); 0 = +d1 (global x at the base)
    a: float  # [m] offset of the pore from the tube axis
    n_w: int  # [-] identical parallel wires, each at the full voltage
    lam_scale: float = 1.0  # [-] resistivity scale, in [0.2, 5]
    T_shift: float = 0.0  # [K] transformation-temperature shift, in [-100, 100]
    eps0: float | None = None  # [-] pre-strain in [0, 0.2]; None: the params' eps0

    def __post_init__(self):
        try:
            psi = float(self.psi_deg)
        except (TypeError, ValueError):
            raise ValueError(f"psi_deg must be a real number in [0, 360) deg, got {self.psi_deg!r}") from None
        if not (math.isfinite(psi) and 0.0 <= psi < 360.0):
            raise ValueError(f"psi_deg must be in [0, 360) deg, got {self.psi_deg!r}")
        object.__setattr__(self, "psi_deg", psi)
        _check("a", self.a, 1e-4, 0.5)
        object.__setattr__(self, "a", float(self.a))
        object.__setattr__(self, "n_w", _integer("n_w", self.n_w, 1, 100))
        for name in WIRE_VALUES:
            v = getattr(self, name)
            if name == "eps0" and v is None:
                continue
            _check(name, v, *WIRE_VALUE_RANGES[name])
            object.__setattr__(self, name, float(v))

    def values(self, params: ModelParams) -> dict[str, float]:
        """{lam_scale, T_shift, eps0} of this group (``eps0`` resolved against ``params``)."""
        return {
            "lam_scale": self.lam_scale,
            "T_shift": self.T_shift,
            "eps0": params.eps0 if self.eps0 is None else self.eps0,
        }

    @property
    def pore(self) -> tuple[float, float]:
        """Pore centre (x, y) [m] in the section's material axes (d1, d2)."""
        r = math.radians(self.psi_deg)
        return self.a * math.cos(r), self.a * math.sin(r)


@dataclass(frozen=True)
class Module:
    """A run of ``n_seg`` segments of arc length ``ls`` between two disks, with its own wires."""

    wires: tuple[WireGroup, ...]  # wire groups anchored at this module's two disks (may be empty)
    n_seg: int  # [-] segments
    ls: float  # [m] segment arc length
    L0: float  # [m] wire length in the straight module (>= n_seg·ls)
    m_disk: float  # [kg] disk at the module's top (the top disk of the spine for the top module)

    def __post_init__(self):
        wires = tuple(self.wires) if isinstance(self.wires, list | tuple) else (None,)
        if len(wires) > MAX_WIRE_GROUPS or not all(isinstance(w, WireGroup) for w in wires):
            raise ValueError(
                f"wires must be a tuple of at most {MAX_WIRE_GROUPS} WireGroup, got {self.wires!r}"
            )
        object.__setattr__(self, "wires", wires)
        object.__setattr__(self, "n_seg", _integer("n_seg", self.n_seg, 1, 1000))
        _check("ls", self.ls, 1e-4, 1.0)
        _check("L0", self.L0, 0.01, 10.0)
        _check("m_disk", self.m_disk, 0.0, 100.0)
        for name in ("ls", "L0", "m_disk"):
            object.__setattr__(self, name, float(getattr(self, name)))
        if self.L0 < self.n_seg * self.ls:
            raise ValueError(
                f"L0 must be >= n_seg*ls = {self.n_seg * self.ls:g} m (the wire spans the module), "
                f"got {self.L0!r}"
            )

    @property
    def length(self) -> float:
        """Bending length n_seg·ls [m]."""
        return self.n_seg * self.ls


def seed_module(params: ModelParams, azimuths_deg=SEED_AZIMUTHS_DEG) -> Module:
    """The seed's module (MODEL.md §7 geometry) with one wire group per azimuth."""
    wires = tuple(WireGroup(psi, params.a, params.n_w) for psi in azimuths_deg)
    return Module(wires, params.n_seg, params.ls, params.L0, params.m_top)


@dataclass(frozen=True)
class SpineLayout:
    """Modules bottom (0) to top, and the material/tube parameters (see the module docstring).

    Wire groups are numbered module by module, bottom first, in each module's order: this is
    the order of the voltages and of every per-wire output.
    """

    modules: tuple[Module, ...] = None  # None: the seed's four-wire module
    params: ModelParams = field(default_factory=ModelParams)

    def __post_init__(self):
        if not isinstance(self.params, ModelParams):
            raise ValueError(f"params must be a ModelParams, got {type(self.params).__name__}")
        if self.modules is None:
            object.__setattr__(self, "modules", (seed_module(self.params),))
        mods = tuple(self.modules) if isinstance(self.modules, list | tuple) else None
        if not mods or len(mods) > MAX_MODULES or not all(isinstance(m, Module) for m in mods):
            raise ValueError(f"modules must be a tuple of 1 to {MAX_MODULES} Module, got {self.modules!r}")
        object.__setattr__(self, "modules", mods)
        for k, m in enumerate(mods):
            self._check_pores(k, m)
        rho = self.load_factor
        if not rho < 1.0:
            raise ValueError(
                f"modules: total length {self.length:g} m must stand under its own weight: the straight "
                f"column's load factor (axial load / buckling load) must be in [0, 1), got {rho:.3f}"
            )

    def _check_pores(self, k: int, m: Module) -> None:
        p = self.params
        for j, w in enumerate(m.wires):
            if w.a <= 0.5 * p.D_i:
                raise ValueError(
                    f"modules[{k}].wires[{j}].a must be > D_i/2 = {0.5 * p.D_i:g} m, got {w.a!r}"
                )
            for i in range(j):
                (x0, y0), (x1, y1) = m.wires[i].pore, w.pore
                gap = math.hypot(x1 - x0, y1 - y0)
                if gap < p.d:
                    raise ValueError(
                        f"modules[{k}].wires[{j}] overlaps wires[{i}]: pore distance must be >= the wire "
                        f"diameter d = {p.d:g} m, got {gap:g} m (psi_deg {w.psi_deg:g} vs "
                        f"{m.wires[i].psi_deg:g}, a {w.a:g} vs {m.wires[i].a:g})"
                    )

    # ---------------------------------------------------------------- factories
    @classmethod
    def seed(cls, params: ModelParams | None = None) -> SpineLayout:
        """The seed's one four-wire module (SPATIAL.md §1)."""
        params = params or ModelParams()
        return cls((seed_module(params),), params)

    @classmethod
    def planar(cls, params: ModelParams | None = None, *, neutral_wires: bool = False) -> SpineLayout:
        """The planar pair (wire 0 = right at 0°, then left at 180°) as a spatial layout.

        ``neutral_wires=True`` gives all four seed wires (0°, 90°, 180°, 270°): the planar pair
        plus two on the neutral axis of the planar bend (SPATIAL.md §6, §7.1).
        """
        params = params or ModelParams()
        az = SEED_AZIMUTHS_DEG if neutral_wires else PLANAR_AZIMUTHS_DEG
        return cls((seed_module(params, az),), params)

    @classmethod
    def chain(cls, n_modules: int = 2, params: ModelParams | None = None) -> SpineLayout:
        """``n_modules`` four-wire modules sharing the seed's bending length and wire length.

        Each module has ceil(N/n_modules) segments of length N·ls/(n_modules·ceil(N/n_modules))
        and wires of L0/n_modules; every joint carries a disk of the top disk's mass (SPATIAL.md §6).
        """
        params = params or ModelParams()
        n_modules = _integer("n_modules", n_modules, 1, MAX_MODULES)
        n_seg = math.ceil(params.n_seg / n_modules)
        ls = params.n_seg * params.ls / (n_modules * n_seg)
        wires = tuple(WireGroup(psi, params.a, params.n_w) for psi in SEED_AZIMUTHS_DEG)
        mod = Module(wires, n_seg, ls, params.L0 / n_modules, params.m_top)
        return cls((mod,) * n_modules, params)

    def with_wire_values(self, values) -> SpineLayout:
        """A copy whose wire groups (voltage order) take the per-wire material values ``values``:
        a sequence of one mapping per wire group with keys among ``lam_scale``, ``T_shift``,
        ``eps0`` (missing keys keep the group's value), or None (no change)."""
        if values is None:
            return self
        values = list(values) if isinstance(values, list | tuple) else None
        if values is None or len(values) != self.n_wires:
            raise ValueError(
                f"wire values must be a sequence of {self.n_wires} mappings (one per wire group), "
                f"got {values!r}"
            )
        mods, j = [], 0
        for m in self.modules:
            groups = []
            for w in m.wires:
                v = values[j]
                if not isinstance(v, dict) or set(v) - set(WIRE_VALUES):
                    raise ValueError(
                        f"wire values[{j}] must be a mapping with keys among {list(WIRE_VALUES)}, got {v!r}"
                    )
                try:
                    groups.append(dataclasses.replace(w, **v))
                except ValueError as e:
                    raise ValueError(f"wire values[{j}]: {e}") from None
                j += 1
            mods.append(dataclasses.replace(m, wires=tuple(groups)))
        return self.replace(modules=tuple(mods))

    @property
    def wire_values(self) -> list[dict[str, float]]:
        """Per wire group (voltage order) its {lam_scale, T_shift, eps0} (eps0 resolved)."""
        return [w.values(self.params) for m in self.modules for w in m.wires]

    def replace(self, **changes) -> SpineLayout:
        """A validated copy with ``changes`` applied (fields: ``modules``, ``params``)."""
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise ValueError(
                f"unknown SpineLayout field(s) {sorted(unknown)}; valid fields: ['modules', 'params']"
            )
        return dataclasses.replace(self, **changes)

    # ---------------------------------------------------------------- derived
    @property
    def n_modules(self) -> int:
        return len(self.modules)

    @property
    def n_wires(self) -> int:
        """Wire groups W (the length of the voltage vector)."""
        return sum(len(m.wires) for m in self.modules)

    @property
    def n_seg(self) -> int:
        """Total segment count N."""
        return sum(m.n_seg for m in self.modules)

    @property
    def length(self) -> float:
        """Total bending length [m]."""
        return sum(m.length for m in self.modules)

    @property
    def wire_module(self) -> np.ndarray:
        """(W,) module index of every wire group."""
        return np.array([k for k, m in enumerate(self.modules) for _ in m.wires], dtype=int)

    @property
    def wire_labels(self) -> list[str]:
        """Human-readable names "m<k>:<ψ>°" of the wire groups, in voltage order."""
        return [f"m{k}:{w.psi_deg:g}°" for k, m in enumerate(self.modules) for w in m.wires]

    @property
    def voltage_scale(self) -> np.ndarray:
        """(W,) L0 of the wire's module / ``params.L0``: multiply a planar drive voltage by it for
        the same Joule heating per unit volume (MODEL.md §3.7, SPATIAL.md §6)."""
        return np.array([m.L0 / self.params.L0 for m in self.modules for _ in m.wires])

    @property
    def segment_masses(self) -> np.ndarray:
        """(K,) mass per segment of every module [kg]: the params' mass per length × ls."""
        return np.array([self.params.m_seg * (m.ls / self.params.ls) for m in self.modules])

    @property
    def load_factor(self) -> float:
        """Axial load / self-weight buckling load of the straight column (< 1 stands)."""
        _, _, km = self.to_kernel()
        return straight_load_factor(km, self.params.E_t * self.params.I_tube, self.params.g)

    def to_kernel(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(kp, kw, km): material constants, wire-group table and module table for the kernels."""
        p = self.params
        kw = np.zeros((self.n_wires, SL.KW_SIZE))
        km = np.zeros((self.n_modules, SL.KM_SIZE))
        seg0 = self.n_seg
        j = 0
        for k, (m, mseg) in enumerate(zip(self.modules, self.segment_masses, strict=True)):
            seg0 -= m.n_seg  # segments are indexed top-down, modules bottom-up
            km[k] = 0.0
            km[k, SL.M_SEG0] = seg0
            km[k, SL.M_NSEG] = m.n_seg
            km[k, SL.M_LS] = m.ls
            km[k, SL.M_MSEG] = mseg
            km[k, SL.M_MDISK] = m.m_disk
            for w in m.wires:
                ex, ey = _unit(w.psi_deg)
                kw[j, SL.W_MOD] = k
                kw[j, SL.W_EX] = ex
                kw[j, SL.W_EY] = ey
                kw[j, SL.W_A] = w.a
                kw[j, SL.W_NW] = w.n_w
                kw[j, SL.W_L0] = m.L0
                eps0 = p.eps0 if w.eps0 is None else w.eps0
                kw[j, SL.W_LREF] = m.L0 / (1.0 + eps0)
                kw[j, SL.W_LAMS] = w.lam_scale
                kw[j, SL.W_DU] = p.delta_eta * w.T_shift
                kw[j, SL.W_EPS0] = eps0
                j += 1
        return p.to_kernel(), kw, km

    def state_size(self) -> int:
        """Length of the spatial state vector."""
        return SL.state_size(self.n_wires, self.n_modules, self.n_seg)
