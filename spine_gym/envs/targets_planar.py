"""The targets of ``SmaSpine-v0``: target-angle profiles θ*(t) [deg].

A :class:`TargetProfile` is a frozen dataclass that can be written by hand (to pin an episode
through ``env.reset(options={"target": ...})``) or drawn from a seeded
:class:`numpy.random.Generator` by :meth:`TargetProfile.sample` (what the environment does at
every reset when no option pins it). Nothing here knows about the physics: a profile is a
function of time in degrees, positive toward the right wire (the model's sign, MODEL.md §4.3).
The spatial envs' targets are in :mod:`.targets_spatial`, the loads of every env in :mod:`.loads`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["TargetProfile", "TARGET_KINDS", "ANGLE_LIMIT"]

TARGET_KINDS = ("steps", "ramp", "sine")
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
