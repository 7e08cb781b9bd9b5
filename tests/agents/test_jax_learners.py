"""The JAX learners of the ``jax`` extra (SBX's CrossQ, TQC, its SAC as DroQ and under MBPO): they train, save, load and
evaluate through the CLI, their YAML entries load, and their exported policies (ONNX, NumPy, C) give
the model's own deterministic actions.

The export models are untrained (random weights, the mean head scaled up so that the tanh
saturates on some rows) with non-trivial batch-renormalisation statistics and ``VecNormalize``
statistics, saved as run folders and loaded back through :func:`spine_gym.agents.runtime.load_policy`.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from agent_cli import run_cli
from export_parity import c_runner, onnx_runner, save_model_run
from stable_baselines3.common.vec_env import DummyVecEnv

from spine_gym.agents.export import UnsupportedPolicyError, export_policy, record_observations
from spine_gym.agents.numpy_policy import load_bundle
from spine_gym.agents.runtime import load_policy, make_env
from spine_gym.agents.training import hyperparameter_keys, resolve_config
from spine_gym.agents.zoo_config import ENV_IDS, JAX_ALGOS, algo_class, load_hyperparams

TOL = 1e-5
# CrossQ's actor with random renormalisation statistics (scales up to ~4.5 per layer) carries
# activations ~100 x larger into the 30 x mean head: float32 rounding of the folded layers, measured
# 2e-5; a fold that dropped the epsilon or a layer would be off by > 1e-2
TOL_RENORM = 5e-5
ENV = "SmaSpineEasy-v2"
# a smoke run: 3-s episodes, tiny networks and batches, one gradient step per vector step
SMOKE = [
    "--env", ENV, "--env-kwargs", "episode_duration:3.0", "--eval-episodes", "1", "-v", "0",
    "-n", "256", "--n-envs", "2", "--eval-freq", "128", "--save-freq", "128", "--no-tensorboard",
    "-params", "learning_starts:64", "batch_size:32", "gradient_steps:1", "buffer_size:1000",
    "policy_kwargs:dict(net_arch=[32, 32])",
]  # fmt: skip


# --------------------------------------------------------------------------- the YAML entries
@pytest.mark.parametrize("algo", JAX_ALGOS)
def test_every_id_has_an_entry_whose_keys_the_algorithm_takes(algo):
    keys = hyperparameter_keys(algo)
    for env_id in ENV_IDS:
        entry = load_hyperparams(algo, env_id)
        assert set(entry) <= keys, (env_id, set(entry) - keys)
        cfg = resolve_config(algo, env_id)
        assert cfg.n_timesteps > 0 and cfg.n_envs >= 1 and cfg.special["normalize"] is not None
    assert any(c.__module__.startswith("sbx.") for c in algo_class(algo).__mro__)  # sbx_mbpo: SAC's subclass


def test_crossq_droq_and_sbx_sac_entries_are_what_their_names_say():
    crossq = resolve_config("crossq", ENV).hp
    assert crossq["policy_kwargs"]["net_arch"]["qf"] == [256, 256]  # the paper's 2048 is too slow on a CPU
    droq = resolve_config("droq", ENV).hp["policy_kwargs"]
    assert droq["dropout_rate"] > 0 and droq["layer_norm"] is True
    for env_id in ENV_IDS:  # small networks, several updates per call, update-to-data ratio 0.25 (chain too)
        sac = resolve_config("sbx_sac", env_id)
        assert sac.hp["policy_kwargs"] == {"net_arch": [64, 64]}, env_id
        assert sac.hp["gradient_steps"] / (sac.hp["train_freq"] * sac.n_envs) == 0.25, env_id
        assert sac.n_timesteps == 60000, env_id
    for env_id in (e for e in ENV_IDS if "Chain" not in e):  # sbx_tqc: sbx_sac's entry, TQC's critics
        assert load_hyperparams("sbx_tqc", env_id) == load_hyperparams("sbx_sac", env_id), env_id


# --------------------------------------------------------------------------- the CLI
@pytest.mark.slow
@pytest.mark.parametrize("algo", JAX_ALGOS)
def test_train_save_load_evaluate_through_the_cli(algo, tmp_path):
    run_cli("-m", "spine_gym.agents.train", "--algo", algo, "-f", str(tmp_path / "logs"), *SMOKE, timeout=400)
    run = tmp_path / "logs" / algo / f"{ENV}_1"
    for name in ("model.zip", "vecnormalize.pkl", "meta.json", "best_model.zip", "checkpoints"):
        assert (run / name).exists(), name
    policy = load_policy(run)
    assert policy.meta["algo"] == algo and type(policy.model) is algo_class(algo)
    obs = make_env({"episode_duration": 3.0}, env_id=ENV).reset(seed=0)[0]
    a1, _ = policy.predict(obs)
    a2, _ = policy.predict(obs)
    assert a1.shape == (2,) and np.all(np.abs(a1) <= 1.0) and np.array_equal(a1, a2)  # deterministic

    # a checkpoint resumes into the same run folder
    run_cli("-m", "spine_gym.agents.train", "--resume", str(run), "-n", "384", timeout=400)
    assert json.loads((run / "meta.json").read_text())["total_timesteps"] >= 384

    out = tmp_path / "eval"
    proc = run_cli(
        "-m", "spine_gym.agents.evaluate", "--suite", "quick", "--scenarios", "step_cross",
        "--baselines", "pid", "--models", f"{algo}={run}", "-o", str(out), "--plain", "--no-plots",
        timeout=400,
    )  # fmt: skip
    rows = (out / "metrics.csv").read_text().splitlines()
    assert any(r.startswith(f"{algo},") for r in rows[1:]), proc.stdout[-2000:]


@pytest.mark.slow
def test_the_benchmark_runs_a_jax_learner(tmp_path):
    out = tmp_path / "bench"
    run_cli(
        "-m", "spine_gym.agents.benchmark", "--quick", "--algos", "crossq", "--envs", ENV, "--out", str(out),
        timeout=400,
    )  # fmt: skip
    done = json.loads((out / "runs" / ENV / "crossq" / "seed_0" / "done.json").read_text())
    assert done["record"]["algo"] == "crossq" and done["record"]["steps"] >= 512
    assert "crossq" in (out / "table.md").read_text()
    assert load_policy(out / "runs" / ENV / "crossq" / "seed_0").meta["algo"] == "crossq"


# --------------------------------------------------------------------------- export
def _randomised_actor(model, rng: np.random.Generator) -> None:
    """Random renormalisation statistics and affine parameters (CrossQ), a mean head 30 x larger."""
    import jax  # imported by SBX already (spine_gym.agents.jax_algos set its threads first)

    state = model.policy.actor_state
    nested = "params" in state.params
    params = jax.tree_util.tree_map(np.array, state.params["params"] if nested else state.params)
    stats = jax.tree_util.tree_map(np.array, state.batch_stats) if hasattr(state, "batch_stats") else {}
    for name, layer in stats.items():
        layer["mean"] = rng.normal(0.0, 1.0, layer["mean"].shape).astype(np.float32)
        layer["var"] = rng.uniform(0.2, 3.0, layer["var"].shape).astype(np.float32)
        params[name]["scale"] = rng.uniform(0.5, 2.0, params[name]["scale"].shape).astype(np.float32)
        params[name]["bias"] = rng.normal(0.0, 0.5, params[name]["bias"].shape).astype(np.float32)
    head = f"Dense_{len(model.policy.actor.net_arch)}"
    params[head]["kernel"] *= 30.0
    params[head]["bias"] = rng.normal(0.0, 0.3, params[head]["bias"].shape).astype(np.float32)
    new = {"params": {"params": params} if nested else params}
    if stats:
        new["batch_stats"] = stats
    model.policy.actor_state = state.replace(**new)


def _save_run(folder, algo: str, obs: np.ndarray, policy_kwargs: dict, seed: int = 0):
    venv = DummyVecEnv([make_env])
    model = algo_class(algo)("MlpPolicy", venv, seed=seed, buffer_size=1000, policy_kwargs=policy_kwargs)
    _randomised_actor(model, np.random.default_rng(seed))
    vn = save_model_run(folder, model, venv, obs, {"algo": algo}, seed=seed + 1)
    return model, vn.normalize_obs(obs)


EXPORT_CASES = {
    "crossq": ("crossq", {"net_arch": {"pi": [64, 48], "qf": [32, 32]}}),
    "crossq_without_actor_renorm": ("crossq", {"net_arch": [64, 48], "batch_norm_actor": False}),
    "droq": ("droq", {"net_arch": [64, 48], "dropout_rate": 0.01, "layer_norm": True}),
    "sbx_tqc": ("sbx_tqc", {"net_arch": [64, 48]}),
    "sbx_mbpo": ("sbx_mbpo", {"net_arch": [64, 48]}),
}


@pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")
@pytest.mark.parametrize("case", sorted(EXPORT_CASES))
def test_exported_jax_policy_gives_the_models_actions(case, tmp_path):
    algo, policy_kwargs = EXPORT_CASES[case]
    obs = record_observations(600)
    model, normalized = _save_run(tmp_path / "run", algo, obs, policy_kwargs)
    ref, _ = model.predict(normalized, deterministic=True)  # the model's deterministic action
    policy = load_policy(tmp_path / "run")
    assert np.array_equal(policy.predict(obs)[0], ref)  # the saved model and statistics load back
    assert np.mean(np.abs(ref) > 0.999) > 0.01 and np.mean(np.abs(ref) < 0.9) > 0.01  # tanh exercised
    bundle = tmp_path / "bundle"
    export_policy(policy, bundle, source=case)
    spec = json.loads((bundle / "policy.json").read_text())
    assert spec["algo"] == {"crossq": "sbx_crossq", "droq": "sbx_sac", "sbx_tqc": "sbx_tqc", "sbx_mbpo": "sbx_sac"}[algo]
    assert spec["network"]["sizes"] == [10, 64, 48, 2] and spec["network"]["output"] == "squash"
    for name, got in (
        ("onnxruntime", onnx_runner(bundle, obs)),
        ("numpy", load_bundle(bundle).act(obs)),
        ("C", c_runner(bundle, obs, tmp_path)),
    ):
        diff = float(np.max(np.abs(got - ref)))
        print(f"{case} {name}: max |action - model| {diff:.1e}")  # shown by pytest -s
        assert diff < (TOL_RENORM if case == "crossq" else TOL), (name, diff)


def test_a_simba_actor_is_refused(tmp_path):
    from sbx.common.policies import SimbaSquashedGaussianActor

    obs = record_observations(50)
    model, _ = _save_run(tmp_path / "run", "droq", obs, {"net_arch": [16]})
    model.policy.actor = SimbaSquashedGaussianActor(net_arch=[16], action_dim=2)
    policy = load_policy(tmp_path / "run")
    policy.model.policy.actor = model.policy.actor
    with pytest.raises(UnsupportedPolicyError, match="Simba"):
        export_policy(policy, tmp_path / "bundle")
    assert not (tmp_path / "bundle").exists()
