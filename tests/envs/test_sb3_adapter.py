"""SB3 adapter over the native vector env: DummyVecEnv semantics, wrappers, PPO/SAC smoke runs."""

import math

import gymnasium as gym
import numpy as np
import pytest
import torch
from stable_baselines3 import PPO, SAC
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

import spine_gym  # noqa: F401 - registers the env
from spine_gym.envs import SmaSpineEnv
from spine_gym.envs.sb3 import SmaSpineSB3VecEnv, make_sb3_vec_env
from spine_gym.envs.loads import LoadSchedule

torch.set_num_threads(1)
KW = {"episode_duration": 2.0, "domain_randomization": True, "sensor_noise": {"angle": 0.1}}


def test_adapter_equals_dummy_vec_env_of_single_envs():
    """Same seeds, same actions: obs, rewards, dones, terminal observations and infos agree."""
    n = 3
    ours = SmaSpineSB3VecEnv(n, **KW)
    ref = DummyVecEnv([lambda: SmaSpineEnv(**KW) for _ in range(n)])
    ours.seed(7)
    ref.seed(7)
    o1, o2 = ours.reset(), ref.reset()
    assert np.array_equal(o1, o2)
    assert ours.reset_infos[1]["target_deg"] == ref.reset_infos[1]["target_deg"]
    rng = np.random.default_rng(0)
    episodes_done = 0
    for _ in range(65):
        a = rng.uniform(-1, 1, size=(n, 2)).astype(np.float32)
        ours.step_async(a)
        ref.step_async(a)
        o1, r1, d1, i1 = ours.step_wait()
        o2, r2, d2, i2 = ref.step_wait()
        assert np.array_equal(o1, o2) and np.array_equal(r1, r2) and np.array_equal(d1, d2)
        assert r1.dtype == np.float32 and d1.dtype == np.bool_
        for a_info, b_info in zip(i1, i2, strict=True):
            assert a_info["TimeLimit.truncated"] == b_info["TimeLimit.truncated"]
            for key in ("angle_deg", "time", "cost", "energy_J"):
                assert a_info[key] == b_info[key], key
            assert ("terminal_observation" in a_info) == ("terminal_observation" in b_info)
            if "terminal_observation" in a_info:
                assert np.array_equal(a_info["terminal_observation"], b_info["terminal_observation"])
                assert a_info["time"] == pytest.approx(2.0) and a_info["TimeLimit.truncated"]
                episodes_done += 1
        for j in range(n):
            assert ours.reset_infos[j]["time"] == ref.reset_infos[j]["time"]
    assert episodes_done == 3 * n


def test_terminated_episode_is_not_marked_truncated():
    crush = LoadSchedule(tip_force_events=((1.0, math.inf, (0.0, -8.0)),))  # past buckling (5.6 N)
    env = SmaSpineSB3VecEnv(2, tip_force_range=None, payload_range=None)
    env.set_options([{"loads": crush}, {}])
    env.reset()
    for _ in range(100):
        env.step_async(np.tile([1.0, -1.0], (2, 1)).astype(np.float32))
        obs, _, dones, infos = env.step_wait()
        if dones[0]:
            break
    assert dones[0] and not dones[1]
    assert infos[0]["status"] != 0 and infos[0]["TimeLimit.truncated"] is False
    assert np.all(np.isfinite(infos[0]["terminal_observation"])) and np.all(np.isfinite(obs))


def test_vecmonitor_and_vecnormalize_report_episodes():
    env = make_sb3_vec_env(2, seed=0, normalize=True, env_kwargs={"episode_duration": 1.0})
    assert isinstance(env, VecNormalize) and isinstance(env.venv, VecMonitor)
    env.reset()
    episodes = []
    for _ in range(10):
        _, _, _, infos = env.step(np.zeros((2, 2), dtype=np.float32))
        episodes += [i["episode"] for i in infos if "episode" in i]
    assert len(episodes) == 2 and all(e["l"] == 10 for e in episodes)
    assert env.get_attr("temperature_limit") == [423.0, 423.0]
    assert env.env_is_wrapped(VecMonitor) == [False, False]


def test_get_set_attr_env_method_and_images():
    env = SmaSpineSB3VecEnv(2, render_mode="rgb_array")
    assert env.render_mode == "rgb_array"
    env.reset()
    assert env.get_attr("v_max", indices=[1]) == [5.0]
    frames = env.get_images()
    assert len(frames) == 2 and frames[0].shape == (480, 480, 3)
    called = env.env_method("render", indices=[0, 1])  # one call on the vector env, result per index
    assert len(called) == 2 and len(called[0]) == 2 and called[0][1].shape == (480, 480, 3)
    with pytest.raises(ValueError, match="share"):
        env.set_attr("render_mode", None, indices=[0])
    with pytest.raises(ValueError, match="unknown reset option"):
        env.set_options({"colour": 1})
        env.reset()


@pytest.mark.parametrize("algo", [PPO, SAC])
def test_ppo_and_sac_train_on_the_adapter(algo):
    env = VecNormalize(VecMonitor(SmaSpineSB3VecEnv(4, seed=0, episode_duration=2.0)))
    kwargs = (
        {"n_steps": 16, "batch_size": 32, "n_epochs": 1}
        if algo is PPO
        else {"learning_starts": 16, "batch_size": 16}
    )
    model = algo("MlpPolicy", env, seed=0, device="cpu", **kwargs)
    model.learn(64)
    assert model.num_timesteps >= 64
    action, _ = model.predict(env.reset(), deterministic=True)
    assert action.shape == (4, 2) and np.all(np.abs(action) <= 1.0)


def test_plain_make_vec_env_with_the_single_env():
    env = make_vec_env("SmaSpine-v0", n_envs=2, seed=0, env_kwargs={"episode_duration": 2.0})
    model = PPO("MlpPolicy", env, n_steps=16, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(32)
    assert model.num_timesteps >= 32
    assert isinstance(gym.make("SmaSpine-v0").unwrapped, SmaSpineEnv)


def test_failed_step_status_text_in_infos_as_dummy_vec_env():
    """The per-env info (= final info) of a failed step has ``status_text``, with the keys
    DummyVecEnv gives."""
    crush = LoadSchedule(tip_force_events=((1.0, math.inf, (0.0, -8.0)),))  # past buckling (5.6 N)
    kw = {"tip_force_range": None, "payload_range": None, "episode_duration": 3.0}
    ours = SmaSpineSB3VecEnv(2, **kw)
    ref = DummyVecEnv([lambda: SmaSpineEnv(**kw) for _ in range(2)])
    for env in (ours, ref):
        env.seed(0)
        env.set_options([{"loads": crush}, {}])
        env.reset()
    for _ in range(30):
        a = np.tile([1.0, -1.0], (2, 1)).astype(np.float32)
        ours.step_async(a)
        ref.step_async(a)
        _, _, d1, i1 = ours.step_wait()
        _, _, d2, i2 = ref.step_wait()
        assert np.array_equal(d1, d2)
        for a_info, b_info in zip(i1, i2, strict=True):
            assert sorted(a_info) == sorted(b_info)
            assert a_info.get("status_text") == b_info.get("status_text")
        if d1[0]:
            break
    assert d1.tolist() == [True, False] and "buckling" in i1[0]["status_text"]
    assert "terminal_observation" in i1[0]


def test_get_attr_gives_per_env_values_as_dummy_vec_env():
    """Spaces of one env (not the batch), one generator per env, the env's own seed and
    episode, and every single-env attribute (episode_duration)."""
    ours = SmaSpineSB3VecEnv(2, **KW)
    ref = DummyVecEnv([lambda: SmaSpineEnv(**KW) for _ in range(2)])
    for env in (ours, ref):
        env.seed(3)
        env.reset()
    for name in (
        "observation_space",
        "action_space",
        "episode_duration",
        "v_max",
        "np_random_seed",
        "target_profile",
        "load_schedule",
        "model_params",
        "max_steps",
    ):
        assert ours.get_attr(name) == ref.get_attr(name), name
    assert ours.get_attr("observation_space")[0].shape == (10,)
    assert ours.get_attr("np_random_seed", indices=[1]) == [4]
    g1, g2 = ours.get_attr("np_random"), ref.get_attr("np_random")
    assert g1[0] is not g1[1]
    assert [g.bit_generator.state for g in g1] == [g.bit_generator.state for g in g2]
    assert np.array_equal(ours.get_attr("state")[1], ref.get_attr("state")[1])
