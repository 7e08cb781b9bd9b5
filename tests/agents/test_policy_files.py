"""A saved policy's trained env, from its meta.json or, without one, from the spaces in its model file."""

import shutil

import pytest
from repo import ROOT

from spine_gym.agents.policy_files import check_policy_env, policy_files, trained_env_id

POLICIES = ROOT / "spine_gym" / "agents" / "policies"
V0_POLICY = POLICIES / "ppo"  # trained on SmaSpine-v0


def test_the_recorded_env_and_the_model_file():
    assert trained_env_id(V0_POLICY) == "SmaSpine-v0"
    assert policy_files(V0_POLICY) == (V0_POLICY, V0_POLICY / "model.zip")
    check_policy_env(V0_POLICY, "SmaSpine-v0", "--models ppo")
    with pytest.raises(ValueError, match="was trained on SmaSpine-v0, not on SmaSpine-v1"):
        check_policy_env(V0_POLICY, "SmaSpine-v1", "--models ppo")


def test_a_tier_with_the_same_spaces_is_accepted():
    spatial = next(p for p in sorted(POLICIES.iterdir()) if trained_env_id(p) == "SmaSpine3D-v1")
    check_policy_env(spatial, "SmaSpine3DHard-v1", "--models x")


def test_a_model_without_meta_is_checked_by_its_spaces(tmp_path):
    shutil.copy(V0_POLICY / "model.zip", tmp_path / "m.zip")
    check_policy_env(tmp_path / "m.zip", "SmaSpine-v0", "-i")
    with pytest.raises(ValueError, match=r"observation \(10,\).*SmaSpine-v1 has observation \(12,\)"):
        check_policy_env(tmp_path / "m.zip", "SmaSpine-v1", "-i")
