"""spine_gym.agents.datasets: Minari datasets of a controller's episodes round-trip, carry their metadata,
refuse to overwrite and reject bad arguments before writing anything."""

from __future__ import annotations

import json

import minari
import numpy as np
import pytest

from spine_gym.agents.datasets import main
from spine_gym.agents.minari_datasets import DATASET_SEED_BASE, dataset_id, load_metadata, transitions
from spine_gym.agents.runtime import VALIDATION_SEED_BASE, build_controller, make_env

ENV_KWARGS = {"episode_duration": 5.0}
IDS = ("SmaSpine-v1", "SmaSpine3D-v2")
#: the envelope each dataset records: on -v1 the PID's own guard, on -v2 the plant's cut-off
ENVELOPES = {
    "SmaSpine-v1": {"v_max_V": 5.0, "cutoff_K": None, "guard": "controller 418 K"},
    "SmaSpine3D-v2": {"v_max_V": 5.0, "cutoff_K": 418.0, "guard": "plant 418 K"},
}
ARGS = ["--controller", "pid", "--episodes", "2", "--env-kwargs", "episode_duration:5.0"]


@pytest.fixture(scope="module")
def data_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("minari")
    assert main(["--env", *IDS, *ARGS, "--data-path", str(path)]) == 0
    return path


@pytest.fixture
def datasets(data_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(data_path))
    return {env_id: minari.load_dataset(dataset_id(env_id, "pid")) for env_id in IDS}


def rerun(env_id: str, seed: int):
    """The PID's episode on a fresh env, stepped here (not through spine_gym.agents.runtime.run_episode)."""
    env = make_env(ENV_KWARGS, env_id=env_id)
    ctrl = build_controller("pid", env)
    ctrl.reset()
    obs, _ = env.reset(seed=seed)
    observations, actions, rewards, start = [obs], [], [], np.ones((1,), dtype=bool)
    while True:
        a, _ = ctrl.predict(obs[None, :], None, start, True)
        a = np.asarray(a, dtype=np.float32).reshape(env.action_space.shape)
        start = np.zeros((1,), dtype=bool)
        obs, r, terminated, truncated, _ = env.step(a)
        observations.append(obs)
        actions.append(a)
        rewards.append(r)
        if terminated or truncated:
            return np.array(observations), np.array(actions), np.array(rewards), terminated, truncated


@pytest.mark.parametrize("env_id", IDS)
def test_round_trip_equals_a_rerun(datasets, env_id):
    ds = datasets[env_id]
    assert ds.total_episodes == 2
    seeds = [m["seed"] for m in ds.storage.get_episode_metadata(range(2))]
    assert seeds == [DATASET_SEED_BASE, DATASET_SEED_BASE + 1]
    for ep, seed in zip(ds.iterate_episodes(), seeds, strict=True):
        obs, act, rew, terminated, truncated = rerun(env_id, seed)
        assert len(act) == 50  # 5 s at the 0.1-s control period
        np.testing.assert_array_equal(ep.observations, obs)
        np.testing.assert_array_equal(ep.actions, act)
        np.testing.assert_allclose(ep.rewards, rew, rtol=0, atol=1e-12)
        assert bool(ep.terminations[-1]) == terminated and bool(ep.truncations[-1]) == truncated
        assert ep.infos["tracking_error_deg"].shape[0] == 51  # the reset's info and each step's
    x, y = transitions(ds)
    assert x.shape == (100, ds.observation_space.shape[0]) and y.shape == (100, ds.action_space.shape[0])


@pytest.mark.parametrize("env_id", IDS)
def test_metadata(datasets, env_id):
    ds = datasets[env_id]
    assert ds.spec.env_spec.id == env_id and ds.spec.env_spec.kwargs["episode_duration"] == 5.0
    assert ds.storage.metadata["algorithm_name"] == "pid"
    meta = load_metadata(ds)
    assert meta["env_id"] == env_id and meta["tier"] == "default" and meta["env_kwargs"] == ENV_KWARGS
    assert meta["controller"] == "pid" and meta["controller_settings"]["tuned"]["kp"] > 0
    assert meta["envelope"] == ENVELOPES[env_id]
    margin = meta["controller_settings"]["temperature_guard_margin_K"]
    assert margin == (None if meta["envelope"]["cutoff_K"] else 5.0)  # no own guard on the plant's
    assert meta["seeds"] == [DATASET_SEED_BASE, DATASET_SEED_BASE + 1]
    assert DATASET_SEED_BASE + 1 < VALIDATION_SEED_BASE
    assert meta["spine_gym_version"] and "git_commit" in meta
    assert [e["seed"] for e in meta["episodes"]] == meta["seeds"]
    assert all(np.isfinite(e["rmse"]) and e["energy_J"] > 0 for e in meta["episodes"])
    env = ds.recover_environment()
    assert env.unwrapped.spec.id == env_id
    json.dumps(meta)  # plain JSON


def test_existing_dataset_is_refused_without_overwrite(data_path, capsys):
    path = data_path / dataset_id("SmaSpine-v1", "pid")
    before = (path / "data" / "metadata.json").read_text()
    assert main(["--env", "SmaSpine-v1", *ARGS, "--data-path", str(data_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "exists" in err and "--overwrite" in err and len(err.splitlines()) == 1
    assert (path / "data" / "metadata.json").read_text() == before


def test_overwrite_replaces_the_dataset(data_path, monkeypatch):
    argv = ["--env", "SmaSpine-v1", *ARGS[:3], "1", *ARGS[4:], "--data-path", str(data_path)]
    assert main([*argv, "--overwrite", "--seed-base", str(DATASET_SEED_BASE + 5)]) == 0
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(data_path))
    ds = minari.load_dataset(dataset_id("SmaSpine-v1", "pid"))
    assert ds.total_episodes == 1 and load_metadata(ds)["seeds"] == [DATASET_SEED_BASE + 5]
    # restore the shared two-episode dataset for the other tests
    assert main(["--env", "SmaSpine-v1", *ARGS, "--data-path", str(data_path), "--overwrite"]) == 0


@pytest.mark.parametrize(
    ("argv", "word"),
    [
        (["--env", "SmaSpine-v9", "--controller", "pid", "--episodes", "1"], "env id"),
        (["--env", "SmaSpine-v1", "--controller", "pid", "--episodes", "0"], "episodes"),
        (["--env", "SmaSpine-v1", "--controller", "pid", "--episodes", "1", "--seed-base", "5"], "seed_base"),
        (
            [
                "--env",
                "SmaSpine-v1",
                "--controller",
                "pid",
                "--episodes",
                "2",
                "--seed-base",
                str(VALIDATION_SEED_BASE - 1),
            ],
            "seed_base",
        ),  # fmt: skip
        (["--env", "SmaSpine-v1", "--controller", "pidd", "--episodes", "1"], "controller"),
        (["--env", "SmaSpine-v1", "--controller", "no/such/folder", "--episodes", "1"], "does not exist"),
        (
            ["--env", "SmaSpine-v1", "--controller", "pid", "--episodes", "1", "--env-kwargs", "bogus:1"],
            "env-kwargs",
        ),
        (["--env", "SmaSpine-v1", "SmaSpine-v1", "--controller", "pid", "--episodes", "1"], "twice"),
        (["--env", "SmaSpine-v1", "--controller", "pid", "--episodes", "x"], "invalid int"),
    ],
)
def test_bad_arguments_exit_2_before_writing(tmp_path, capsys, argv, word):
    target = tmp_path / "data"
    assert main([*argv, "--data-path", str(target)]) == 2
    err = capsys.readouterr().err.strip()
    assert word in err and len(err.splitlines()) == 1
    assert not target.exists()
