"""The fixed, named, seeded scenario suite on which controllers are compared.

A :class:`Scenario` is pure data (target profile, load schedule, duration, reset seed); its
:meth:`Scenario.reset_options` turns it into the env's ``reset(options={"target": ...,
"loads": ...})`` objects (:mod:`spine_gym.envs.targets_planar`, :mod:`spine_gym.envs.loads`). The suite has
two groups with the same target profiles:

* ``nominal`` — no external load;
* ``disturbed`` — a payload on the top disk (gravity load) and horizontal tip-force pulses that
  push the spine off its target;
* ``hard`` — what ``disturbed`` only hints at: a payload of 50-90 g, three tip pushes of
  0.3-1 N that alternate sides and tilt up to ±20° from the horizontal, and a parameter-randomised
  plant (convection, tube modulus, ambient
  temperature and resistivities drawn from the env's ``default_randomization`` ranges), which the
  controllers do not know.

Target profiles (all within ±40°, inside the ±45° the env samples for training and well inside
the ±63° the wires can reach) start at 0° like the spine: a hold then a step, a step sequence
crossing zero, a staircase, ramps and sinusoids (periods 20-30 s). The disturbances are fixed
numbers drawn once from ``numpy.random.default_rng(EVAL_SEED_BASE + k)`` here, so the suite does
not move when the env's samplers change. Reset seeds are ``EVAL_SEED_BASE + k`` — disjoint from
the training and tuning seeds (< ``EVAL_SEED_BASE``).

``full`` is the suite of the README (60-s episodes, all three groups); ``quick`` is a 3-profile,
20-s cut of the nominal and disturbed groups for
tests and the notebook.

The spatial envs have their own suites (:data:`SUITES_BY_ENV`, :func:`get_suite` with ``env_id``),
with ``nominal`` and ``disturbed`` groups (payload plus 3-D tip pushes tilted up to ±20° from the
horizontal, in any azimuth):

* ``SmaSpine3D-v0`` — target bending vectors (:class:`spine_gym.envs.targets_spatial.BendTarget`): a
  diagonal step, a tour of three steps around the azimuth, a 40° hold, a circle and a
  figure-eight of the tip direction;
* ``SmaSpineChain-v0`` — target tip positions (:class:`spine_gym.envs.targets_spatial.ChainTarget`,
  every module an arc within the env's 20° per-module bend limit, so inside its documented
  workspace): a hold, a step sequence, a circle and a figure-eight.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from spine_gym import ModelParams
from spine_gym.envs import ENV_SPECS, base_id, default_randomization
from spine_gym.envs.loads import LoadSchedule
from spine_gym.envs.targets_planar import TargetProfile
from spine_gym.envs.targets_spatial import BendTarget, ChainTarget

from .zoo_config import CHAIN_ENV_ID, ENV_ID, SPATIAL_ENV_ID

EVAL_SEED_BASE = 900_000  # evaluation reset seeds: EVAL_SEED_BASE + k; training/tuning seeds stay below
G = 9.81  # [m/s^2]


@dataclass(frozen=True)
class Scenario:
    """One evaluation episode.

    Attributes:
        name: unique name (``<profile>`` + ``_dist`` in the disturbed group).
        group: ``"nominal"`` or ``"disturbed"``.
        kind: ``"step"``, ``"ramp"`` or ``"sine"`` (settling time is reported for steps).
        target: ``(constructor, kwargs)`` of the env's target class (:data:`TARGET_CLASSES`:
            :class:`~spine_gym.envs.targets_planar.TargetProfile` for ``SmaSpine-v0``); constructor ``""``
            calls the class itself.
        payload_kg: mass hung on the top disk [kg] (a constant downward tip force m g).
        tip_pulses: ``(t_start [s], t_end [s], fx [N], fy [N])`` tip-force pulses (global x/y), or
            ``(t_start, t_end, fx, fy, fz)`` for the spatial envs (global x/y/z, z up).
        params: ``(ModelParams field, value)`` pairs of a randomised plant (empty: nominal).
        duration: episode duration [s].
        seed: env reset seed.
        env_id: the env the scenario is for.
    """

    name: str
    group: str
    kind: str
    target: tuple[str, dict]
    payload_kg: float = 0.0
    tip_pulses: tuple[tuple[float, ...], ...] = field(default_factory=tuple)
    params: tuple[tuple[str, float], ...] = field(default_factory=tuple)
    duration: float = 60.0
    seed: int = EVAL_SEED_BASE
    env_id: str = ENV_ID

    def reset_options(self) -> dict:
        """The env's ``reset`` options: ``{"target": <target>, "loads": LoadSchedule}`` and, for
        a randomised plant, ``"params"``: the baseline ModelParams with :attr:`params` replaced."""
        ctor, kwargs = self.target
        cls = TARGET_CLASSES[base_id(self.env_id)]
        target = getattr(cls, ctor)(**kwargs) if ctor else cls(**kwargs)
        loads = LoadSchedule(
            tip_force_events=tuple((p[0], p[1], tuple(p[2:])) for p in self.tip_pulses),
            payload=self.payload_kg,
            dim=FORCE_DIM[base_id(self.env_id)],
        )
        out = {"target": target, "loads": loads}
        if self.params:
            out["params"] = ModelParams().replace(**dict(self.params))
        return out


TARGET_CLASSES = {ENV_ID: TargetProfile, SPATIAL_ENV_ID: BendTarget, CHAIN_ENV_ID: ChainTarget}
FORCE_DIM = {ENV_ID: 2, SPATIAL_ENV_ID: 3, CHAIN_ENV_ID: 3}  # tip-force components of each env


# target profiles shared by both groups: name -> (kind, constructor, kwargs); times in s, angles in deg
def _profiles(duration: float) -> dict[str, tuple[str, str, dict]]:
    """Every profile starts at 0 deg (the straight spine at rest) and moves after a short hold."""
    d = duration
    h = 5.0 * d / 60.0  # [s] initial hold at 0 deg
    q = (d - h) / 4.0
    return {
        "step_up": ("step", "step", {"times": (0.0, h), "values": (0.0, 30.0)}),
        "step_cross": ("step", "step", {"times": (0.0, h, h + 2 * q), "values": (0.0, 20.0, -15.0)}),
        "staircase": (
            "step",
            "step",
            {"times": (0.0, h, h + q, h + 2 * q, h + 3 * q), "values": (0.0, 10.0, 25.0, 40.0, 15.0)},
        ),
        "ramp_up": ("ramp", "ramp", {"times": (h, h + 2 * q), "values": (0.0, 35.0)}),
        "ramp_swing": ("ramp", "ramp", {"times": (0.0, 0.4 * d, d), "values": (0.0, 30.0, -20.0)}),
        "sine_slow": ("sine", "sine", {"amplitude": 25.0, "period": d / 2.0, "offset": 0.0}),
        "sine_fast": ("sine", "sine", {"amplitude": 15.0, "period": d / 3.0, "offset": 0.0}),
    }


def _disturbance(k: int, duration: float) -> tuple[float, tuple[tuple[float, float, float, float], ...]]:
    """Payload [kg] and two horizontal tip-force pulses for scenario k, from a fixed seed."""
    return _payload_and_pushes(k, duration, _horizontal_push)


def _horizontal_push(rng: np.random.Generator) -> tuple[float, float]:
    return float(np.round(rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 0.3), 3)), 0.0


def _payload_and_pushes(k: int, duration: float, push) -> tuple[float, tuple[tuple[float, ...], ...]]:
    """Payload [kg] and two tip pushes (``push(rng)``: the force components) for scenario seed k: one
    in 20–45 % of the episode, one in 60–85 %, each lasting 4–10 s."""
    rng = np.random.default_rng(EVAL_SEED_BASE + k)
    payload = float(np.round(rng.uniform(0.02, 0.05), 3))
    pulses = []
    for t_lo, t_hi in ((0.2, 0.45), (0.6, 0.85)):
        t0 = float(np.round(rng.uniform(t_lo, t_hi) * duration, 1))
        t1 = float(np.round(t0 + rng.uniform(4.0, 10.0), 1))
        pulses.append((t0, min(t1, duration), *push(rng)))
    return payload, tuple(pulses)


HARD_PAYLOAD_KG = (0.05, 0.09)  # [kg]; 0.15 kg would buckle the tube (see below)
HARD_PUSH_N = (0.3, 1.0)  # [N] magnitude of each tip push
HARD_TILT_DEG = 20.0  # [deg] largest tilt of a push from the horizontal (up or down)
HARD_PUSHES = 3
# the hard group's plants and loads as a *training/validation distribution* of the env's own
# samplers (env kwargs): randomised plant, payload 0-90 g, 0-3 tip forces up to 0.8 N in any
# direction (the env draws the direction globally, so the cap stays below HARD_PUSH_N's 1 N to keep
# a downward push plus the heaviest payload off the buckling load); it contains the light loads too
HARD_LIKE_KWARGS = {
    "domain_randomization": True,
    "payload_range": (0.0, HARD_PAYLOAD_KG[1]),
    "tip_force_range": (0.0, 0.8),
    "tip_force_count": (0, HARD_PUSHES),
}


def _hard(k: int, duration: float):
    """Payload, three pushes in changing directions and a randomised plant for hard scenario k.

    The pushes alternate between the two sides (the first side drawn), each tilted up to
    ``HARD_TILT_DEG`` from the horizontal. Payload and tilt are capped by the tube's buckling
    load: with payloads of 123-139 g and the softest randomised modulus (0.8 E_t) the model ended
    the episodes within 6-15 s (buckling); 90 g plus the steepest downward push stays below it.
    """
    rng = np.random.default_rng(EVAL_SEED_BASE + k)
    payload = float(np.round(rng.uniform(*HARD_PAYLOAD_KG), 3))
    pulses = []
    side = rng.choice([-1.0, 1.0])
    for j in range(HARD_PUSHES):
        t0 = float(np.round(rng.uniform(0.1 + 0.3 * j, 0.3 + 0.3 * j) * duration, 1))
        t1 = float(np.round(t0 + rng.uniform(3.0, 8.0), 1))
        tilt = np.radians(rng.uniform(-HARD_TILT_DEG, HARD_TILT_DEG))
        mag = rng.uniform(*HARD_PUSH_N)
        fx, fy = (float(np.round(f, 3)) for f in (side * mag * np.cos(tilt), mag * np.sin(tilt)))
        pulses.append((t0, min(t1, duration), fx, fy))
        side = -side
    params = tuple(
        (name, float(rng.uniform(lo, hi))) for name, (lo, hi) in sorted(default_randomization().items())
    )
    return payload, tuple(pulses), params


GROUP_OFFSET = {"nominal": 0, "disturbed": 100, "hard": 200}  # scenario k of a group: seed base + offset + k
SUFFIX = {"nominal": "", "disturbed": "_dist", "hard": "_hard"}


def build_suite(
    duration: float = 60.0, profiles: list[str] | None = None, groups: tuple[str, ...] = tuple(GROUP_OFFSET)
) -> list[Scenario]:
    """The scenarios of ``groups`` (default: nominal, disturbed, hard) for ``duration``-s episodes."""
    return _suite(_profiles(duration), duration, profiles, groups, _planar_loads)


def _planar_loads(group: str, k: int, duration: float):
    """Payload, tip pulses and plant parameters of scenario seed k of a planar group."""
    if group == "disturbed":
        return (*_disturbance(k, duration), ())
    if group == "hard":
        return _hard(k, duration)
    return 0.0, (), ()


def _suite(table: dict, duration: float, profiles, groups, loads, env_id: str = ENV_ID, seed_offset: int = 0):
    """The scenarios of ``groups`` x ``profiles`` (default: all of ``table``); ``loads(group, k,
    duration)`` gives the payload, tip pulses and plant parameters of scenario seed k."""
    out = []
    for group in groups:
        for i, name in enumerate(profiles or list(table)):
            kind, ctor, kwargs = table[name]
            k = i + GROUP_OFFSET[group] + seed_offset
            payload, pulses, params = loads(group, k, duration)
            out.append(
                Scenario(
                    name=name + SUFFIX[group],
                    group=group,
                    kind=kind,
                    target=(ctor, kwargs),
                    payload_kg=payload,
                    tip_pulses=pulses,
                    params=params,
                    duration=duration,
                    seed=EVAL_SEED_BASE + k,
                    env_id=env_id,
                )
            )
    return out


SUITES = {
    "full": lambda: build_suite(60.0),
    "quick": lambda: build_suite(
        20.0, ["step_cross", "ramp_swing", "sine_fast"], groups=("nominal", "disturbed")
    ),
}


# ---------------------------------------------------------------- spatial envs
def _polar(theta: float, azimuth: float) -> tuple[float, float]:
    r = np.radians(azimuth)
    return float(np.round(theta * np.cos(r), 6)), float(np.round(theta * np.sin(r), 6))


def _profiles_3d(duration: float) -> dict[str, tuple[str, str, dict]]:
    """Target bending vectors [deg] of ``SmaSpine3D-v0``: (kind, BendTarget constructor, kwargs)."""
    d = duration
    h = 5.0 * d / 60.0
    q = (d - h) / 3.0
    zero = (0.0, 0.0)
    return {
        "step_diag": ("step", "", {"kind": "steps", "times": (0.0, h), "values": (zero, _polar(30.0, 45.0))}),
        "step_tour": (
            "step",
            "",
            {
                "kind": "steps",
                "times": (0.0, h, h + q, h + 2 * q),
                "values": (zero, _polar(25.0, 0.0), _polar(35.0, 120.0), _polar(20.0, 240.0)),
            },
        ),  # fmt: skip
        "hold_40": ("step", "", {"kind": "steps", "times": (0.0, h), "values": (zero, _polar(40.0, 200.0))}),
        "circle": ("circle", "", {"kind": "circle", "amplitude": 25.0, "period": d / 2.0}),
        "figure8": (
            "figure8",
            "",
            {"kind": "figure8", "amplitude": 30.0, "period": d / 2.0, "rotation_deg": 30.0},
        ),
    }


def _profiles_chain(duration: float) -> dict[str, tuple[str, str, dict]]:
    """Target tip positions of ``SmaSpineChain-v0`` as module arcs [deg] (ChainTarget kwargs)."""
    d = duration
    h = 5.0 * d / 60.0
    q = (d - h) / 2.0
    zero = (0.0, 0.0)
    times = (0.0, h, h + q)

    def steps(*values):
        return BendTarget("steps", times, values)

    def pattern(kind, amplitude, **kw):
        return BendTarget(kind, amplitude=amplitude, period=d / 2.0, **kw)

    return {
        "hold": (
            "step",
            "",
            {"modules": (steps(zero, (15.0, 5.0), (15.0, 5.0)), steps(zero, (10.0, 0.0), (10.0, 0.0)))},
        ),
        "steps": (
            "step",
            "",
            {"modules": (steps(zero, (15.0, 0.0), (-5.0, 12.0)), steps(zero, (10.0, 5.0), (-10.0, 8.0)))},
        ),  # fmt: skip
        "circle": ("circle", "", {"modules": (pattern("circle", 15.0), pattern("circle", 10.0))}),
        "figure8": (
            "figure8",
            "",
            {
                "modules": (
                    pattern("figure8", 15.0, rotation_deg=60.0),
                    pattern("figure8", 10.0, rotation_deg=60.0),
                )
            },
        ),  # fmt: skip
    }


SPATIAL_SEED_OFFSET = {SPATIAL_ENV_ID: 10_000, CHAIN_ENV_ID: 20_000}  # reset seeds stay >= EVAL_SEED_BASE


def _disturbance_3d(k: int, duration: float):
    """Payload [kg] and two 3-D tip pushes (any azimuth, tilted ±20°) for scenario seed k."""
    return _payload_and_pushes(k, duration, _tilted_push)


def _tilted_push(rng: np.random.Generator) -> tuple[float, float, float]:
    mag, az = rng.uniform(0.1, 0.3), rng.uniform(0.0, 2.0 * np.pi)
    el = np.radians(rng.uniform(-HARD_TILT_DEG, HARD_TILT_DEG))
    f = mag * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    return tuple(float(np.round(c, 3)) for c in f)


def build_spatial_suite(
    env_id: str, duration: float = 60.0, profiles: list[str] | None = None, groups=("nominal", "disturbed")
) -> list[Scenario]:
    """The scenarios of a spatial env (``SmaSpine3D-v0`` or ``SmaSpineChain-v0``)."""
    table = (_profiles_3d if env_id == SPATIAL_ENV_ID else _profiles_chain)(duration)
    return _suite(table, duration, profiles, groups, _spatial_loads, env_id, SPATIAL_SEED_OFFSET[env_id])


def _spatial_loads(group: str, k: int, duration: float):
    """Payload and 3-D tip pushes of scenario seed k of a spatial group (no plant randomisation)."""
    payload, pulses = _disturbance_3d(k, duration) if group == "disturbed" else (0.0, ())
    return payload, pulses, ()


SUITES_BY_ENV = {
    ENV_ID: SUITES,
    SPATIAL_ENV_ID: {
        "full": lambda: build_spatial_suite(SPATIAL_ENV_ID, 60.0),
        "quick": lambda: build_spatial_suite(SPATIAL_ENV_ID, 20.0, ["step_diag", "circle"]),
    },
    CHAIN_ENV_ID: {
        "full": lambda: build_spatial_suite(CHAIN_ENV_ID, 60.0),
        "quick": lambda: build_spatial_suite(CHAIN_ENV_ID, 20.0, ["steps", "circle"]),
    },
}


def get_suite(
    name: str = "full", groups: list[str] | None = None, names: list[str] | None = None, env_id: str = ENV_ID
) -> list[Scenario]:
    """The scenarios of suite ``name`` of ``env_id``, optionally only some groups / scenario names.

    Every version and tier of a family shares its ``-v0`` suite (the same targets, loads and plants,
    pinned by the reset options); the scenarios run on ``env_id`` itself, so a policy meets the
    observation it was trained on (and a tier's sensor noise and delay)."""
    if env_id not in ENV_SPECS:
        raise ValueError(f"env_id must be one of {sorted(ENV_SPECS)}, got {env_id!r}")
    suites = SUITES_BY_ENV[base_id(env_id)]
    if name not in suites:
        raise ValueError(f"suite must be one of {sorted(suites)}, got {name!r}")
    suite = [replace(s, env_id=env_id) for s in suites[name]()]
    if groups:
        bad = set(groups) - {s.group for s in suite}
        if bad:
            raise ValueError(
                f"unknown group(s) {sorted(bad)}; suite {name!r} has {sorted({s.group for s in suite})}"
            )
        suite = [s for s in suite if s.group in groups]
    if names:
        bad = set(names) - {s.name for s in suite}
        if bad:
            raise ValueError(f"unknown scenario(s) {sorted(bad)}; available: {[s.name for s in suite]}")
        suite = [s for s in suite if s.name in names]
    return suite
