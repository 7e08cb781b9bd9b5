"""The residual's baseline (``spine_gym/agents/residual.py``: ``base_spec``, ``build_base``).

Spec: the baseline is the registry's controller under the registry's one guard rule
(``spine_gym.controllers.registry.controller_kwargs``): its own guard at the env's temperature limit
minus the margin, none where the plant cuts hot wires itself (the ``thermal_cutoff`` of the ``-v2``
ids). A spec saved in a model's meta is rebuilt as it was written, guard included.
"""

from __future__ import annotations

import pytest

import spine_gym  # noqa: F401 - registers the ids
from spine_gym.agents.residual import base_spec, build_base
from spine_gym.agents.runtime import controller_for
from spine_gym.controllers.registry import load_tuned
from spine_gym.envs import ENV_ID, config_of

FAMILIES = ("SmaSpine", "SmaSpine3D", "SmaSpineChain")


def _spec(env_id: str) -> dict:
    cfg = config_of(env_id)
    return base_spec(
        "pid",
        v_max=cfg.v_max,
        dt=cfg.control_period,
        temperature_limit=cfg.temperature_limit,
        scale=1.0,
        env_id=env_id,
        env_kwargs={},
        thermal_cutoff=cfg.thermal_cutoff,
    )


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("version", (0, 1, 2))
def test_the_baseline_has_the_guard_of_the_registry_controller(family, version):
    env_id = f"{family}-v{version}"
    spec = _spec(env_id)
    reference = controller_for("pid", env_id)
    assert spec["temperature_limit"] == reference.temperature_limit
    assert build_base(spec).temperature_limit == reference.temperature_limit
    assert spec["params"] == load_tuned(env_id=env_id)["pid"]


@pytest.mark.parametrize("family", FAMILIES)
def test_the_plant_cutoff_leaves_the_baseline_without_a_guard_of_its_own(family):
    assert _spec(f"{family}-v2")["temperature_limit"] is None
    cfg = config_of(f"{family}-v1")
    assert _spec(f"{family}-v1")["temperature_limit"] < cfg.temperature_limit


def test_a_saved_spec_with_a_guard_is_rebuilt_as_it_was():
    """Meta written before the rule held a guard on a ``-v2`` id too: it keeps it."""
    for env_id in ("SmaSpine-v2", "SmaSpineChain-v2"):
        saved = _spec(env_id) | {"temperature_limit": 418.0}
        assert build_base(saved).temperature_limit == 418.0
    assert build_base(_spec(ENV_ID) | {"temperature_limit": 410.0}).temperature_limit == 410.0
