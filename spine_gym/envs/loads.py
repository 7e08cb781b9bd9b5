"""The external loads of every env: tip-force events and a payload, as a schedule over an episode.

A :class:`LoadSchedule` is a frozen dataclass that can be written by hand (to pin an episode
through ``env.reset(options={"loads": ...})``) or drawn from a seeded
:class:`numpy.random.Generator` by :meth:`LoadSchedule.sample` (what the environment does at
every reset when no option pins it). Nothing here knows about the physics: a schedule is a
function of time in newtons, in the global frame (planar: x to the right, y up; spatial: z up,
x toward wire 0); a payload's weight is (0, -m g) or (0, 0, -m g).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .targets_planar import _finite, _range

__all__ = ["TipForceEvent", "LoadSchedule", "STANDARD_GRAVITY"]

STANDARD_GRAVITY = 9.81  # [m/s^2] default g of a payload weight (ModelParams.g)


@dataclass(frozen=True)
class TipForceEvent:
    """A force on the top disk, constant over ``[start, end)``.

    Attributes:
        start: onset [s], >= 0.
        end: switch-off time [s], > start (``inf`` for "until the end").
        force: (fx, fy) [N] for the planar spine (global frame, x toward the right wire, y up), or
            (fx, fy, fz) [N] for the spatial spines (SPATIAL.md §1: z up, x toward wire 0).
    """

    start: float
    end: float
    force: tuple[float, float]

    def __post_init__(self):
        start = _finite("start", self.start)
        try:
            end = float(self.end)
        except (TypeError, ValueError):
            raise ValueError(f"end must be a real number, got {self.end!r}") from None
        if start < 0.0:
            raise ValueError(f"start must be >= 0 s, got {self.start!r}")
        if math.isnan(end) or end <= start:
            raise ValueError(f"end must be > start = {start:g} s, got {self.end!r}")
        if np.shape(self.force) not in ((2,), (3,)):
            raise ValueError(f"force must be (fx, fy) or (fx, fy, fz) [N], got {self.force!r}")
        force = tuple(_finite(f"force[{c}]", f) for c, f in enumerate(self.force))
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "end", end)
        object.__setattr__(self, "force", force)

    @classmethod
    def from_polar(
        cls, magnitude: float, direction_deg: float, onset: float, duration: float
    ) -> TipForceEvent:
        """Event of ``magnitude`` [N] pointing at ``direction_deg`` [deg] from +x toward +y (global),
        switched on at ``onset`` [s] for ``duration`` [s]."""
        magnitude = _finite("magnitude", magnitude)
        if magnitude < 0.0:
            raise ValueError(f"magnitude must be >= 0 N, got {magnitude!r}")
        phi = math.radians(_finite("direction_deg", direction_deg))
        duration = float(duration)
        if not duration > 0.0:
            raise ValueError(f"duration must be > 0 s, got {duration!r}")
        return cls(onset, onset + duration, (magnitude * math.cos(phi), magnitude * math.sin(phi)))

    @classmethod
    def from_spherical(
        cls, magnitude: float, azimuth_deg: float, elevation_deg: float, onset: float, duration: float
    ) -> TipForceEvent:
        """3-D event of ``magnitude`` [N] at ``azimuth_deg`` from +x toward +y and ``elevation_deg``
        above the x-y plane (global frame of SPATIAL.md §1, z up), on at ``onset`` for ``duration`` [s]."""
        magnitude = _finite("magnitude", magnitude)
        if magnitude < 0.0:
            raise ValueError(f"magnitude must be >= 0 N, got {magnitude!r}")
        az = math.radians(_finite("azimuth_deg", azimuth_deg))
        el = math.radians(_finite("elevation_deg", elevation_deg))
        duration = float(duration)
        if not duration > 0.0:
            raise ValueError(f"duration must be > 0 s, got {duration!r}")
        c = magnitude * math.cos(el)
        return cls(onset, onset + duration, (c * math.cos(az), c * math.sin(az), magnitude * math.sin(el)))

    @property
    def dim(self) -> int:
        """2 (planar) or 3 (spatial) force components."""
        return len(self.force)

    @property
    def magnitude(self) -> float:
        """``|force|`` [N]."""
        return math.hypot(*self.force)

    @property
    def direction_deg(self) -> float:
        """Direction of the force from +x toward +y [deg], in (-180, 180]."""
        return math.degrees(math.atan2(self.force[1], self.force[0]))


def _as_event(i: int, ev) -> TipForceEvent:
    if isinstance(ev, TipForceEvent):
        return ev
    if isinstance(ev, dict):
        return TipForceEvent(**ev)
    try:
        start, end, force = ev
    except (TypeError, ValueError):
        raise ValueError(
            f"tip_force_events[{i}] must be a TipForceEvent, a dict or a (start, end, (fx, fy)) tuple, "
            f"got {ev!r}"
        ) from None
    return TipForceEvent(start, end, force)


@dataclass(frozen=True)
class LoadSchedule:
    """External loads of one episode: tip-force events plus a payload on the top disk.

    Attributes:
        tip_force_events: :class:`TipForceEvent` s (or ``(start, end, force)`` tuples, converted);
            overlapping events add up.
        payload: mass hung on the top disk [kg], >= 0; its weight (0, -payload·g) (planar) or
            (0, 0, -payload·g) (spatial) acts for the whole episode, including the initial state.
        dim: force components, 2 (planar, ``SmaSpine-v0``) or 3 (``SmaSpine3D-v0``,
            ``SmaSpineChain-v0``); every event must have this many.
    """

    tip_force_events: tuple[TipForceEvent, ...] = field(default=())
    payload: float = 0.0
    dim: int = 2

    def __post_init__(self):
        events = self.tip_force_events
        if isinstance(events, TipForceEvent):
            events = (events,)
        events = tuple(_as_event(i, e) for i, e in enumerate(events))
        payload = _finite("payload", self.payload)
        if payload < 0.0:
            raise ValueError(f"payload must be >= 0 kg, got {self.payload!r}")
        if self.dim not in (2, 3) or isinstance(self.dim, bool):
            raise ValueError(f"dim must be 2 or 3 force components, got {self.dim!r}")
        for i, e in enumerate(events):
            if e.dim != self.dim:
                raise ValueError(
                    f"tip_force_events[{i}].force must have dim = {self.dim} components, got {e.force!r}"
                )
        object.__setattr__(self, "tip_force_events", events)
        object.__setattr__(self, "payload", payload)

    @classmethod
    def none(cls) -> LoadSchedule:
        """No tip force and no payload."""
        return cls()

    @classmethod
    def sample(
        cls,
        rng: np.random.Generator,
        duration: float,
        force_range: tuple[float, float] | None = (0.0, 0.5),
        count_range: tuple[int, int] = (0, 2),
        duration_range: tuple[float, float] = (1.0, 10.0),
        payload_range: tuple[float, float] | None = (0.0, 0.05),
        dim: int = 2,
    ) -> LoadSchedule:
        """Draw a schedule for an episode of ``duration`` seconds.

        The number of tip-force events is uniform in ``count_range`` (inclusive); each has a
        magnitude ~ U(force_range) [N], a direction ~ U(0°, 360°) in the global frame (``dim`` = 3:
        uniform on the sphere, azimuth ~ U(0°, 360°) then sin(elevation) ~ U(−1, 1)), an onset
        ~ U(0, duration) [s] and a length ~ U(duration_range) [s]. The payload is ~ U(payload_range)
        [kg]. ``None`` switches a load type off (no draws are made for it).
        """
        duration = _finite("duration", duration)
        events = []
        if force_range is not None:
            f_lo, f_hi = _range("force_range", force_range, 0.0, math.inf)
            c_lo, c_hi = (int(c) for c in _range("count_range", count_range, 0, 1000))
            d_lo, d_hi = _range("duration_range", duration_range, 1e-9, math.inf)
            for _ in range(int(rng.integers(c_lo, c_hi + 1))):
                mag = rng.uniform(f_lo, f_hi)
                direction = rng.uniform(0.0, 360.0)
                if dim == 3:
                    elevation = math.degrees(math.asin(rng.uniform(-1.0, 1.0)))
                onset = rng.uniform(0.0, duration)
                length = rng.uniform(d_lo, d_hi)
                if dim == 3:
                    events.append(TipForceEvent.from_spherical(mag, direction, elevation, onset, length))
                else:
                    events.append(TipForceEvent.from_polar(mag, direction, onset, length))
        payload = 0.0
        if payload_range is not None:
            p_lo, p_hi = _range("payload_range", payload_range, 0.0, math.inf)
            payload = float(rng.uniform(p_lo, p_hi))
        return cls(tuple(events), payload, dim)

    def tip_force(self, t) -> np.ndarray:
        """Sum of the tip-force events active at time(s) ``t`` [s]: (dim,) or (len(t), dim) [N]."""
        tt = np.asarray(t, dtype=np.float64)
        out = np.zeros((*tt.shape, self.dim))
        for ev in self.tip_force_events:
            on = (tt >= ev.start) & (tt < ev.end)
            out[on] += ev.force
        return out

    def payload_force(self, g: float = STANDARD_GRAVITY) -> np.ndarray:
        """Weight of the payload [N]: (0, -payload·g), or (0, 0, -payload·g) if ``dim`` = 3."""
        out = np.zeros(self.dim)
        out[-1] = -self.payload * g
        return out

    def total_force(self, t, g: float = STANDARD_GRAVITY) -> np.ndarray:
        """Tip force plus payload weight at time(s) ``t``: (dim,) or (len(t), dim) [N]."""
        return self.tip_force(t) + self.payload_force(g)
