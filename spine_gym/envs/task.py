"""The tracking task of ``SmaSpine-v0``: target-angle profiles and external-load schedules.

Both are frozen dataclasses that can be written by hand (to pin an episode through
``env.reset(options={"target": ..., "loads": ...})``) or drawn from a seeded
:class:`numpy.random.Generator` by their ``sample`` class methods (what the environment does at
every reset when no option pins them). Nothing here knows about the physics: a profile is a
function of time in degrees, a schedule a function of time in newtons.

Conventions: angles in degrees, positive toward the right wire (the model's sign, MODEL.md §4.3);
forces in newtons in the global frame (x to the right, y up; a weight is (0, -m g)).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["TargetProfile", "TipForceEvent", "LoadSchedule", "TARGET_KINDS", "STANDARD_GRAVITY"]

TARGET_KINDS = ("steps", "ramp", "sine")
STANDARD_GRAVITY = 9.81  # [m/s^2] default g of a payload weight (ModelParams.g)
ANGLE_LIMIT = 90.0  # [deg] |target| bound (the observation bound of the target entries)
_INTERPOLATIONS = ("previous", "linear")


def _finite(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def _range(name: str, value, lo: float, hi: float) -> tuple[float, float]:
    """A (low, high) pair with lo <= low <= high <= hi, or ValueError naming it."""
    try:
        a, b = value
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a (low, high) pair, got {value!r}") from None
    a = _finite(f"{name}[0]", a)
    b = _finite(f"{name}[1]", b)
    if not (lo <= a <= b <= hi):
        raise ValueError(f"{name} must satisfy {lo:g} <= low <= high <= {hi:g}, got {value!r}")
    return a, b


def _as_tuple(name: str, value) -> tuple[float, ...]:
    if np.ndim(value) == 0:
        value = (value,)
    out = tuple(_finite(f"{name}[{i}]", v) for i, v in enumerate(value))
    if not out:
        raise ValueError(f"{name} must hold at least one value")
    return out


# ====================================================================== target profiles
@dataclass(frozen=True)
class TargetProfile:
    """Target bending angle θ*(t) [deg] = base(t) + amplitude · sin(2π t / period + phase).

    ``base`` is given by knots ``(times, values)``: held piecewise constant (``interpolation=
    "previous"``, setpoint steps) or interpolated linearly (``"linear"``, ramps); before the first
    knot it equals ``values[0]`` and after the last ``values[-1]``. Build profiles with the class
    methods :meth:`constant`, :meth:`step`, :meth:`ramp`, :meth:`sine`, or draw one with
    :meth:`sample`. A profile is evaluated by calling it with a time or an array of times [s].

    Attributes:
        times: knot times [s], strictly increasing.
        values: target at each knot [deg].
        interpolation: ``"previous"`` (steps) or ``"linear"`` (ramps).
        amplitude: sine amplitude [deg], >= 0.
        period: sine period [s], > 0.
        phase: sine phase at t = 0 [rad].
        kind: a label (``"steps"``, ``"ramp"``, ``"sine"``, ``"constant"``, ``"custom"``).
    """

    times: tuple[float, ...] = (0.0,)
    values: tuple[float, ...] = (0.0,)
    interpolation: str = "previous"
    amplitude: float = 0.0
    period: float = 1.0
    phase: float = 0.0
    kind: str = "custom"

    def __post_init__(self):
        times = _as_tuple("times", self.times)
        values = _as_tuple("values", self.values)
        if len(times) != len(values):
            raise ValueError(
                f"times and values must have the same length, got {len(times)} and {len(values)}"
            )
        if any(b <= a for a, b in zip(times[:-1], times[1:], strict=True)):
            raise ValueError(f"times must be strictly increasing, got {times}")
        if self.interpolation not in _INTERPOLATIONS:
            raise ValueError(f"interpolation must be one of {_INTERPOLATIONS}, got {self.interpolation!r}")
        amplitude = _finite("amplitude", self.amplitude)
        period = _finite("period", self.period)
        if amplitude < 0.0:
            raise ValueError(f"amplitude must be >= 0 deg, got {self.amplitude!r}")
        if period <= 0.0:
            raise ValueError(f"period must be > 0 s, got {self.period!r}")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "amplitude", amplitude)
        object.__setattr__(self, "period", period)
        object.__setattr__(self, "phase", _finite("phase", self.phase))
        object.__setattr__(self, "kind", str(self.kind))
        lo, hi = self.bounds()
        if lo < -ANGLE_LIMIT or hi > ANGLE_LIMIT:
            raise ValueError(
                f"a target profile must stay within [-{ANGLE_LIMIT:g}, {ANGLE_LIMIT:g}] deg, "
                f"this one spans [{lo:g}, {hi:g}] deg"
            )

    # ------------------------------------------------------------------ constructors
    @classmethod
    def constant(cls, value: float) -> TargetProfile:
        """Hold ``value`` [deg] for the whole episode."""
        return cls(times=(0.0,), values=(value,), kind="constant")

    @classmethod
    def step(cls, times: Sequence[float] | float, values: Sequence[float] | float) -> TargetProfile:
        """Setpoint steps: ``values[k]`` [deg] from ``times[k]`` [s] on (``values[0]`` before)."""
        return cls(times=times, values=values, interpolation="previous", kind="steps")

    @classmethod
    def ramp(cls, times: Sequence[float], values: Sequence[float]) -> TargetProfile:
        """Piecewise-linear target through the knots ``(times [s], values [deg])``, held outside them."""
        return cls(times=times, values=values, interpolation="linear", kind="ramp")

    @classmethod
    def sine(cls, amplitude: float, period: float, offset: float = 0.0, phase: float = 0.0) -> TargetProfile:
        """``offset + amplitude · sin(2π t / period + phase)`` [deg]; period [s], phase [rad]."""
        return cls(
            times=(0.0,), values=(offset,), amplitude=amplitude, period=period, phase=phase, kind="sine"
        )

    @classmethod
    def sample(
        cls,
        rng: np.random.Generator,
        duration: float,
        angle_range: tuple[float, float] = (-45.0, 45.0),
        kinds: Iterable[str] = TARGET_KINDS,
        sine_period_range: tuple[float, float] = (20.0, 60.0),
    ) -> TargetProfile:
        """Draw a profile that stays in ``angle_range`` over ``[0, duration]``.

        One of ``kinds`` is chosen uniformly, then:

        * ``"steps"``: 1-3 setpoints drawn uniformly in ``angle_range``; the k-th of n starts at
          ``k·duration/n`` jittered by up to ±25 % of a hold (the first at t = 0).
        * ``"ramp"``: a hold at a level a until t0 ~ U(0, 0.3 d), then a linear ramp to a level b
          reached at t0 + U(0.2, 0.6)·d (clipped to d), held afterwards; a, b uniform in the range.
        * ``"sine"``: amplitude ~ U(0.2, 0.5)·(range width), offset uniform where the sine stays in
          range, period ~ U(sine_period_range), phase ~ U(0, 2π).

        Args:
            rng: the environment's seeded generator (all draws come from it).
            duration: episode duration [s], > 0.
            angle_range: (low, high) target bounds [deg].
            kinds: subset of ``("steps", "ramp", "sine")``.
            sine_period_range: (low, high) sine period [s].
        """
        duration = _finite("duration", duration)
        if duration <= 0.0:
            raise ValueError(f"duration must be > 0 s, got {duration!r}")
        lo, hi = _range("angle_range", angle_range, -ANGLE_LIMIT, ANGLE_LIMIT)
        p_lo, p_hi = _range("sine_period_range", sine_period_range, 1e-3, math.inf)
        kinds = tuple(kinds)
        if not kinds or any(k not in TARGET_KINDS for k in kinds):
            raise ValueError(f"kinds must be a non-empty subset of {TARGET_KINDS}, got {kinds!r}")
        kind = kinds[int(rng.integers(len(kinds)))]
        width = hi - lo
        if kind == "steps":
            n = int(rng.integers(1, 4))
            hold = duration / n
            times = [0.0] + [k * hold + rng.uniform(-0.25, 0.25) * hold for k in range(1, n)]
            values = rng.uniform(lo, hi, size=n)
            return cls.step(times, values)
        if kind == "ramp":
            a, b = rng.uniform(lo, hi, size=2)
            t0 = rng.uniform(0.0, 0.3) * duration
            t1 = min(t0 + rng.uniform(0.2, 0.6) * duration, duration)
            if t1 <= t0:  # only for a zero-width draw; keep the knots strictly increasing
                t1 = t0 + 1e-6
            return cls.ramp((t0, t1), (a, b))
        amplitude = rng.uniform(0.2, 0.5) * width
        offset = rng.uniform(lo + amplitude, hi - amplitude)
        period = rng.uniform(p_lo, p_hi)
        phase = rng.uniform(0.0, 2.0 * math.pi)
        return cls.sine(amplitude, period, offset, phase)

    # ------------------------------------------------------------------ evaluation
    def __call__(self, t):
        """θ*(t) [deg] at time(s) ``t`` [s]: a float for a scalar, an array for an array."""
        tt = np.asarray(t, dtype=np.float64)
        times = np.asarray(self.times)
        values = np.asarray(self.values)
        if self.interpolation == "linear":
            base = np.interp(tt, times, values)
        else:
            idx = np.searchsorted(times, tt, side="right") - 1
            base = values[np.clip(idx, 0, len(values) - 1)]
        out = (
            base + self.amplitude * np.sin(2.0 * np.pi * tt / self.period + self.phase)
            if self.amplitude
            else base
        )
        return float(out) if np.ndim(out) == 0 else np.asarray(out, dtype=np.float64)

    def bounds(self) -> tuple[float, float]:
        """(min, max) the profile can take over all times [deg] (knot range ± amplitude)."""
        return min(self.values) - self.amplitude, max(self.values) + self.amplitude


# ====================================================================== loads
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
