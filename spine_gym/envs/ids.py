"""Every registered env id: its class, its version, its difficulty tier and the settings that make it.

One family per spine (``SmaSpine``: the planar pair, ``SmaSpine3D``: one four-wire module,
``SmaSpineChain``: chained modules), each under the same versions and tiers:

* ``-v0`` — the first release: the observation has no tracking-error entries and a step's reward is
  −|e| / 10° (planar, 3-D) or −|e| / 20 mm (chain) minus 0.5 × the normalised energy: returns of
  several hundred over a 600-step episode.
* ``-v1`` — the learnable defaults: the observation ends with the measured tracking error (target −
  reading) and the preview error (preview − reading), and the reward is the ``-v0`` reward ÷ 10
  (``error_scale`` 100° / 200 mm, ``energy_weight`` 0.05): the same optimum, returns of order 1–10.
  ``<Family>-v1`` keeps ``-v0``'s task distribution (loads, targets); two tiers change it:

  * ``<Family>Easy-v1`` — the nominal plant without loads, noise or delay; targets within ±30°
    (planar), 30° (3-D), 15° per module (chain);
  * ``<Family>Hard-v1`` — a payload, one to three tip pushes, the randomised plant
    (:func:`.config.default_randomization`), sensor noise and a one-period sensor delay.

* ``-v2`` — ``-v1`` (each tier the same task) on a plant whose wire driver has a thermal cut-off:
  a wire at or above ``thermal_cutoff`` = ``temperature_limit`` − :data:`CUTOFF_MARGIN_K` (418 K)
  gets 0 V for that control period, whatever the controller asked for. The protection is part of
  the plant, as a driver board's firmware would be, so every controller and every policy meets the
  same one, in training and in evaluation; the controllers bring no guard of their own on it. The
  ceiling stays 5 V (``docs/envelope.md`` gives the reasoning).

Everything an id sets is a keyword argument of its class, passed by the registration
(``gym.make(id)`` needs none; any of them can still be overridden). :data:`ENV_SPECS` is the one
table of them; :func:`base_id` maps any id to its family's ``-v0`` id (controllers, tuned gains and
evaluation suites are per family); :data:`BENCHMARK_IDS` are the ids of the benchmark table.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "EnvSpec",
    "ENV_SPECS",
    "FAMILIES",
    "TIERS",
    "BENCHMARK_IDS",
    "CUTOFF_MARGIN_K",
    "TEMPERATURE_LIMIT_K",
    "base_id",
    "family_of",
    "tier_of",
    "markdown_table",
]

FAMILIES = ("SmaSpine", "SmaSpine3D", "SmaSpineChain")
TIERS = ("easy", "default", "hard")
_ENTRY = {
    "SmaSpine": ("planar_env:SmaSpineEnv", "planar_env:SmaSpineVectorEnv"),
    "SmaSpine3D": ("spatial_env:SmaSpine3DEnv", "spatial_env:SmaSpine3DVectorEnv"),
    "SmaSpineChain": ("spatial_env:SmaSpineChainEnv", "spatial_env:SmaSpineChainVectorEnv"),
}
_TRACKS = {
    "SmaSpine": "bending angle θ [deg]",
    "SmaSpine3D": "tip bending vector (2) [deg]",
    "SmaSpineChain": "tip position (3) [mm]",
}
_ERROR_SCALE_V0 = {"SmaSpine": 10.0, "SmaSpine3D": 10.0, "SmaSpineChain": 20.0}
V1_REWARD_DIVISOR = 10.0  # -v1 reward = -v0 reward / 10
TEMPERATURE_LIMIT_K = 423.0  # the envs' default temperature_limit (150 °C)
CUTOFF_MARGIN_K = 5.0  # -v2: the driver cuts a wire at temperature_limit - margin


def _v2(family: str) -> dict[str, Any]:
    """The settings every ``-v2`` id of ``family`` shares: ``-v1``'s and the driver's cut-off."""
    return {**_v1(family), "thermal_cutoff": TEMPERATURE_LIMIT_K - CUTOFF_MARGIN_K}


def _v1(family: str) -> dict[str, Any]:
    """The settings every ``-v1`` id of ``family`` shares (observed errors, the reward ÷ 10)."""
    return {
        "observe_errors": True,
        "error_scale": _ERROR_SCALE_V0[family] * V1_REWARD_DIVISOR,
        "energy_weight": 0.5 / V1_REWARD_DIVISOR,
    }


_EASY_TASK = {
    "SmaSpine": {"target_range": (-30.0, 30.0)},
    "SmaSpine3D": {"target_range": (0.0, 30.0)},
    "SmaSpineChain": {"module_bend_limit": 15.0},
}
_HARD_NOISE = {"angle": 0.5, "temperature": 1.0, "resistance": 0.01}
_HARD_PAYLOAD = {"SmaSpine": (0.0, 0.09), "SmaSpine3D": (0.0, 0.09), "SmaSpineChain": (0.0, 0.05)}


def _tier(family: str, tier: str) -> dict[str, Any]:
    """What a tier changes of ``family``'s ``-v1`` task distribution."""
    if tier == "easy":
        return {"payload_range": None, "tip_force_range": None, **_EASY_TASK[family]}
    if tier == "hard":
        noise = {**_HARD_NOISE, "position": 1.0} if family == "SmaSpineChain" else dict(_HARD_NOISE)
        return {
            "payload_range": _HARD_PAYLOAD[family],
            "tip_force_range": (0.3, 1.0),
            "tip_force_count": (1, 3),
            "domain_randomization": True,
            "sensor_noise": noise,
            "sensor_delay": 1,
        }
    return {}


@dataclass(frozen=True)
class EnvSpec:
    """One registered id: its family, version, tier and the keyword arguments its registration passes."""

    id: str
    family: str
    version: int
    tier: str
    kwargs: dict[str, Any] = field(default_factory=dict)

    @property
    def entry_point(self) -> str:
        return f"spine_gym.envs.{_ENTRY[self.family][0]}"

    @property
    def vector_entry_point(self) -> str:
        return f"spine_gym.envs.{_ENTRY[self.family][1]}"


def _specs() -> dict[str, EnvSpec]:
    out = {}
    for fam in FAMILIES:
        out[f"{fam}-v0"] = EnvSpec(f"{fam}-v0", fam, 0, "default")
        for tier in TIERS:
            name = fam if tier == "default" else f"{fam}{tier.capitalize()}"
            out[f"{name}-v1"] = EnvSpec(f"{name}-v1", fam, 1, tier, {**_v1(fam), **_tier(fam, tier)})
        for tier in TIERS:
            name = fam if tier == "default" else f"{fam}{tier.capitalize()}"
            out[f"{name}-v2"] = EnvSpec(f"{name}-v2", fam, 2, tier, {**_v2(fam), **_tier(fam, tier)})
    return out


ENV_SPECS: dict[str, EnvSpec] = _specs()
BENCHMARK_IDS = tuple(s.id for s in ENV_SPECS.values() if s.version == 1 and s.tier != "default")


def _spec(env_id: str) -> EnvSpec:
    if env_id not in ENV_SPECS:
        raise ValueError(f"unknown spine_gym env id {env_id!r}; registered: {sorted(ENV_SPECS)}")
    return ENV_SPECS[env_id]


def family_of(env_id: str) -> str:
    """The family of a registered id (``"SmaSpine"``, ``"SmaSpine3D"``, ``"SmaSpineChain"``)."""
    return _spec(env_id).family


def base_id(env_id: str) -> str:
    """The ``-v0`` id of ``env_id``'s family: controllers, tuned gains and suites are per family."""
    return f"{family_of(env_id)}-v0"


def tier_of(env_id: str) -> str:
    """``"easy"``, ``"default"`` or ``"hard"``."""
    return _spec(env_id).tier


def markdown_table() -> str:
    """Every id: family, version, tier, what it tracks and what its registration sets (Markdown)."""
    lines = ["| id | tracks | version | tier | settings (keyword arguments) |", "|---|---|---|---|---|"]
    for s in ENV_SPECS.values():
        kw = ", ".join(f"``{k}={v!r}``" for k, v in s.kwargs.items()) or "the class defaults"
        lines.append(f"| ``{s.id}`` | {_TRACKS[s.family]} | v{s.version} | {s.tier} | {kw} |")
    return "\n".join(lines)
