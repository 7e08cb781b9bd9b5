"""The shipped policies of the -v1 ids (every family and tier): small, documented, reproducible from
their command, and each in its own env (its voltage ceiling) better than random actions."""

from __future__ import annotations

import json

import numpy as np
import pytest
from random_policy import RandomPolicy

from spine_gym.agents import evaluate as ev
from spine_gym.agents.runtime import load_policy, make_env, run_episode
from spine_gym.agents.scenarios import get_suite
from spine_gym.agents.zoo_config import CHAIN_ENV_ID, ENV_ID, ENV_IDS, POLICIES_DIR, SPATIAL_ENV_ID
from spine_gym.envs import base_id

V1_IDS = tuple(e for e in ENV_IDS if e.endswith("-v1"))
SHIPPED_V1 = [(env_id, name) for env_id in V1_IDS for name in sorted(ev.shipped_policies(env_id))]
# a 60-s scenario of each family's suite with loads: a reversal, a tour of the bending directions, steps
SCENARIO = {ENV_ID: "step_cross_dist", SPATIAL_ENV_ID: "step_tour_dist", CHAIN_ENV_ID: "steps_dist"}


def test_v1_policies_are_shipped_small_and_documented():
    families = {"SmaSpine-v1", "SmaSpine3D-v1", "SmaSpineChain-v1"}
    assert {e for e, _ in SHIPPED_V1} >= families, "a family's -v1 id without a shipped policy"
    commands = (POLICIES_DIR / "COMMANDS.md").read_text()
    for env_id, name in SHIPPED_V1:
        folder = POLICIES_DIR / name
        assert sum(f.stat().st_size for f in folder.iterdir()) < 2_000_000
        meta = json.loads((folder / "meta.json").read_text())
        assert meta["command"].startswith("python -m spine_gym.agents.train") and f"--env {env_id}" in meta["command"]
        assert f"`{name}`" in commands and (folder / "vecnormalize.pkl").exists()


@pytest.mark.parametrize("env_id, name", SHIPPED_V1)
def test_shipped_v1_policy_runs_in_its_own_env_and_beats_a_random_policy(env_id, name):
    # the policy meets the env kwargs it was trained with that the suite keeps (e.g. its v_max);
    # the random policy drives the same env
    scenario = get_suite("full", names=[SCENARIO[base_id(env_id)]], env_id=env_id)[0]
    pol = load_policy(POLICIES_DIR / name)
    kw = ev.evaluation_env_kwargs(pol.env_kwargs)
    env = make_env({**kw, "episode_duration": scenario.duration}, env_id=env_id)
    if "v_max" in pol.env_kwargs:
        assert env.v_max == pytest.approx(float(pol.env_kwargs["v_max"]))

    def rmse(p):
        return np.sqrt(np.mean(run_episode(env, p, scenario).error ** 2))

    assert rmse(pol) < 0.5 * rmse(RandomPolicy(env.action_space.shape[0]))
    env.close()
