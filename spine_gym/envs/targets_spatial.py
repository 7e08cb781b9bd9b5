"""Targets of the spatial envs: tip bending vectors (``SmaSpine3D-v0``), tip positions (``SmaSpineChain-v0``).

* :class:`BendTarget` — a target bending vector b*(t) = (Θ cos β, Θ sin β) [deg] (SPATIAL.md §2):
  setpoint steps to random directions and magnitudes, circles and figure-eights of the tip
  direction.
* :class:`ChainTarget` — a target tip position p*(t) [mm] of a chain: one :class:`BendTarget` per
  module, mapped to the tip by the chain's kinematics with every module bent as a circular arc
  (:func:`arc_tip_position`). A target drawn with every module's bend magnitude at most the
  env's ``module_bend_limit`` lies in the workspace the env documents (and tests: the model
  reaches those bends).

Frozen dataclasses, as :mod:`.targets_planar`: written by hand to pin an episode
(``reset(options={"target": ...})``) or drawn by ``sample`` from the env's seeded generator.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from ..physics.spatial.columns import M_NSEG, M_SEG0
from ..physics.spatial.tube import kinematics, positions
from .targets_planar import ANGLE_LIMIT, _finite, _range

__all__ = ["BendTarget", "ChainTarget", "BEND_KINDS", "arc_positions", "arc_tip_position"]

BEND_KINDS = ("steps", "circle", "figure8")
_ALL_KINDS = (*BEND_KINDS, "constant")


@dataclass(frozen=True)
class BendTarget:
    """Target bending vector b*(t) [deg] = base(t) + pattern(t).

    ``base`` holds the setpoints ``values[k]`` from ``times[k]`` on (``values[0]`` before); the
    pattern, with φ = phase + 2π t / period, is

    * ``"circle"``: amplitude · (cos φ, sin φ) — the tip direction circles at polar angle
      ``amplitude`` about the base (counter-clockwise seen from above; a negative period turns
      the other way);
    * ``"figure8"``: amplitude · R(rotation) (sin φ, ½ sin 2φ) — a lemniscate of half-width
      ``amplitude`` whose long axis points at azimuth ``rotation_deg``;
    * ``"steps"``, ``"constant"``: none.

    Attributes:
        kind: one of ``"steps"``, ``"circle"``, ``"figure8"``, ``"constant"``.
        times: setpoint times [s], strictly increasing.
        values: setpoints (b1, b2) [deg].
        amplitude: pattern size [deg], >= 0.
        period: pattern period [s], != 0.
        phase: φ at t = 0 [rad].
        rotation_deg: long axis of the figure-eight [deg].
    """

    kind: str = "constant"
    times: tuple[float, ...] = (0.0,)
    values: tuple[tuple[float, float], ...] = ((0.0, 0.0),)
    amplitude: float = 0.0
    period: float = 1.0
    phase: float = 0.0
    rotation_deg: float = 0.0

    def __post_init__(self):
        if self.kind not in _ALL_KINDS:
            raise ValueError(f"kind must be one of {_ALL_KINDS}, got {self.kind!r}")
        times = tuple(_finite("times", t) for t in np.atleast_1d(np.asarray(self.times, dtype=float)))
        values = np.asarray(self.values, dtype=float)
        if values.ndim != 2 or values.shape != (len(times), 2) or not np.isfinite(values).all():
            raise ValueError(
                f"values must be {len(times)} finite (b1, b2) pairs [deg] (one per time), got {self.values!r}"
            )
        if any(b <= a for a, b in zip(times[:-1], times[1:], strict=True)):
            raise ValueError(f"times must be strictly increasing, got {times}")
        amplitude = _finite("amplitude", self.amplitude)
        if amplitude < 0.0:
            raise ValueError(f"amplitude must be >= 0 deg, got {self.amplitude!r}")
        period = _finite("period", self.period)
        if period == 0.0:
            raise ValueError(f"period must be != 0 s, got {self.period!r}")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", tuple((float(a), float(b)) for a, b in values))
        object.__setattr__(self, "amplitude", amplitude)
        object.__setattr__(self, "period", period)
        object.__setattr__(self, "phase", _finite("phase", self.phase))
        object.__setattr__(self, "rotation_deg", _finite("rotation_deg", self.rotation_deg))
        if self.max_magnitude() > ANGLE_LIMIT:
            raise ValueError(
                f"a bend target must stay within |b| <= {ANGLE_LIMIT:g} deg, this one reaches "
                f"{self.max_magnitude():g} deg"
            )

    # ------------------------------------------------------------------ constructors
    @classmethod
    def constant(cls, b1: float, b2: float = 0.0) -> BendTarget:
        """Hold (b1, b2) [deg]."""
        return cls("constant", (0.0,), ((b1, b2),))

    @classmethod
    def polar(cls, theta_deg: float, azimuth_deg: float) -> BendTarget:
        """Hold a bend of ``theta_deg`` toward azimuth ``azimuth_deg`` (from wire 0 toward wire 1)."""
        r = math.radians(azimuth_deg)
        return cls.constant(theta_deg * math.cos(r), theta_deg * math.sin(r))

    @classmethod
    def sample(
        cls,
        rng: np.random.Generator,
        duration: float,
        magnitude_range: tuple[float, float] = (0.0, 45.0),
        kinds: Iterable[str] = BEND_KINDS,
        period_range: tuple[float, float] = (20.0, 60.0),
    ) -> BendTarget:
        """Draw a target whose magnitude ``|b*|`` stays in ``magnitude_range`` [deg].

        One of ``kinds`` uniformly, then:

        * ``"steps"``: 1-3 setpoints, magnitude ~ U(magnitude_range), azimuth ~ U(0°, 360°); the
          k-th of n starts at k·duration/n jittered by up to ±25 % of a hold (as
          :meth:`TargetProfile.sample`);
        * ``"circle"``: amplitude ~ U(magnitude_range), period ~ U(period_range) with a random
          sense of rotation, phase ~ U(0, 2π);
        * ``"figure8"``: amplitude ~ U(magnitude_range) (so ``|b*| <= amplitude``), period ~
          U(period_range), phase ~ U(0, 2π), long axis ~ U(0°, 180°).
        """
        duration = _finite("duration", duration)
        if duration <= 0.0:
            raise ValueError(f"duration must be > 0 s, got {duration!r}")
        lo, hi = _range("magnitude_range", magnitude_range, 0.0, ANGLE_LIMIT)
        p_lo, p_hi = _range("period_range", period_range, 1e-3, math.inf)
        kinds = tuple(kinds)
        if not kinds or any(k not in BEND_KINDS for k in kinds):
            raise ValueError(f"kinds must be a non-empty subset of {BEND_KINDS}, got {kinds!r}")
        kind = kinds[int(rng.integers(len(kinds)))]
        if kind == "steps":
            n = int(rng.integers(1, 4))
            hold = duration / n
            times = [0.0] + [k * hold + rng.uniform(-0.25, 0.25) * hold for k in range(1, n)]
            mag = rng.uniform(lo, hi, size=n)
            az = rng.uniform(0.0, 2.0 * math.pi, size=n)
            return cls("steps", tuple(times), tuple(zip(mag * np.cos(az), mag * np.sin(az), strict=True)))
        amplitude = rng.uniform(lo, hi)
        period = rng.uniform(p_lo, p_hi) * (1.0 if rng.uniform() < 0.5 else -1.0)
        phase = rng.uniform(0.0, 2.0 * math.pi)
        if kind == "circle":
            return cls("circle", amplitude=amplitude, period=period, phase=phase)
        rotation = rng.uniform(0.0, 180.0)
        return cls("figure8", amplitude=amplitude, period=abs(period), phase=phase, rotation_deg=rotation)

    # ------------------------------------------------------------------ evaluation
    def __call__(self, t) -> np.ndarray:
        """b*(t) [deg]: (2,) for a scalar time, (len(t), 2) for an array of times [s]."""
        tt = np.asarray(t, dtype=np.float64)
        idx = np.clip(np.searchsorted(np.asarray(self.times), tt, side="right") - 1, 0, len(self.times) - 1)
        out = np.asarray(self.values)[idx].copy()
        if self.kind in ("circle", "figure8") and self.amplitude:
            phi = self.phase + 2.0 * np.pi * tt / self.period
            if self.kind == "circle":
                u, v = np.cos(phi), np.sin(phi)
            else:
                x, y = np.sin(phi), 0.5 * np.sin(2.0 * phi)
                r = math.radians(self.rotation_deg)
                u, v = math.cos(r) * x - math.sin(r) * y, math.sin(r) * x + math.cos(r) * y
            out[..., 0] += self.amplitude * u
            out[..., 1] += self.amplitude * v
        return out

    def max_magnitude(self) -> float:
        """An upper bound of ``|b*(t)|`` over all times [deg] (largest setpoint + amplitude)."""
        return max(math.hypot(a, b) for a, b in self.values) + self.amplitude


# ====================================================================== chains
def arc_positions(bends_deg: np.ndarray, km: np.ndarray) -> np.ndarray:
    """Vertex positions [mm] of chains whose modules are circular arcs with the given bending vectors.

    Module k (bottom first) bent by b_k (SPATIAL.md §2: polar angle |b_k| toward azimuth
    atan2(b_k2, b_k1) in the module's base frame) has every segment rotated by the same ω, of
    magnitude |b_k| / N_k about the axis normal to the bend (a parallel-transported frame turns by
    equal steps on an arc); the positions are the spatial core's own kinematics
    (:func:`spine_gym.physics.spatial.tube.kinematics`).

    Args:
        bends_deg: (K, 2) or (n, K, 2) module bending vectors [deg].
        km: the layout's module table (``SpineLayout.to_kernel()[2]``).

    Returns:
        (N + 1, 3) or (n, N + 1, 3) vertex positions P_0 (tip) … P_N (base), global x, y, z [mm].
    """
    b = np.asarray(bends_deg, dtype=np.float64)
    single = b.ndim == 2
    b = b[None] if single else b
    nm = km.shape[0]
    if b.shape[1:] != (nm, 2):
        raise ValueError(f"bends_deg must have shape ({nm}, 2) or (n, {nm}, 2), got {np.shape(bends_deg)}")
    ns = int(km[:, M_NSEG].sum())
    omega = np.empty((ns, 2))
    frames = np.empty((ns + 1, 3, 3))
    chords = np.empty((ns, 3))
    pos = np.empty((ns + 1, 3))
    out = np.empty((b.shape[0], ns + 1, 3))
    for r in range(b.shape[0]):
        for k in range(nm):
            s0, nk = int(km[k, M_SEG0]), int(km[k, M_NSEG])
            # the tangent tilts toward (ω2, −ω1) (SPATIAL.md §2): ω = (−b2, b1) / N_k
            omega[s0 : s0 + nk, 0] = -np.radians(b[r, k, 1]) / nk
            omega[s0 : s0 + nk, 1] = np.radians(b[r, k, 0]) / nk
        kinematics(omega, km, frames, chords)
        positions(chords, pos)
        out[r] = pos * 1000.0
    return out[0] if single else out


def arc_tip_position(bends_deg: np.ndarray, km: np.ndarray) -> np.ndarray:
    """Tip position(s) [mm], (3,) or (n, 3), of :func:`arc_positions`."""
    return arc_positions(bends_deg, km)[..., 0, :]


@dataclass(frozen=True)
class ChainTarget:
    """Target tip position p*(t) [mm] of a chain: module k follows ``modules[k]`` (a
    :class:`BendTarget`, bottom first) as a circular arc; p*(t) = :func:`arc_tip_position`."""

    modules: tuple[BendTarget, ...]

    def __post_init__(self):
        mods = tuple(self.modules) if isinstance(self.modules, list | tuple) else None
        if not mods or not all(isinstance(m, BendTarget) for m in mods):
            raise ValueError(f"modules must be a non-empty tuple of BendTarget, got {self.modules!r}")
        object.__setattr__(self, "modules", mods)

    @property
    def n_modules(self) -> int:
        return len(self.modules)

    @property
    def kind(self) -> str:
        return self.modules[0].kind

    @classmethod
    def constant(cls, bends_deg: Sequence[Sequence[float]]) -> ChainTarget:
        """Hold the arc configuration ``bends_deg`` ((K, 2) module bending vectors [deg])."""
        return cls(tuple(BendTarget.constant(float(a), float(b)) for a, b in bends_deg))

    @classmethod
    def sample(
        cls,
        rng: np.random.Generator,
        duration: float,
        n_modules: int,
        bend_limit: float,
        kinds: Iterable[str] = BEND_KINDS,
        period_range: tuple[float, float] = (20.0, 60.0),
    ) -> ChainTarget:
        """Draw one kind for all modules, then per module a :meth:`BendTarget.sample` with
        magnitude in [0, ``bend_limit``] [deg]; circles and figure-eights share period, phase,
        sense and axis across the modules (the tip traces one closed curve), steps share times."""
        kinds = tuple(kinds)
        if not kinds or any(k not in BEND_KINDS for k in kinds):
            raise ValueError(f"kinds must be a non-empty subset of {BEND_KINDS}, got {kinds!r}")
        kind = kinds[int(rng.integers(len(kinds)))]
        first = BendTarget.sample(rng, duration, (0.0, bend_limit), (kind,), period_range)
        mods = [first]
        for _ in range(1, n_modules):
            if kind == "steps":
                n = len(first.times)
                mag = rng.uniform(0.0, bend_limit, size=n)
                az = rng.uniform(0.0, 2.0 * math.pi, size=n)
                vals = tuple(zip(mag * np.cos(az), mag * np.sin(az), strict=True))
                mods.append(BendTarget("steps", first.times, vals))
            else:
                mods.append(
                    BendTarget(
                        kind,
                        amplitude=rng.uniform(0.0, bend_limit),
                        period=first.period,
                        phase=first.phase,
                        rotation_deg=first.rotation_deg,
                    )
                )
        return cls(tuple(mods))

    def bends(self, t) -> np.ndarray:
        """Module bending vectors [deg]: (K, 2) or (len(t), K, 2)."""
        return np.stack([m(t) for m in self.modules], axis=-2)

    def position(self, t, km: np.ndarray) -> np.ndarray:
        """p*(t) [mm]: (3,) or (len(t), 3) for the chain of module table ``km``."""
        return arc_tip_position(self.bends(t), km)

    def max_bend(self) -> float:
        """Largest module bend magnitude over all times (upper bound) [deg]."""
        return max(m.max_magnitude() for m in self.modules)
