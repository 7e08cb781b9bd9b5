"""The shipped policies of the -v2 ids (one per family, trained under the PID's energy budget): small,
documented, reproducible from their command, chosen on validation episodes, and in their own env
better than random actions without a wire over the temperature limit."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from random_policy import RandomPolicy

from spine_gym.agents import evaluate as ev
from spine_gym.agents.runtime import env_temperature_limit, load_policy, make_env, run_episode
from spine_gym.agents.scenarios import get_suite
from spine_gym.agents.training import resolve_config
from spine_gym.agents.zoo_config import CHAIN_ENV_ID, ENV_ID, ENV_IDS, POLICIES_DIR, SPATIAL_ENV_ID
from spine_gym.envs import base_id

#: the id each family's -v2 policy is shipped for
V2_FAMILY_IDS = ("SmaSpineHard-v2", "SmaSpine3D-v2", "SmaSpineChain-v2")
SHIPPED_V2 = [(env_id, name) for env_id in V2_FAMILY_IDS for name in sorted(ev.shipped_policies(env_id))]
# a 60-s scenario of each family's suite with loads: a reversal, a tour of the bending directions, steps
SCENARIO = {ENV_ID: "step_cross_dist", SPATIAL_ENV_ID: "step_tour_dist", CHAIN_ENV_ID: "steps_dist"}
STUDIES = POLICIES_DIR.parents[2] / "docs" / "studies"


def test_each_family_has_one_v2_policy_shipped_small_and_documented():
    assert sorted(e for e, _ in SHIPPED_V2) == sorted(V2_FAMILY_IDS), "one shipped policy per family's -v2 id"
    commands = (POLICIES_DIR / "COMMANDS.md").read_text()
    for env_id, name in SHIPPED_V2:
        study = STUDIES / name  # its selection: the page, the rule, every candidate's scores, the figure
        with open(study / "scores.csv", newline="") as f:
            scored = {row["model"] for row in csv.DictReader(f)}
        assert (study / "selection_rule.txt").exists() and (study / "selection.png").exists()
        folder = POLICIES_DIR / name
        assert sum(f.stat().st_size for f in folder.iterdir()) < 2_000_000
        meta = json.loads((folder / "meta.json").read_text())
        assert meta["command"].startswith("python -m spine_gym.agents.train")
        assert f"--env {env_id}" in meta["command"]
        # trained under the energy budget: the tuned PID's energy, scaled by at most 1
        assert "energy_budget:pid" in meta["command"] and meta["energy_budget_J"] > 0.0
        assert 0.0 < float(meta["budget_scale"]) <= 1.0
        assert meta["train_cpu_time_s"] > 0.0 and meta["origin"] in ("from scratch", "fine-tuned")
        assert f"`{name}`" in commands and f"`{name}`" in (study / "README.md").read_text()
        assert (folder / "vecnormalize.pkl").exists()
        assert meta["selected_as"] in scored, "the shipped model is one of the scored candidates"


@pytest.mark.parametrize("env_id, name", SHIPPED_V2)
def test_shipped_v2_policy_tracks_better_than_random_and_keeps_its_wires_under_the_limit(env_id, name):
    scenario = get_suite("full", names=[SCENARIO[base_id(env_id)]], env_id=env_id)[0]
    pol = load_policy(POLICIES_DIR / name)
    kw = ev.evaluation_env_kwargs(pol.env_kwargs)
    env = make_env({**kw, "episode_duration": scenario.duration}, env_id=env_id)
    assert "v_max" not in pol.env_kwargs, "the -v2 policies keep the env's own voltage ceiling"

    def run(p):
        return run_episode(env, p, scenario)

    ours = run(pol)
    rmse = np.sqrt(np.mean(ours.error**2))
    assert rmse < 0.5 * np.sqrt(np.mean(run(RandomPolicy(env.action_space.shape[0])).error ** 2))
    # the plant's cut-off (418 K) holds every wire under the 423-K limit, whatever the policy asks
    assert ours.temperature.max() < env_temperature_limit(env)
    env.close()


@pytest.mark.parametrize("env_id", [e for e in ENV_IDS if e.endswith("-v2")])
def test_the_v2_entries_train_under_the_pids_energy_budget(env_id):
    # the constrained entry of the benchmark: stock PPO on a -v2 id meets the tuned PID's energy
    cfg = resolve_config("ppo", env_id)
    assert cfg.special["energy_budget"] == "pid" and 0.0 < float(cfg.special["budget_scale"]) <= 1.0
    assert cfg.special["obs_integral"] == 10.0 and cfg.special["env_kwargs"] == {"target_preview": 3.0}
