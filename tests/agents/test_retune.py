"""Per-id tuned gains: an id's own gains and the family fallback (load_tuned), the budget and
validation scores stored with them, the energy-aware objective, and the rule that a re-tune
replaces the gains in use only if better on validation episodes."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from spine_gym.agents import retune
from spine_gym.agents.retune import Budget, adopt, write_id_gains
from spine_gym.agents.runtime import VALIDATION_SEED_BASE, build_controller, make_env, run_episode
from spine_gym.agents.tuning import TRAIN_SEED_BASE, episode_score, energy_exchange_rate
from spine_gym.controllers import registry
from spine_gym.controllers.registry import DEFAULT_TUNED, TUNED_DIR, load_tuned, tuned_file, tuned_record


# --------------------------------------------------------------------------- the replacement rule
@pytest.mark.parametrize(
    ("before", "after", "adopted"),
    [
        (2.0, 1.9, True),  # better: replaces
        (2.0, 2.0, False),  # a tie keeps the gains in use
        (2.0, 2.1, False),  # worse: kept
        (2.0, math.nan, False),  # a failed re-tune never wins
        (2.0, math.inf, False),
        (math.nan, 5.0, True),  # nothing valid in use: any finite score wins
    ],
)
def test_a_retune_replaces_the_gains_only_if_better_on_validation(before, after, adopted):
    assert adopt(before, after) is adopted


def _record(adopted: bool, env_id="SmaSpineEasy-v2", name="pid", kp=1.0) -> dict:
    """A synthetic retune_one record (scores made up; the gains valid)."""
    params = {**DEFAULT_TUNED[name], "kp": kp}
    before = {"score": 5.0, "rmse": 4.0, "energy_J": 300.0, "time_over_limit_s": 0.0, "peak_temperature_K": 400.0}
    after = {**before, "score": 4.5 if adopted else 5.5}
    budget = Budget(trials=40, episodes=6, sampler_seed=0)
    return {
        "env_id": env_id,
        "controller": name,
        "params": params,
        "previous_params": dict(DEFAULT_TUNED[name]),
        "budget": {
            "trials": 40, "episodes": 6, "sampler_seed": 0, "objective": "rmse_energy",
            "validation_episodes": 20, "episode_seeds": "1000..1005", "text": budget.describe(),
        },  # fmt: skip
        "train_score": 4.0,
        "validation": {"seeds": "500000..500019", "before": before, "after": after},
        "adopted": adopt(before["score"], after["score"]),
        "tuning_wall_time_s": 1.0,
    }


# --------------------------------------------------------------------------- per-id gains, fallback
@pytest.fixture
def own_files(tmp_path, monkeypatch):
    """Ids' own gain files in ``tmp_path`` instead of the shipped folder."""
    monkeypatch.setattr(registry, "id_tuned_file", lambda env_id: tmp_path / f"{env_id}.yml")
    return tmp_path


def test_an_id_reads_its_own_gains_and_falls_back_to_its_family(own_files):
    family = load_tuned(path=tuned_file("SmaSpine-v0"), env_id="SmaSpine-v0")
    path = write_id_gains(_record(True, kp=0.777), path=own_files / "SmaSpineEasy-v2.yml")
    assert path.exists()
    own = load_tuned(env_id="SmaSpineEasy-v2")
    assert own["pid"]["kp"] == 0.777 and own["pid"] != family["pid"]
    assert own["smc"] == family["smc"] and own["bang_bang"] == family["bang_bang"]  # entries it lacks
    for other in ("SmaSpineHard-v2", "SmaSpineEasy-v1", "SmaSpine-v0"):  # ids without own gains
        assert load_tuned(env_id=other) == family
    rec = tuned_record("SmaSpineEasy-v2", "pid")
    assert rec["params"]["kp"] == 0.777 and rec["n_trials"] == 40
    assert tuned_record("SmaSpineHard-v2", "pid") == yaml.safe_load(tuned_file("SmaSpine-v0").read_text())["pid"]


def test_the_controller_built_for_an_id_uses_its_own_gains(own_files):
    write_id_gains(_record(True, kp=0.777), path=own_files / "SmaSpineEasy-v2.yml")
    env = make_env({}, env_id="SmaSpineEasy-v2")
    assert build_controller("pid", env).gains.kp == 0.777
    env.close()
    env = make_env({}, env_id="SmaSpineHard-v2")
    assert build_controller("pid", env).gains.kp == load_tuned(env_id="SmaSpine-v0")["pid"]["kp"]
    env.close()


def test_an_unknown_id_has_no_gain_file():
    with pytest.raises(ValueError, match="unknown spine_gym env id"):
        registry.id_tuned_file("SmaSpineHuge-v9")


# --------------------------------------------------------------------------- the budget recorded
def test_an_adopted_retune_stores_its_budget_and_validation_scores(tmp_path):
    path = tmp_path / "SmaSpineEasy-v2.yml"
    write_id_gains(_record(True), path=path)
    write_id_gains(_record(True, name="smc"), path=path)  # a second entry keeps the first
    data = yaml.safe_load(path.read_text())
    assert set(data) == {"pid", "smc"}
    entry = data["pid"]
    assert (entry["n_trials"], entry["n_episodes"], entry["sampler_seed"]) == (40, 6, 0)
    assert entry["episode_seeds"] == "1000..1005" and entry["objective"] == "rmse_energy"
    assert entry["validation"]["after"]["score"] < entry["validation"]["before"]["score"]
    assert entry["replaces"] == DEFAULT_TUNED["pid"]


def test_a_rejected_retune_writes_nothing(tmp_path):
    path = tmp_path / "SmaSpineEasy-v2.yml"
    assert write_id_gains(_record(False), path=path) is None
    assert not path.exists()


def test_budget_is_checked_and_described():
    assert Budget(40, 6).describe() == "40 trials × 6 episodes (seeds 1000..1005), TPE seed 0, rmse_energy"
    for bad, match in (({"trials": 0}, "trials"), ({"episodes": 0}, "episodes"),
                       ({"objective": "mse"}, "objective"), ({"validation_episodes": 0}, "validation_episodes")):  # fmt: skip
        with pytest.raises(ValueError, match=match):
            Budget(**{"trials": 1, "episodes": 1, **bad})


def test_the_shipped_per_id_gains_won_on_validation_and_carry_their_budget():
    files = sorted(p for p in TUNED_DIR.glob("*.yml") if not p.name.startswith("baselines"))
    for path in files:
        env_id = path.stem
        for name, entry in yaml.safe_load(path.read_text()).items():
            assert entry["env_id"] == env_id
            assert entry["n_trials"] >= 1 and entry["n_episodes"] >= 1 and "sampler_seed" in entry
            assert entry["episode_seeds"].startswith(str(TRAIN_SEED_BASE))
            assert entry["validation"]["seeds"].startswith(str(VALIDATION_SEED_BASE))
            assert adopt(entry["validation"]["before"]["score"], entry["validation"]["after"]["score"])
            assert load_tuned(env_id=env_id)[name] == entry["params"]
            env = make_env({}, env_id=env_id)
            build_controller(name, env)  # valid gains
            env.close()


# --------------------------------------------------------------------------- the objective
def test_the_energy_aware_objective_adds_the_rewards_energy_term():
    env = make_env({"episode_duration": 3.0}, env_id="SmaSpineEasy-v2")
    traj = run_episode(env, build_controller("pid", env), seed=TRAIN_SEED_BASE)
    rmse = float(np.sqrt(np.mean(traj.error**2)))
    assert episode_score(env, traj, "rmse") == pytest.approx(rmse)
    cfg = env.unwrapped.config
    assert energy_exchange_rate(env) == pytest.approx(cfg.error_scale * cfg.energy_weight) == pytest.approx(5.0)
    # the same exchange rate as the reward: −|e|/error_scale − energy_weight · E/E_ref per step
    energy_term = -float(np.mean(traj.reward)) * cfg.error_scale - float(np.mean(np.abs(traj.error)))
    assert episode_score(env, traj, "rmse_energy") - rmse == pytest.approx(energy_term, rel=1e-3)
    assert np.sum(traj.energy_J) > 0
    with pytest.raises(ValueError, match="objective"):
        episode_score(env, traj, "mse")
    env.close()


def test_retune_one_compares_the_family_gains_with_the_retune_on_validation_episodes():
    budget = Budget(trials=2, episodes=1, validation_episodes=1)
    rec = retune.retune_one("SmaSpineEasy-v2", "pid", budget)
    family = retune.family_gains("SmaSpineEasy-v2", "pid")
    assert rec["previous_params"] == family
    assert rec["validation"]["before"] == retune.validation_summary("SmaSpineEasy-v2", "pid", family, budget)
    assert rec["adopted"] == adopt(rec["validation"]["before"]["score"], rec["validation"]["after"]["score"])
    assert rec["budget"]["trials"] == 2 and rec["budget"]["episode_seeds"] == f"{TRAIN_SEED_BASE}..{TRAIN_SEED_BASE}"
    assert set(retune.record_row(rec)) == set(retune.ROW_FIELDS)
    with pytest.raises(ValueError, match="name"):
        retune.retune_one("SmaSpineEasy-v2", "step", budget)
