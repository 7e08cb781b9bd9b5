"""spine_gym/agents/ on the spatial envs: train/evaluate/tune CLIs on the new ids with tiny budgets,
their scenario suites and registries, and the shipped SmaSpine3D-v0 policy."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from random_policy import RandomPolicy
from repo import ROOT

from spine_gym.agents import evaluate as ev
from spine_gym.agents import registry
from spine_gym.agents.runtime import build_controller, load_policy, make_env, run_episode
from spine_gym.agents.scenarios import EVAL_SEED_BASE, get_suite
from spine_gym.agents.tune import TRAIN_SEED_BASE, tune
from spine_gym.agents.zoo_config import CHAIN_ENV_ID, POLICIES_DIR, SPATIAL_ENV_ID

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
SPATIAL_IDS = (SPATIAL_ENV_ID, CHAIN_ENV_ID)


def run_cli(*args, timeout=300):
    proc = subprocess.run(
        [sys.executable, *args], cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=timeout
    )
    assert proc.returncode == 0, f"{args} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


TINY = ["--env-kwargs", "episode_duration:3.0", "--eval-freq", "0", "--save-freq", "0", "-v", "0",
        "--no-tensorboard"]  # fmt: skip


@pytest.mark.parametrize(
    "env_id, extra", [(SPATIAL_ENV_ID, []), (CHAIN_ENV_ID, ["residual:pid", "residual_scale:0.5"])]
)
def test_train_smoke_on_the_spatial_ids(tmp_path, env_id, extra):
    run_cli(
        "-m", "spine_gym.agents.train", "--algo", "ppo", "--env", env_id, "-n", "256", "--n-envs", "2",
        "-f", str(tmp_path), *TINY, "-params", "n_steps:64", "batch_size:64", "n_epochs:1", *extra,
    )  # fmt: skip
    run = tmp_path / "ppo" / f"{env_id}_1"
    meta = json.loads((run / "meta.json").read_text())
    assert meta["env_id"] == env_id and meta["total_timesteps"] >= 256
    pol = load_policy(run)
    env = make_env({"episode_duration": 3.0}, env_id=env_id)
    obs, _ = env.reset(seed=0)
    a, _ = pol.predict(obs)
    assert a.shape == env.action_space.shape and np.all(np.abs(a) <= 1.0)
    env.close()


@pytest.mark.parametrize(
    "env_id, scenario, unit", [(SPATIAL_ENV_ID, "step_diag", "deg"), (CHAIN_ENV_ID, "steps", "mm")]
)
def test_evaluate_cli_on_the_spatial_ids(tmp_path, env_id, scenario, unit):
    proc = run_cli(
        "-m", "spine_gym.agents.evaluate", "--env", env_id, "--suite", "quick", "--scenarios", scenario, "--models",
        "-o", str(tmp_path), "--plain",
    )  # fmt: skip
    assert f"RMSE [{unit}]" in proc.stdout
    rows = (tmp_path / "metrics.csv").read_text().splitlines()
    assert len(rows) == 1 + len(registry.baselines_for(env_id))
    assert (tmp_path / "plots" / "pid_nominal.png").stat().st_size > 10_000


def test_tuning_on_the_3d_env_is_reproducible_and_uses_training_seeds():
    kw = {"episode_duration": 3.0}
    r1 = tune("pid", n_trials=2, n_episodes=1, seed=3, env_kwargs=kw, verbose=False, env_id=SPATIAL_ENV_ID)
    r2 = tune("pid", n_trials=2, n_episodes=1, seed=3, env_kwargs=kw, verbose=False, env_id=SPATIAL_ENV_ID)
    assert r1["params"] == r2["params"] and r1["train_rmse_deg"] == r2["train_rmse_deg"]
    assert r1["episode_seeds"] == f"{TRAIN_SEED_BASE}..{TRAIN_SEED_BASE}" and r1["env_id"] == SPATIAL_ENV_ID


@pytest.mark.parametrize("env_id", SPATIAL_IDS)
def test_registry_builds_every_spatial_baseline_with_its_tuned_settings(env_id):
    env = make_env({"episode_duration": 2.0}, env_id=env_id)
    tuned = registry.load_tuned(env_id=env_id)
    for name, spec in registry.registry_for(env_id).items():
        ctrl = build_controller(name, env)
        assert isinstance(ctrl, spec.cls)
        assert ctrl.temperature_limit == (
            env.temperature_limit - registry.GUARD_MARGIN_K if spec.guard else None
        )
        if name == "pid":
            assert ctrl.gains.kp == tuned["pid"]["kp"]
    assert {"mpc_oracle", "mpc_estimated"} <= set(registry.registry_for(env_id))  # every env id
    assert build_controller("mpc_oracle", env).mode == "oracle"
    with pytest.raises(ValueError, match="unknown controller 'lqr'"):
        build_controller("lqr", env)
    env.close()


@pytest.mark.parametrize("env_id", SPATIAL_IDS)
def test_spatial_suites_are_seeded_apart_and_inside_the_env_task(env_id):
    suite = get_suite("full", env_id=env_id)
    assert {s.group for s in suite} == {"nominal", "disturbed"}
    seeds = [s.seed for s in suite]
    assert len(set(seeds)) == len(seeds) and min(seeds) >= EVAL_SEED_BASE
    planar = {s.seed for s in get_suite("full")}
    assert not planar & set(seeds)
    env = make_env({"episode_duration": 60.0}, env_id=env_id)
    for sc in suite:
        opts = sc.reset_options()
        if env_id == CHAIN_ENV_ID:  # inside the workspace the chain env documents (its module bend limit)
            assert opts["target"].max_bend() <= env.config.module_bend_limit + 1e-9
        else:
            assert opts["target"].max_magnitude() <= 45.0
        if sc.group == "disturbed":
            assert len(sc.tip_pulses) == 2 and all(len(p) == 5 for p in sc.tip_pulses)
        env.reset(seed=sc.seed, options=opts)  # the env accepts it
    env.close()


# --------------------------------------------------------------------------- the shipped 3-D policy
SHIPPED_3D = sorted(ev.shipped_policies(SPATIAL_ENV_ID))


def test_a_3d_policy_is_shipped_small_and_documented():
    assert SHIPPED_3D, "no shipped policy for SmaSpine3D-v0"
    for name in SHIPPED_3D:
        folder = POLICIES_DIR / name
        assert sum(f.stat().st_size for f in folder.iterdir()) < 2_000_000
        meta = json.loads((folder / "meta.json").read_text())
        assert (
            meta["command"].startswith("python -m spine_gym.agents.train") and "--env SmaSpine3D-v0" in meta["command"]
        )
    assert SHIPPED_3D[0] in (POLICIES_DIR / "COMMANDS.md").read_text()


@pytest.mark.parametrize("name", SHIPPED_3D)
def test_shipped_3d_policy_beats_a_random_policy(name):
    scenario = get_suite("full", names=["step_tour_dist"], env_id=SPATIAL_ENV_ID)[0]
    pol = load_policy(POLICIES_DIR / name)
    env = make_env({**pol.env_kwargs, "episode_duration": scenario.duration}, env_id=SPATIAL_ENV_ID)

    def rmse(p):
        return np.sqrt(np.mean(run_episode(env, p, scenario).error ** 2))

    assert rmse(pol) < 0.5 * rmse(RandomPolicy(4))
    env.close()
