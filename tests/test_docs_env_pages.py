"""The env pages of the documentation site describe the env that ``gymnasium.make(id)`` returns.

The pages are the Markdown that ``docs/_ext/spine_docs.py`` writes at build time (docs/envs/<id>.md);
here each page's observation table is parsed back and compared with
``gymnasium.make(id).observation_space`` (shape, per-entry names and bounds), its reward
coefficients and settings with ``env.unwrapped.config``, and no reST role is left as literal text.
"""

from __future__ import annotations

import re
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import spine_gym  # noqa: F401  (registers the ids)
from spine_gym.envs.ids import ENV_SPECS

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "_ext"))
import env_pages  # noqa: E402
import spine_docs  # noqa: E402

IDS = list(ENV_SPECS)


def _make(env_id: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gym.make(env_id)


def _section(page: str, title: str) -> str:
    """The text of the ``## title`` section of a page."""
    match = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", page, flags=re.M | re.S)
    assert match, f"no section {title!r}"
    return match.group(1)


def _table(text: str) -> list[list[str]]:
    """The body rows of the first Markdown table in ``text``, cells stripped."""
    rows = [line for line in text.splitlines() if line.startswith("|")]
    return [[c.strip() for c in r.strip("|").split("|")] for r in rows[2:]]


@pytest.fixture(scope="module")
def pages() -> dict[str, str]:
    return {i: spine_docs.env_page(ENV_SPECS[i]) for i in IDS}


@pytest.mark.parametrize("env_id", IDS)
def test_observation_table_is_the_space_of_make(pages, env_id):
    env = _make(env_id)
    space, names = env.observation_space, env.unwrapped.observation_names
    section = _section(pages[env_id], "Observation space")
    assert f"`{space}`" in section
    rows = _table(section)
    assert len(rows) == space.shape[0]
    assert [int(r[0]) for r in rows] == list(range(space.shape[0]))
    assert [r[1].strip("`") for r in rows] == list(names)
    np.testing.assert_allclose([float(r[4]) for r in rows], space.low, rtol=1e-5)
    np.testing.assert_allclose([float(r[5]) for r in rows], space.high, rtol=1e-5)
    env.close()


def test_v1_pages_show_the_v1_observation_and_reward(pages):
    """The observed errors and the reward ÷ 10 of the -v1 ids (MODEL.md: error_scale 100°)."""
    v0_sizes = {"SmaSpine": (10, "deg"), "SmaSpine3D": (20, "deg"), "SmaSpineChain": (40, "mm")}
    for family, (n0, unit) in v0_sizes.items():
        v0, v1 = ENV_SPECS[f"{family}-v0"], ENV_SPECS[f"{family}-v1"]
        assert len(_table(_section(pages[v0.id], "Observation space"))) == n0
        v1_rows = _table(_section(pages[v1.id], "Observation space"))
        assert len(v1_rows) == n0 + 2 * (3 if family == "SmaSpineChain" else 1 if family == "SmaSpine" else 2)
        coefficients = dict(r[:2] for r in _table(_section(pages[v1.id], "Reward coefficients")))
        assert coefficients["`error_scale`"].startswith(f"{v1.kwargs['error_scale']:g} {unit}")
        assert coefficients["`energy_weight`"] == f"{v1.kwargs['energy_weight']:g}"


@pytest.mark.parametrize("env_id", IDS)
def test_reward_and_settings_are_the_config_of_make(pages, env_id):
    env = _make(env_id)
    cfg = env.unwrapped.config
    coefficients = dict(r[:2] for r in _table(_section(pages[env_id], "Reward coefficients")))
    assert coefficients["`error_scale`"].split()[0] == f"{cfg.error_scale:g}"
    assert coefficients["`energy_weight`"] == f"{cfg.energy_weight:g}"
    assert coefficients["`cost_weight`"] == f"{cfg.cost_weight:g} 1/K"
    settings = dict(r[:2] for r in _table(_section(pages[env_id], "Task and plant settings")))
    delay_key = "**`sensor_delay`**" if "sensor_delay" in ENV_SPECS[env_id].kwargs else "`sensor_delay`"
    assert settings[delay_key].startswith(str(cfg.sensor_delay))
    for key in ENV_SPECS[env_id].kwargs:  # every setting of the registration is marked as such
        assert f"**`{key}`**" in settings or f"`{key}`" in coefficients
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_no_literal_rest_roles(pages, env_id):
    assert not env_pages.ROLE.search(pages[env_id]), env_pages.ROLE.search(pages[env_id]).group(0)
    assert "{meth}`" in pages[env_id] or "{class}`" in pages[env_id]  # the docstring's roles, converted


def test_myst_roles_converts_each_role():
    text = ":meth:`a.b`, :py:class:`~c.D` and :func:`.e`"
    assert env_pages.myst_roles(text) == "{meth}`a.b`, {class}`~c.D` and {func}`.e`"


def test_v2_pages_show_the_drivers_cutoff(pages):
    """A ``-v2`` page lists ``thermal_cutoff`` as a registered setting with its value in K and says
    in its action section what the driver does; a ``-v1`` page shows the cut-off off."""
    for env_id, spec in ENV_SPECS.items():
        settings = dict(r[:2] for r in _table(_section(pages[env_id], "Task and plant settings")))
        action = _section(pages[env_id], "Action space")
        if spec.version == 2:
            assert settings["**`thermal_cutoff`**"] == f"{spec.kwargs['thermal_cutoff']:g} K"
            assert f"`thermal_cutoff` = {spec.kwargs['thermal_cutoff']:g} K" in action and "0 V" in action
        else:
            assert settings["`thermal_cutoff`"] == "off"
            assert "no thermal cut-off" in action


@pytest.mark.parametrize("env_id", IDS)
def test_the_action_section_states_the_volts_the_env_applies(pages, env_id):
    """Action +1 from a cold start: the volts ``info["voltage"]`` reports are those the page states
    (a chain's shorter wires get the seed's voltage × their length / L0, half of ``v_max`` here)."""
    env = _make(env_id)
    env.reset(seed=0)
    volts = np.ravel(env.step(np.ones(env.action_space.shape, np.float32))[4]["voltage"])
    env.close()
    action = _section(pages[env_id], "Action space")
    assert np.allclose(volts, volts[0]) and f"action +1 puts {volts[0]:g} V on every wire" in action
    v_max = env.unwrapped.config.v_max
    assert ("· `v_max` · s" in action) == (not np.isclose(volts[0], v_max))


def test_the_drive_formula_lists_unequal_wires():
    from types import SimpleNamespace

    cfg = SimpleNamespace(v_max=5.0, volt_coef=np.array([1.5, 1.5, 1.0, 1.0]))
    text = env_pages.drive_formula(cfg, 4)
    assert "s = (0.6, 0.6, 0.4, 0.4) here" in text and "puts (3, 3, 2, 2) V on the wires" in text
