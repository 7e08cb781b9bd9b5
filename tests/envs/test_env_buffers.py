"""The env layer's preallocated step buffers: every env id keeps the Gymnasium and SB3
contracts of its single env, and nothing it hands out is overwritten by a later step.

The vector envs step into per-batch buffers and hand out fresh copies; the SB3 adapter builds its
per-env dicts straight from the table rows. These tests hold all three env ids to the reference
implementations over single envs (``SyncVectorEnv``, SB3's ``DummyVecEnv``), with autoresets, sensor
noise and domain randomisation on, and check that results kept from one step survive the next.
"""

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest
import torch
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.utils.env_match import check_environments_match
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from stable_baselines3.common.vec_env import DummyVecEnv

import spine_gym  # noqa: F401 - registers the env ids
from spine_gym.envs._infos import RowInfo
from spine_gym.envs.sb3 import SmaSpineSB3VecEnv

torch.set_num_threads(1)
IDS = ("SmaSpine-v0", "SmaSpine3D-v0", "SmaSpineChain-v0")
KW = {
    "episode_duration": 0.8,  # 8 steps: autoresets within a short run
    "domain_randomization": True,
    "sensor_noise": {"angle": 0.2, "temperature": 0.5},
    "tip_force_count": (1, 2),
}
MODES = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP, AutoresetMode.DISABLED)


def _acts(env_id, steps, n, seed=0):
    w = gym.make(env_id).action_space.shape[0]
    return np.random.default_rng(seed).uniform(-1.2, 1.2, size=(steps, n, w)).astype(np.float32)


def _same(a, b, where):
    """Equal values, dtypes and keys (tuples, lists, dicts recursively; object arrays element-wise)."""
    if isinstance(b, tuple | list):
        assert isinstance(a, tuple | list) and len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{k}]")
    elif isinstance(b, dict):
        assert sorted(a) == sorted(b), f"{where}: keys {sorted(set(a) ^ set(b))}"
        for k in b:
            _same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(b, np.ndarray) and b.dtype == object:
        assert a.dtype == object and len(a) == len(b), where
        for x, y in zip(a, b, strict=True):
            assert (x is None) == (y is None), where
            if y is not None:
                _same(x, y, where)
    elif isinstance(b, np.ndarray):
        assert isinstance(a, np.ndarray) and a.dtype == b.dtype and np.array_equal(a, b), where
    else:
        assert type(a) is type(b) and a == b, where


def _frozen(x):
    """A deep copy of a step result (to compare with later)."""
    return copy.deepcopy(x)


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
def test_vector_env_equals_sync_vector_env_and_keeps_what_it_returned(env_id, mode):
    """Row i == single env i through autoresets (every mode, every env id), with SyncVectorEnv's
    info keys and masks; the arrays of a step are not changed by the steps after it."""
    n = 2
    native = gym.make_vec(env_id, num_envs=n, autoreset_mode=mode, **KW)
    sync = SyncVectorEnv([lambda: gym.make(env_id, **KW).unwrapped for _ in range(n)], autoreset_mode=mode)
    _same(native.reset(seed=3), sync.reset(seed=3), "reset")
    kept = []
    for a in _acts(env_id, 20, n):
        out = native.step(a)
        _same(out, sync.step(a), "step")
        kept.append((out, _frozen(out)))
        if mode == AutoresetMode.DISABLED and (out[2] | out[3]).all():
            for env in (native, sync):
                env.reset(options={"reset_mask": np.ones(n, dtype=bool)})
    for out, frozen in kept:
        _same(out, frozen, "a step's result after later steps")


@pytest.mark.parametrize("env_id", IDS)
def test_sb3_adapter_infos_equal_dummy_vec_env_in_every_key(env_id):
    """Every key and value of the per-env infos (terminal observations, TimeLimit.truncated,
    reset_infos) as DummyVecEnv of single envs gives them, and they survive later steps."""
    n = 2
    ours = SmaSpineSB3VecEnv(n, env_id=env_id, **KW)
    ref = DummyVecEnv([lambda: gym.make(env_id, **KW).unwrapped for _ in range(n)])
    ours.seed(5)
    ref.seed(5)
    assert np.array_equal(ours.reset(), ref.reset())
    _same(ours.reset_infos, ref.reset_infos, "reset_infos")
    kept, ends = [], 0
    for a in _acts(env_id, 18, n, seed=1):
        ours.step_async(a)
        ref.step_async(a)
        out, expected = ours.step_wait(), ref.step_wait()
        _same(list(out), list(expected), "step_wait")
        _same(ours.reset_infos, ref.reset_infos, "reset_infos")
        ends += int(out[2].sum())
        kept.append((out, _frozen(out)))
    assert ends >= 2 * n
    for out, frozen in kept:
        _same(list(out), list(frozen), "a step's infos after later steps")


@pytest.mark.parametrize("env_id", IDS)
def test_single_env_results_are_not_overwritten_by_later_steps(env_id):
    env = gym.make(env_id, **KW).unwrapped
    first = env.reset(seed=0)
    kept = [(first, _frozen(first))]
    for a in _acts(env_id, 6, 1)[:, 0]:
        out = env.step(a)
        kept.append((out, _frozen(out)))
    for out, frozen in kept:
        _same(out, frozen, "a step's result after later steps")


@pytest.mark.parametrize("env_id", IDS)
def test_copied_pickled_and_restored_vector_envs_continue_bit_for_bit(env_id):
    """A deep copy, a pickle and a snapshot/restore of a vector env mid-episode continue exactly as
    the original (their buffers are their own: the copy's writer does not write into the original)."""
    n = 2
    venv = gym.make_vec(env_id, num_envs=n, autoreset_mode=AutoresetMode.SAME_STEP, **KW).unwrapped
    venv.reset(seed=8)
    acts = _acts(env_id, 16, n, seed=2)
    for a in acts[:5]:
        venv.step(a)
    snaps = [venv.snapshot(i) for i in range(n)]
    clones = [copy.deepcopy(venv), pickle.loads(pickle.dumps(venv))]
    expected = [venv.step(a) for a in acts[5:]]
    for clone in clones:
        assert clone._core.obs is not venv._core.obs
        _same([clone.step(a) for a in acts[5:]], expected, "clone")
    for i, snap in enumerate(snaps):
        venv.restore(i, snap)
    _same([venv.step(a) for a in acts[5:]], expected, "restored")


def test_lazy_infos_behave_as_the_eager_dicts_and_fill_only_when_read():
    """The adapter's per-env infos (RowInfo) fill themselves from the step row on first use: SB3's
    reads of its own keys do not fill them; every dict operation gives the eager dict's result."""
    env = SmaSpineSB3VecEnv(2, seed=0)
    env.reset()
    env.step_async(np.zeros((2, 2), dtype=np.float32))
    _, _, _, infos = env.step_wait()
    eager = env.venv.row_infos()  # the same rows, built eagerly
    for d in eager:
        d["TimeLimit.truncated"] = False
    d, ref = infos[0], eager[0]
    assert isinstance(d, RowInfo)
    assert d.get("episode") is None and "terminal_observation" not in d and not d["TimeLimit.truncated"]
    assert "angle_deg" in d and "status" in d and "status_text" not in d
    assert d._src is not None  # none of that filled it
    for other in (d, dict(d), {**d}, d.copy(), copy.copy(d), copy.deepcopy(d), pickle.loads(pickle.dumps(d))):
        _same(other, ref, "filled")
        assert list(other) == list(ref)  # the eager key order
    assert type(d.copy()) is dict and type(pickle.loads(pickle.dumps(d))) is dict
    e = infos[1]
    e["angle_deg"] = 1.5  # a write of a table key before the fill survives it
    assert e["angle_deg"] == 1.5 and len(e) == len(ref)
    _same(e, {**eager[1], "angle_deg": 1.5}, "written before the fill")


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_check_environments_match_native_and_sync_vector_envs(env_id):
    """Gymnasium's own check (strict types, exact keys, values to 1e-5) passes between the native
    vector env and SyncVectorEnv of the same id, through autoresets (8-step episodes). The check
    tests the flags with ``assert a == b``, so it only runs on one sub-env; the next test takes
    more sub-envs and every autoreset mode."""
    native = gym.make_vec(env_id, num_envs=1, vectorization_mode="vector_entry_point", **KW)
    sync = gym.make_vec(env_id, num_envs=1, vectorization_mode="sync", **KW)
    check_environments_match(native, sync, num_steps=12, seed=7)


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
def test_vector_infos_are_plain_dicts_equivalent_to_sync_vector_env(env_id, mode):
    """Every info dict of a reset and a step (and ``final_info``) is exactly a ``dict``, and each
    reset and step result passes Gymnasium's ``data_equivalence`` against SyncVectorEnv's, bit for
    bit (``exact``), every mode, 3 sub-envs, through autoresets."""
    n = 3
    native = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="vector_entry_point", autoreset_mode=mode, **KW
    )
    sync = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="sync", vector_kwargs={"autoreset_mode": mode}, **KW
    )
    ours, ref = native.reset(seed=11), sync.reset(seed=11)
    assert type(ours[1]) is dict and data_equivalence(ours, ref, exact=True)
    finals = 0
    for a in _acts(env_id, 12, n, seed=2):
        ours, ref = native.step(a), sync.step(a)
        assert type(ours[4]) is dict and data_equivalence(ours, ref, exact=True)
        if "final_info" in ours[4]:
            finals += 1
            assert type(ours[4]["final_info"]) is dict
        if mode == AutoresetMode.DISABLED and (ours[2] | ours[3]).any():
            mask = ours[2] | ours[3]
            ours, ref = (env.reset(options={"reset_mask": mask}) for env in (native, sync))
            assert type(ours[1]) is dict and data_equivalence(ours, ref, exact=True)
    assert finals > 0 or mode != AutoresetMode.SAME_STEP
