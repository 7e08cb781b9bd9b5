"""spine_gym.agents.export: the ONNX graph, the NumPy runner and the generated C agree with SB3's predict.

Models are built untrained (random weights, output layers scaled up so that the action clip and
the tanh squash are exercised) with non-trivial ``VecNormalize`` statistics and a tight
``clip_obs``, saved as run folders and loaded back through :func:`spine_gym.agents.runtime.load_policy`,
as the CLI does. The reference is SB3's ``predict(deterministic=True)`` on
``VecNormalize.normalize_obs`` of 1 000 observations recorded from ``SmaSpine-v0``.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from export_parity import CLIP_OBS, c_runner, onnx_runner, save_model_run
from repo import ROOT
from stable_baselines3 import PPO, SAC, TD3
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

from spine_gym.agents.evaluation import evaluate
from spine_gym.agents.export import OneUlpUp, UnsupportedPolicyError, export_policy, main, record_observations
from spine_gym.agents.numpy_policy import load_bundle
from spine_gym.agents.observations import (
    HistoryObsVecEnv,
    HistorySpec,
    IntegralObsVecEnv,
    IntegralSpec,
    integral_step,
)
from spine_gym.agents.runtime import evaluation_env_kwargs, load_policy, make_env
from spine_gym.agents.scenarios import get_suite

POLICIES = ROOT / "spine_gym" / "agents" / "policies"
TOL = 1e-5
ALGOS = {"ppo": PPO, "sac": SAC, "td3": TD3}

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")


@pytest.fixture(scope="module")
def observations():
    return record_observations()


def _vec_env(features=()):
    venv = DummyVecEnv([make_env])
    for wrap, spec in features:
        venv = wrap(venv, spec)
    return venv


def _scale_output_layer(model) -> None:
    """Random weights large enough that PPO's clip and SAC's / TD3's tanh saturate on some rows
    (PPO's action layer starts at gain 0.01)."""
    pol = model.policy
    factor = {PPO: 300.0, SAC: 30.0, TD3: 30.0}[type(model)]
    layer = {PPO: lambda: pol.action_net, SAC: lambda: pol.actor.mu, TD3: lambda: pol.actor.mu[-2]}[
        type(model)
    ]()
    with torch.no_grad():
        layer.weight.mul_(factor)
        layer.bias.normal_(0.0, 0.3)


def save_run(folder: Path, algo: str, observations: np.ndarray, features=(), meta_extra=None, seed=0):
    """An untrained ``algo`` model with VecNormalize statistics off the data, as a run folder
    (``ppo_sde``: PPO with state-dependent exploration, as the -v1 hyperparameters train it)."""
    venv = _vec_env(features)
    kw = {"buffer_size": 1000} if algo not in ("ppo", "ppo_sde") else {"n_steps": 64, "batch_size": 64}
    if algo == "ppo_sde":
        algo, kw = "ppo", kw | {"use_sde": True, "sde_sample_freq": 16}
    model = ALGOS[algo]("MlpPolicy", venv, seed=seed, device="cpu", **kw)
    _scale_output_layer(model)
    save_model_run(folder, model, venv, observations, {"algo": algo} | (meta_extra or {}), seed=seed)
    return folder


def sb3_reference(folder: Path, net_input: np.ndarray) -> np.ndarray:
    """SB3's deterministic predict on VecNormalize's own transform of ``net_input``."""
    model = ALGOS[json.loads((folder / "meta.json").read_text())["algo"]].load(
        folder / "model.zip", device="cpu"
    )
    vn = VecNormalize.load(str(folder / "vecnormalize.pkl"), DummyVecEnv([make_env]))
    action, _ = model.predict(vn.normalize_obs(net_input), deterministic=True)
    return action


def numpy_runner_without_torch(
    bundle: Path, net_input: np.ndarray, tmp: Path, mode: str = "act"
) -> np.ndarray:
    """The bundle's own copy of the NumPy runner in a fresh interpreter where importing torch fails."""
    np.save(tmp / "in.npy", net_input)
    script = (
        "import sys; sys.modules['torch'] = None\n"
        f"sys.path.insert(0, {str(bundle)!r})\n"
        "import numpy as np\n"
        "from numpy_policy import load_bundle\n"
        f"p = load_bundle({str(bundle)!r}); x = np.load({str(tmp / 'in.npy')!r})\n"
        f"a = p.act(x) if {mode!r} == 'act' else np.array([p.step(o) for o in x])\n"
        f"np.save({str(tmp / 'out.npy')!r}, a)\n"
        "heavy = ('torch', 'stable_baselines3', 'spine_gym', 'onnx')\n"
        "bad = [m for m in sys.modules if m.split('.')[0] in heavy\n"
        "       and sys.modules[m] is not None]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", script], cwd=ROOT, check=True, capture_output=True, text=True)
    return np.load(tmp / "out.npy")


@pytest.mark.parametrize("algo", ["ppo", "ppo_sde", "sac", "td3"])
def test_every_runner_agrees_with_sb3_predict(algo, observations, tmp_path):
    folder = save_run(tmp_path / "run", algo, observations)
    bundle = tmp_path / "bundle"
    export_policy(load_policy(folder), bundle, source=str(folder))
    ref = sb3_reference(folder, observations)
    # the test exercises the normaliser's clip and the output stage's saturation
    vn = VecNormalize.load(str(folder / "vecnormalize.pkl"), DummyVecEnv([make_env]))
    assert np.mean(np.abs(vn.normalize_obs(observations)) == CLIP_OBS) > 0.01
    assert np.mean(np.abs(ref) > 0.999) > 0.01 and np.mean(np.abs(ref) < 0.9) > 0.01
    for name, got in (
        ("onnxruntime", onnx_runner(bundle, observations)),
        ("numpy", numpy_runner_without_torch(bundle, observations, tmp_path)),
        ("C", c_runner(bundle, observations, tmp_path)),
    ):
        assert got.shape == ref.shape, name
        diff = float(np.max(np.abs(got - ref)))
        print(f"{algo} {name}: max |action - SB3 predict| {diff:.1e}")  # shown by pytest -s
        assert diff < TOL, (name, diff)


def test_the_bundle_describes_its_numbers(observations, tmp_path):
    folder = save_run(tmp_path / "run", "sac", observations)
    export_policy(load_policy(folder), tmp_path / "b")
    spec = json.loads((tmp_path / "b" / "policy.json").read_text())
    assert spec["network"]["sizes"] == [10, 256, 256, 2] and spec["network"]["activations"] == [
        "relu",
        "relu",
        "none",
    ]
    assert spec["network"]["output"] == "squash" and spec["features"] == []
    assert spec["input"]["names"][:4] == ["angle", "target", "temperature_right", "temperature_left"]
    assert spec["input"]["units"][:4] == ["deg", "deg", "K", "K"]
    with np.load(tmp_path / "b" / "policy.npz") as z:
        vn = VecNormalize.load(str(folder / "vecnormalize.pkl"), DummyVecEnv([make_env]))
        np.testing.assert_array_equal(z["obs_mean"], vn.obs_rms.mean)
        np.testing.assert_array_equal(z["obs_std"], np.sqrt(vn.obs_rms.var + vn.epsilon))
        assert float(z["clip_obs"]) == CLIP_OBS
    header = (tmp_path / "b" / "policy.h").read_text()
    assert "void policy_act(const float *input, float *act);" in header and "POLICY_HAS_STATE" not in header


def _episode_rows(policy, runner, scenarios):
    kw = evaluation_env_kwargs(policy.env_kwargs)
    rows, trajs = evaluate({"sb3": policy, "exported": runner}, scenarios, {"sb3": kw, "exported": kw})
    return rows, trajs


def test_episodes_of_the_exported_shipped_ppo_reproduce_its_metrics(observations, tmp_path):
    """The quick suite (6 episodes) driven by the NumPy runner: the same RMSE and energy as the SB3
    policy, to 1e-5 relative or to twice what the SB3 policy itself moves when its observations
    move by one float32 ulp, whichever is larger. Not to the last digit: the runners' float32 sums
    differ from torch's by ~1e-7 (an order that depends on the CPU's vector units), and the closed
    loop amplifies that as much as it amplifies the one-ulp move (docs/export.md)."""
    policy = load_policy(POLICIES / "ppo")
    export_policy(policy, tmp_path / "ppo")
    bundle = tmp_path / "ppo"
    ref = policy.predict(observations)[0]
    for got in (
        onnx_runner(bundle, observations),
        load_bundle(bundle).act(observations),
        c_runner(bundle, observations, tmp_path),
    ):
        assert np.max(np.abs(got - ref)) < TOL
    ctrls = {"sb3": policy, "exported": load_bundle(bundle), "sb3_1ulp": OneUlpUp(policy)}
    kw = evaluation_env_kwargs(policy.env_kwargs)
    rows, _ = evaluate(ctrls, get_suite("quick"), {k: kw for k in ctrls})
    by = {(r["controller"], r["scenario"]): r for r in rows}
    scenarios = sorted({r["scenario"] for r in rows})
    assert len(rows) == 18 and len(scenarios) == 6
    for sc in scenarios:
        for m in ("rmse_deg", "energy_J"):
            sb3, exported, moved = (by[(k, sc)][m] for k in ("sb3", "exported", "sb3_1ulp"))
            tol = max(1e-5, 2.0 * abs(moved / sb3 - 1.0))
            assert abs(exported / sb3 - 1.0) <= tol, (sc, m, exported, sb3, moved)


class _Recorder:
    """A controller that records the observations it is given."""

    def __init__(self, policy):
        self.policy, self.obs = policy, []

    def reset(self):
        self.policy.reset()

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        self.obs.append(np.asarray(observation, np.float32).reshape(-1))
        return self.policy.predict(observation, state, episode_start, deterministic)


def test_memories_are_exported_and_an_episode_matches(observations, tmp_path):
    env = make_env()
    integral = IntegralSpec.from_env(env, tau=5.0, limit=40.0)
    history = HistorySpec.from_env(env, frames=3)
    features = [(IntegralObsVecEnv, integral), (HistoryObsVecEnv, history)]
    meta = {"obs_integral": integral.to_dict(), "obs_history": history.to_dict()}
    folder = save_run(tmp_path / "run", "ppo", observations, features, meta)
    policy = load_policy(folder)
    bundle = tmp_path / "bundle"
    export_policy(policy, bundle)
    spec = json.loads((bundle / "policy.json").read_text())
    assert [f["kind"] for f in spec["features"]] == ["integral", "history"]
    assert spec["n_obs"] == 10 and spec["n_input"] == 10 + 1 + 3 * 3
    assert spec["input"]["names"][10:12] == ["integral_error_angle", "angle[t-1]"]
    runner = _Recorder(load_bundle(bundle))
    rows, trajs = _episode_rows(policy, runner, get_suite("quick", names=["ramp_swing_dist"]))
    np.testing.assert_allclose(
        trajs[("exported", "ramp_swing_dist")].action, trajs[("sb3", "ramp_swing_dist")].action, atol=1e-4
    )
    assert rows[1]["rmse_deg"] == pytest.approx(rows[0]["rmse_deg"], rel=1e-5)
    assert rows[1]["energy_J"] == pytest.approx(rows[0]["energy_J"], rel=1e-5)
    # the integral's clip is reached in the episode, so the test sees it
    episode = np.asarray(runner.obs)
    mem, reached = np.zeros((1, 1)), False
    for o in episode:
        mem = integral_step(mem, o[None, :], integral)
        reached |= bool(np.abs(mem[0, 0]) == integral.limit)
    assert reached
    # the C step function and the torch-free NumPy runner keep the same memories
    want = trajs[("exported", "ramp_swing_dist")].action.astype(np.float32)
    for got in (
        c_runner(bundle, episode, tmp_path, "step"),
        numpy_runner_without_torch(bundle, episode, tmp_path, "step"),
    ):
        assert np.max(np.abs(got - want)) < TOL


def test_shipped_integral_policy_exports_with_its_integral(observations, tmp_path):
    policy = load_policy(POLICIES / "ppo_int")
    export_policy(policy, tmp_path / "b")
    spec = json.loads((tmp_path / "b" / "policy.json").read_text())
    assert [f["kind"] for f in spec["features"]] == ["integral"]
    assert IntegralSpec.from_dict(spec["features"][0]) == policy.spec
    assert "POLICY_HAS_STATE" in (tmp_path / "b" / "policy.h").read_text()
    # one stream of 1 000 observations: the wrapped SB3 policy, the NumPy runner and C step alike
    policy.reset()
    want = np.array([policy.predict(o)[0] for o in observations])
    runner = load_bundle(tmp_path / "b")
    for got in (
        np.array([runner.step(o) for o in observations]),
        c_runner(tmp_path / "b", observations, tmp_path, "step"),
    ):
        assert np.max(np.abs(got - want)) < TOL


def test_unsupported_policies_are_refused_before_writing(observations, tmp_path, capsys):
    out = tmp_path / "out"
    with pytest.raises(UnsupportedPolicyError, match="exporting a residual policy is not supported"):
        export_policy(load_policy(POLICIES / "ppo_3d"), out)
    assert not out.exists()
    assert main([str(POLICIES / "ppo_3d"), "-o", str(out)]) == 2
    assert "error: exporting a residual policy is not supported" in capsys.readouterr().err
    venv = _vec_env()
    elu = PPO(
        "MlpPolicy",
        venv,
        policy_kwargs={"activation_fn": torch.nn.ELU},
        n_steps=64,
        batch_size=64,
        device="cpu",
    )
    (tmp_path / "elu").mkdir()
    elu.save(tmp_path / "elu" / "model.zip")
    (tmp_path / "elu" / "meta.json").write_text(json.dumps({"algo": "ppo"}))
    with pytest.raises(UnsupportedPolicyError, match="ELU layer is not supported"):
        export_policy(load_policy(tmp_path / "elu"), out)
    assert not out.exists()


def test_the_runner_rejects_bad_observations(tmp_path):
    export_policy(load_policy(POLICIES / "ppo"), tmp_path / "b")
    p = load_bundle(tmp_path / "b")
    with pytest.raises(ValueError, match=r"obs must be a numeric array \(10,\)"):
        p.step(np.zeros(9))
    with pytest.raises(ValueError, match="obs must be finite"):
        p.step(np.full(10, np.nan))
    with pytest.raises(ValueError, match="deterministic must be True"):
        p.predict(np.zeros(10), deterministic=False)
    with pytest.raises(ValueError, match="has no policy.npz"):
        load_bundle(tmp_path)
