"""Native vector env: equivalence with the single env and SyncVectorEnv, autoreset modes, errors."""

import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv, VectorEnv

import spine_gym  # noqa: F401 - registers the env
from spine_gym.envs import SmaSpineEnv, SmaSpineVectorEnv
from spine_gym.envs.loads import LoadSchedule
from spine_gym.envs.targets import TargetProfile
from spine_gym.envs.spine_vector_env import PARALLEL_MIN_ENVS
from spine_gym.physics import columns as L

# short episodes so that autoresets happen; every source of randomness switched on
KW = {
    "episode_duration": 3.0,
    "tip_force_count": (1, 3),
    "domain_randomization": True,
    "sensor_noise": {"angle": 0.2, "temperature": 0.5, "resistance": 0.01},
    "sensor_delay": 1,
}
NUMERIC_INFO = ("voltage", "angle_deg", "target_deg", "energy_J", "cost", "temperature", "time", "tip_force")


def actions(n_steps, n_envs, seed=0):
    return np.random.default_rng(seed).uniform(-1.3, 1.3, size=(n_steps, n_envs, 2)).astype(np.float32)


def assert_same_infos(ours: dict, ref: dict, where: str = "info") -> None:
    """Same keys, masks and values as a SyncVectorEnv's info dict (recursing into final_info)."""
    assert sorted(ours) == sorted(ref), f"{where}: keys differ: {sorted(set(ours) ^ set(ref))}"
    for key, v in ref.items():
        if isinstance(v, dict):
            assert_same_infos(ours[key], v, f"{where}[{key!r}]")
        elif v.dtype == object:  # final_obs, status_text: None where the mask is False
            assert ours[key].dtype == object and len(ours[key]) == len(v), f"{where}[{key!r}]"
            for a, b in zip(ours[key], v, strict=True):
                assert (a is None) == (b is None) and (a is None or np.array_equal(a, b)), f"{where}[{key!r}]"
        else:
            assert ours[key].dtype == v.dtype and np.array_equal(ours[key], v), f"{where}[{key!r}]"


class PinFirstLoads(gym.Wrapper):
    """Pins the load schedule of an explicit reset ``options={"pin": True}`` (SyncVectorEnv hands
    one options dict to every env); autoresets (no options) draw as usual."""

    def __init__(self, env, loads):
        super().__init__(env)
        self.loads = loads

    def reset(self, *, seed=None, options=None):
        pinned = {"loads": self.loads} if options and self.loads is not None else None
        return self.env.reset(seed=seed, options=pinned)


def test_make_vec_returns_the_native_vector_env_without_warnings():
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        venv = gym.make_vec("SmaSpine-v0", num_envs=3)
    # Gymnasium notes that a newer version of a -v0 id exists; nothing else may warn
    assert [str(x.message) for x in w if "is out of date" not in str(x.message)] == []
    assert isinstance(venv, SmaSpineVectorEnv) and isinstance(venv, VectorEnv)
    assert venv.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    assert venv.num_envs == 3 and venv.max_steps == 600
    assert venv.action_space.shape == (3, 2) and venv.observation_space.shape == (3, 10)
    assert venv.single_observation_space == SmaSpineEnv().observation_space
    # the parallel kernel is the default from PARALLEL_MIN_ENVS sub-envs on (serial below it)
    assert not venv.parallel and SmaSpineVectorEnv(PARALLEL_MIN_ENVS).parallel
    assert not SmaSpineVectorEnv(PARALLEL_MIN_ENVS - 1).parallel


def test_rows_equal_single_envs_seeded_seed_plus_i():
    """Row i == gym.make single env reset with seed + i, through several autoresets (NEXT_STEP)."""
    n, seed = 3, 21
    venv = gym.make_vec("SmaSpine-v0", num_envs=n, **KW)
    singles = [gym.make("SmaSpine-v0", **KW) for _ in range(n)]
    obs, info = venv.reset(seed=seed)
    for i, env in enumerate(singles):
        o, inf = env.reset(seed=seed + i)
        assert np.array_equal(obs[i], o)
        assert info["target_deg"][i] == inf["target_deg"]
    done = np.zeros(n, dtype=bool)
    n_resets = 0
    for a in actions(100, n):
        obs, rew, term, trunc, info = venv.step(a)
        for i, env in enumerate(singles):
            if done[i]:  # NEXT_STEP: this step resets row i and ignores its action
                o, inf = env.reset()
                r, te, tr = 0.0, False, False
                n_resets += 1
            else:
                o, r, te, tr, inf = env.step(a[i])
            assert np.array_equal(obs[i], o)
            assert (rew[i], term[i], trunc[i]) == (r, te, tr)
            for key in NUMERIC_INFO:
                assert np.array_equal(info[key][i], inf[key]), key
        done = term | trunc
    assert n_resets >= 6


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_autoreset_matches_sync_vector_env(mode):
    n, seed = 2, 5
    native = SmaSpineVectorEnv(n, autoreset_mode=mode, **KW)
    sync = SyncVectorEnv([lambda: SmaSpineEnv(**KW) for _ in range(n)], autoreset_mode=mode)
    assert native.metadata["autoreset_mode"] is mode
    o1, _ = native.reset(seed=seed)
    o2, _ = sync.reset(seed=seed)
    assert np.array_equal(o1, o2)
    finals = 0
    prev_done = np.zeros(n, dtype=bool)
    for a in actions(75, n, seed=3):
        o1, r1, te1, tr1, i1 = native.step(a)
        o2, r2, te2, tr2, i2 = sync.step(a)
        assert np.array_equal(o1, o2) and np.array_equal(r1, r2)
        assert np.array_equal(te1, te2) and np.array_equal(tr1, tr2)
        assert_same_infos(i1, i2)
        if mode == AutoresetMode.SAME_STEP and (te1 | tr1).any():
            finals += 1
            assert np.array_equal(i1["_final_obs"], i2["_final_obs"])
            for i in np.flatnonzero(i1["_final_obs"]):
                assert np.array_equal(i1["final_obs"][i], i2["final_obs"][i])
                assert i1["final_info"]["time"][i] == pytest.approx(3.0)
                assert i1["final_info"]["_time"][i]
                assert i1["time"][i] == 0.0  # the info of the new episode
        if mode == AutoresetMode.NEXT_STEP:  # rows reset in this step carry the reset info only
            assert np.all(i1["time"][prev_done] == 0.0) and np.all(r1[prev_done] == 0.0)
            assert np.all(i1["reward_tracking"][prev_done] == 0.0)
        prev_done = te1 | tr1
    if mode == AutoresetMode.SAME_STEP:
        assert finals >= 2


def test_truncates_on_its_own_and_respects_max_episode_steps():
    venv = SmaSpineVectorEnv(4, episode_duration=1.0)
    venv.reset(seed=0)
    trunc = [venv.step(np.zeros((4, 2)))[3].copy() for _ in range(10)]
    assert not np.any(trunc[:9]) and np.all(trunc[9])
    # NEXT_STEP: the following step resets every row (reward 0, time 0)
    _, r, te, tr, info = venv.step(np.ones((4, 2)))
    assert np.all(r == 0) and not te.any() and not tr.any() and np.all(info["time"] == 0.0)
    capped = SmaSpineVectorEnv(2, max_episode_steps=5)
    capped.reset(seed=0)
    trunc = [capped.step(np.zeros((2, 2)))[3].copy() for _ in range(5)]
    assert not np.any(trunc[:4]) and np.all(trunc[4])


def test_disabled_autoreset_with_reset_mask():
    venv = SmaSpineVectorEnv(3, episode_duration=0.5, autoreset_mode=AutoresetMode.DISABLED)
    venv.reset(seed=0)
    for _ in range(5):
        obs, _, _, trunc, _ = venv.step(np.zeros((3, 2)))
    assert trunc.all()
    before = obs.copy()
    obs, info = venv.reset(options={"reset_mask": np.array([True, False, True])})
    assert np.array_equal(info["_time"], [True, False, True])
    assert np.array_equal(obs[1], before[1]) and not np.array_equal(obs[0], before[0])
    with pytest.raises(ValueError, match="reset_mask"):
        venv.reset(options={"reset_mask": np.array([1, 0, 1])})


def test_parallel_and_serial_loops_are_bit_identical():
    a = actions(40, 8, seed=9)
    out = []
    for parallel in (True, False):
        venv = SmaSpineVectorEnv(8, parallel=parallel, **KW)
        obs, _ = venv.reset(seed=77)
        rows = [obs]
        for x in a:
            rows.append(venv.step(x)[0])
        out.append(np.array(rows))
    assert np.array_equal(out[0], out[1])


def test_a_failing_row_terminates_alone_and_stays_finite():
    crush = LoadSchedule(tip_force_events=((1.0, math.inf, (0.0, -8.0)),))  # past buckling (5.6 N)
    venv = SmaSpineVectorEnv(3, tip_force_range=None, payload_range=None)
    venv.reset(seed=0, options={"loads": [None, crush, None]})
    a = np.tile([1.0, -1.0], (3, 1))
    for _ in range(60):
        obs, r, term, trunc, info = venv.step(a)
        assert np.all(np.isfinite(obs)) and np.all(np.isfinite(r))
        assert all(venv.single_observation_space.contains(o) for o in obs)
        if term.any():
            break
    assert term.tolist() == [False, True, False] and info["status"][1] == L.ERR_BUCKLING


def test_per_env_and_shared_reset_options():
    venv = SmaSpineVectorEnv(3)
    obs, _ = venv.reset(seed=0, options={"target": TargetProfile.constant(12.0)})
    assert np.all(obs[:, 1] == 12.0)
    obs, _ = venv.reset(seed=0, options={"target": [10.0, None, -10.0]})
    assert obs[0, 1] == 10.0 and obs[2, 1] == -10.0
    with pytest.raises(ValueError, match="num_envs"):
        venv.reset(options={"target": [1.0, 2.0]})


def test_seeding_and_pickling():
    a = actions(30, 2, seed=4)
    v1, v2 = SmaSpineVectorEnv(2, **KW), SmaSpineVectorEnv(2, **KW)
    assert np.array_equal(v1.reset(seed=[3, 9])[0], v2.reset(seed=[3, 9])[0])
    for x in a[:10]:
        v1.step(x)
        v2.step(x)
    clone = pickle.loads(pickle.dumps(v1))
    for x in a[10:]:
        o1, r1, *_ = v1.step(x)
        o2, r2, *_ = v2.step(x)
        o3, r3, *_ = clone.step(x)
        assert np.array_equal(o1, o2) and np.array_equal(o1, o3) and np.array_equal(r1, r3)
    single = SmaSpineEnv(**KW)
    assert np.array_equal(single.reset(seed=9)[0], SmaSpineVectorEnv(2, **KW).reset(seed=[3, 9])[0][1])


@pytest.mark.parametrize(
    "bad, match",
    [
        (np.zeros((3, 2)), "shape"),
        (np.zeros(4), "shape"),
        (np.array([[0.0, np.nan], [0.0, 0.0]]), "finite"),
    ],
)
def test_bad_actions_raise(bad, match):
    venv = SmaSpineVectorEnv(2)
    venv.reset(seed=0)
    with pytest.raises(ValueError, match=match):
        venv.step(bad)


def test_bad_arguments():
    with pytest.raises(ValueError, match="num_envs"):
        SmaSpineVectorEnv(0)
    with pytest.raises(ValueError, match="v_max"):
        SmaSpineVectorEnv(2, v_max=-1.0)
    with pytest.raises(ValueError, match="autoreset_mode"):
        SmaSpineVectorEnv(2, autoreset_mode="sometimes")
    with pytest.raises(ValueError, match="max_episode_steps"):
        SmaSpineVectorEnv(2, max_episode_steps=0)
    with pytest.raises(TypeError, match="colour"):
        SmaSpineVectorEnv(2, colour="red")
    venv = SmaSpineVectorEnv(2)
    with pytest.raises(RuntimeError, match="reset"):
        venv.step(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="seeds"):
        venv.reset(seed=[1, 2, 3])
    with pytest.raises(ValueError, match="unknown reset option"):
        venv.reset(options={"colour": 1})


def test_render_returns_one_frame_per_env():
    venv = gym.make_vec("SmaSpine-v0", num_envs=2, render_mode="rgb_array")
    venv.reset(seed=0)
    frames = venv.render()
    assert len(frames) == 2 and all(f.shape == (480, 480, 3) for f in frames)
    venv.close()


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_failed_step_carries_status_text_as_sync_vector_env(mode):
    """A failed sub-env step has ``status_text`` (masked to that row), as SyncVectorEnv
    over single envs gives it; in SAME_STEP mode inside ``final_info``."""
    crush = LoadSchedule(tip_force_events=((1.0, math.inf, (0.0, -8.0)),))  # past buckling (5.6 N)
    kw = {"tip_force_range": None, "payload_range": None, "episode_duration": 3.0}
    native = SmaSpineVectorEnv(3, autoreset_mode=mode, **kw)
    sync = SyncVectorEnv(
        [lambda loads=loads: PinFirstLoads(SmaSpineEnv(**kw), loads) for loads in (None, crush, None)],
        autoreset_mode=mode,
    )
    _, i1 = native.reset(seed=0, options={"loads": [None, crush, None]})
    _, i2 = sync.reset(seed=0, options={"pin": True})
    assert_same_infos(i1, i2)
    failed = 0
    for _ in range(35):
        a = np.tile([1.0, -1.0], (3, 1))
        o1, r1, te1, tr1, i1 = native.step(a)
        o2, r2, te2, tr2, i2 = sync.step(a)
        assert np.array_equal(o1, o2) and np.array_equal(te1, te2) and np.array_equal(tr1, tr2)
        assert_same_infos(i1, i2)
        if te1.any():
            failed += 1
            info = i1["final_info"] if mode == AutoresetMode.SAME_STEP else i1
            assert info["_status_text"].tolist() == [False, True, False]
            assert info["status_text"][1] == L.STATUS_TEXT[L.ERR_BUCKLING]
    assert failed == 1


def test_same_step_with_all_envs_done_has_the_sync_vector_env_keys():
    """Equal episode lengths end every sub-env in one step; the info is then the reset
    info (no all-False reward masks), and reset infos have every step key."""
    kw = {"episode_duration": 0.5}
    native = SmaSpineVectorEnv(2, autoreset_mode=AutoresetMode.SAME_STEP, **kw)
    sync = SyncVectorEnv(
        [lambda: SmaSpineEnv(**kw) for _ in range(2)], autoreset_mode=AutoresetMode.SAME_STEP
    )
    _, reset_info = native.reset(seed=1)
    _, ref = sync.reset(seed=1)
    assert_same_infos(reset_info, ref)
    for k in range(5):
        _, _, _, trunc, i1 = native.step(np.zeros((2, 2)))
        _, _, _, _, i2 = sync.step(np.zeros((2, 2)))
        assert_same_infos(i1, i2)
        if k < 4:
            step_keys = set(i1)
    assert trunc.all() and i1["_reward_tracking"].all() and np.all(i1["reward_tracking"] == 0.0)
    assert set(reset_info) == step_keys
    single = SmaSpineEnv()
    _, info = single.reset(seed=0)
    assert set(info) == set(single.step(np.zeros(2))[4])


def test_reset_seed_is_recorded_as_gymnasium_vector_envs_do():
    """``np_random_seed`` is the int seed of the reset (as CartPole's native vector env);
    per sub-env seeds and generators via get_attr equal SyncVectorEnv's."""
    native = gym.make_vec("SmaSpine-v0", num_envs=3)
    cartpole = gym.make_vec("CartPole-v1", num_envs=3, vectorization_mode="vector_entry_point")
    sync = SyncVectorEnv([lambda: SmaSpineEnv() for _ in range(3)])
    native.reset(seed=42)
    cartpole.reset(seed=42)
    sync.reset(seed=42)
    assert native.np_random_seed == cartpole.np_random_seed == 42
    assert native.get_attr("np_random_seed") == sync.np_random_seed == (42, 43, 44)
    for g1, g2 in zip(native.get_attr("np_random"), sync.np_random, strict=True):
        assert g1.bit_generator.state == g2.bit_generator.state
    native.reset()  # no seed: the generators run on, the seed stays
    assert native.np_random_seed == 42
    native.reset(seed=[5, 6, 7])
    assert native.get_attr("np_random_seed") == (5, 6, 7)
