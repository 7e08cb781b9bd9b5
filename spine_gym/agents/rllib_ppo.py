"""PPO on ``SmaSpine-v0`` with RLlib: several env runners on a Ray cluster, each stepping the
**native** numba vector env; checkpoint, restore, and a score on the fixed scenario suite.

Example (a local Ray cluster; the multi-node commands are in ``docs/scale_out.md``)::

    python -m spine_gym.agents.rllib_ppo --env-runners 2 --envs-per-runner 8 --iterations 50 --out runs/rllib/ppo
    python -m spine_gym.agents.rllib_ppo --restore runs/rllib/ppo/checkpoint --iterations 10 --out runs/rllib/ppo2
    python -m spine_gym.agents.rllib_ppo --address auto ...        # join a cluster started with `ray start`

How each runner gets the native env: RLlib's ``SingleAgentEnvRunner`` builds its env with
``gym.make_vec(config.env, num_envs=num_envs_per_env_runner,
vectorization_mode=config.gym_env_vectorize_mode, **config.env_config)``. With the env id
``"spine_gym:SmaSpine-v0"`` Gymnasium imports ``spine_gym`` inside every runner process (which
registers the id), and with ``gym_env_vectorize_mode="vector_entry_point"`` ``make_vec`` calls the
registration's ``vector_entry_point``: one :class:`~spine_gym.envs.SmaSpineVectorEnv` per runner,
with the registration's 600-step limit. Its default ``AutoresetMode.NEXT_STEP`` is the mode the
runner expects. ``vectorize="sync"`` gives RLlib's default instead (a ``SyncVectorEnv`` of
``gym.make`` single envs), the peer of ``benchmarks/bench_rllib.py``.

Hyperparameters are those of ``spine_gym/agents/hyperparams/ppo.yml`` (the SB3 entry) translated to RLlib's
names (:func:`ppo_settings`). Observations are standardised by :class:`FrozenObsNorm` with a mean and
std measured once, before training, on a seeded random-action rollout of the native env
(:func:`observation_stats`); the statistics are constructor arguments of the connector, so the
checkpoint carries them. RLlib's own ``MeanStdFilter`` is not used: with several env runners its
merged statistics drift (ray 2.60: after a few iterations the stored mean wire temperature was
116 K, below the 293 K ambient that no observation goes under).
:class:`RLlibPolicy` loads a checkpoint's module and normaliser behind SB3's ``predict``, so
:func:`spine_gym.agents.evaluation.evaluate` scores it like the shipped policies.

Needs ``ray[rllib]`` (which pins its own gymnasium, e.g. 1.2.2); install it in a separate venv
(``.ci/run`` builds ``.venv-rllib``).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from functools import partial
from pathlib import Path

import gymnasium as gym
import numpy as np
import ray
import torch
from ray.rllib.algorithms.algorithm import Algorithm
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.connectors.connector_v2 import ConnectorV2
from ray.rllib.connectors.env_to_module.observation_preprocessor import SingleAgentObservationPreprocessor
from ray.rllib.core import DEFAULT_MODULE_ID
from ray.rllib.core.columns import Columns
from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
from ray.rllib.core.rl_module.rl_module import RLModule
from ray.rllib.utils.spaces.space_utils import unsquash_action
from tqdm.auto import tqdm

from spine_gym.cli_conventions import module_prog
from spine_gym.envs import SmaSpineVectorEnv

from .evaluation import evaluate, format_tables, summarize
from .scenarios import SUITES, get_suite
from .zoo_config import ENV_ID, load_hyperparams, preprocess_hyperparams

__all__ = [
    "RLLIB_ENV",
    "VECTORIZE",
    "FrozenObsNorm",
    "RLlibPolicy",
    "build_config",
    "observation_stats",
    "ppo_settings",
    "runner_env_classes",
    "runner_placement",
    "sample_throughput",
    "main",
]

RLLIB_ENV = f"spine_gym:{ENV_ID}"  # "module:id": gymnasium imports spine_gym in each runner
VECTORIZE = {"native": gym.VectorizeMode.VECTOR_ENTRY_POINT, "sync": gym.VectorizeMode.SYNC}
CHECKPOINT = "checkpoint"
MODULE_DIR = Path("learner_group") / "learner" / "rl_module" / DEFAULT_MODULE_ID
NORM_DIR = Path("env_runner") / "env_to_module_connector"


# --------------------------------------------------------------------------- configuration
def ppo_settings() -> dict:
    """``spine_gym/agents/hyperparams/ppo.yml`` (SB3 names) as RLlib PPO settings.

    Returns ``{"training": ..., "hiddens": [...], "rollout_fragment_length": n_steps}``; the train
    batch is ``n_steps`` per sub-env, as SB3 collects ``n_steps * n_envs``.
    """
    hp, _special = preprocess_hyperparams(load_hyperparams("ppo"))
    training = {
        "gamma": hp["gamma"],
        "lambda_": hp["gae_lambda"],
        "lr": hp["learning_rate"],
        "clip_param": hp["clip_range"],
        "num_epochs": hp["n_epochs"],
        "minibatch_size": hp["batch_size"],
        "entropy_coeff": hp["ent_coef"],
        "grad_clip": hp["max_grad_norm"],
    }
    hiddens = list(hp["policy_kwargs"]["net_arch"]["pi"])
    return {"training": training, "hiddens": hiddens, "rollout_fragment_length": int(hp["n_steps"])}


class FrozenObsNorm(SingleAgentObservationPreprocessor):
    """Env-to-module connector: ``clip((obs - mean) / std, -clip, clip)`` with fixed statistics
    (SB3's ``VecNormalize`` frozen). The statistics are constructor arguments, so RLlib's
    checkpoint of the connector pipeline restores them."""

    def __init__(self, input_observation_space=None, input_action_space=None, mean=(), std=(), clip=10.0):
        self.mean = np.asarray(mean, dtype=np.float32)
        self.std = np.asarray(std, dtype=np.float32)
        self.clip = float(clip)
        if self.mean.shape != self.std.shape or self.mean.ndim != 1 or not np.all(self.std > 0):
            raise ValueError(
                f"mean and std must be 1-D of one length with std > 0, got shapes {self.mean.shape}, "
                f"{self.std.shape}"
            )
        super().__init__(input_observation_space, input_action_space)

    def recompute_output_observation_space(self, input_observation_space, input_action_space):
        return gym.spaces.Box(-self.clip, self.clip, self.mean.shape, np.float32)

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """Standardise one observation or a batch (rows)."""
        return np.clip((np.asarray(obs, np.float32) - self.mean) / self.std, -self.clip, self.clip)

    def preprocess(self, observation, episode):
        return self.normalize(observation)


def observation_stats(steps: int = 200, num_envs: int = 8, seed: int = 0, **env_kwargs) -> tuple[list, list]:
    """Mean and std of the observations of a seeded random-action rollout of the native vector env
    (``num_envs`` sub-envs, ``steps`` steps each; std floored as ``sqrt(var + 1e-8)``)."""
    if steps < 2 or num_envs < 1:
        raise ValueError(f"steps must be >= 2 and num_envs >= 1, got {steps}, {num_envs}")
    env = SmaSpineVectorEnv(num_envs, **{"parallel": False, **env_kwargs})
    env.action_space.seed(seed)
    obs, _ = env.reset(seed=seed)
    rows = [obs]
    for _ in range(steps - 1):
        obs, *_ = env.step(env.action_space.sample())
        rows.append(obs)
    env.close()
    x = np.concatenate(rows).astype(np.float64)
    return x.mean(axis=0).tolist(), np.sqrt(x.var(axis=0) + 1e-8).tolist()


def _obs_norm_connector(env=None, spaces=None, device=None, *, mean, std):
    return FrozenObsNorm(mean=mean, std=std)


def build_config(
    *,
    env_runners: int = 2,
    envs_per_runner: int = 8,
    vectorize: str = "native",
    rollout_fragment_length: int | None = None,
    seed: int | None = 0,
    env_config: dict | None = None,
    num_epochs: int | None = None,
    runner_resources: dict | None = None,
) -> PPOConfig:
    """The PPO config of this example.

    Args:
        env_runners: remote env runners (processes; on a cluster they spread over the nodes).
        envs_per_runner: sub-envs stepped together by each runner.
        vectorize: ``"native"`` (the registration's ``vector_entry_point``: one
            ``SmaSpineVectorEnv`` per runner) or ``"sync"`` (RLlib's default ``SyncVectorEnv``).
        rollout_fragment_length: steps per sub-env per sample (default: ``n_steps`` of ppo.yml).
        seed: RLlib's seed (runner k resets its vector env with ``seed + k``; None: random) and
            the seed of the normalisation rollout (0 when None).
        env_config: ``SmaSpine-v0`` keyword arguments; the native env defaults to
            ``parallel=False`` (one core per runner process is the better split when other processes share the cores).
        num_epochs: override of ppo.yml's ``n_epochs`` (e.g. 1 for a smoke run).
        runner_resources: custom Ray resources each env runner needs besides its CPU (e.g.
            ``{"runner_slot": 1}`` with ``ray start --resources '{"runner_slot": 1}'`` on the nodes
            that should host runners, one runner per slot).
    """
    if vectorize not in VECTORIZE:
        raise ValueError(f"vectorize must be one of {sorted(VECTORIZE)}, got {vectorize!r}")
    for name, value, low in (("env_runners", env_runners, 0), ("envs_per_runner", envs_per_runner, 1)):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    s = ppo_settings()
    fragment = int(rollout_fragment_length or s["rollout_fragment_length"])
    if fragment < 1:
        raise ValueError(f"rollout_fragment_length must be >= 1, got {fragment}")
    env_config = dict(env_config or {})
    mean, std = observation_stats(seed=seed or 0, **env_config)
    if vectorize == "native":
        env_config.setdefault("parallel", False)
    training = dict(s["training"])
    if num_epochs is not None:
        training["num_epochs"] = int(num_epochs)
    runner_resources = dict(runner_resources or {})
    if not all(isinstance(v, int | float) and v > 0 for v in runner_resources.values()):
        raise ValueError(f"runner_resources must map resource names to amounts > 0, got {runner_resources!r}")
    batch = fragment * envs_per_runner * max(env_runners, 1)
    training["minibatch_size"] = min(training["minibatch_size"], batch)
    return (
        PPOConfig()
        .environment(RLLIB_ENV, env_config=env_config)
        .env_runners(
            num_env_runners=env_runners,
            num_envs_per_env_runner=envs_per_runner,
            gym_env_vectorize_mode=VECTORIZE[vectorize].value,
            rollout_fragment_length=fragment,
            env_to_module_connector=partial(_obs_norm_connector, mean=mean, std=std),
            custom_resources_per_env_runner=runner_resources,
        )
        .training(train_batch_size_per_learner=batch, **training)
        .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=s["hiddens"], vf_share_layers=False))
        .debugging(seed=seed)
    )


def runner_env_classes(algo: Algorithm) -> list[str]:
    """Class name of the (unwrapped) env of every remote env runner."""
    return algo.env_runner_group.foreach_env_runner(
        lambda r: type(r.env.unwrapped).__name__, local_env_runner=False
    )


def runner_placement(algo: Algorithm) -> list[dict]:
    """Ray node id and env steps sampled so far of every remote env runner."""
    return algo.env_runner_group.foreach_env_runner(
        lambda r: {
            "node_id": ray.get_runtime_context().get_node_id(),
            "env_steps": int(r.num_env_steps_sampled_lifetime),
        },
        local_env_runner=False,
    )


def sample_throughput(algo: Algorithm, steps_per_runner: int) -> float:
    """Env steps/s of one round of sampling on all remote runners at once (policy inference + env
    step, RLlib's ``EnvRunner.sample``; counted over all runners and sub-envs)."""
    t0 = time.perf_counter()
    counts = algo.env_runner_group.foreach_env_runner(
        lambda r: sum(len(e) for e in r.sample(num_timesteps=steps_per_runner, explore=True)),
        local_env_runner=False,
    )
    return sum(counts) / (time.perf_counter() - t0)


# --------------------------------------------------------------------------- a trained policy
class RLlibPolicy:
    """An RLlib PPO checkpoint as a controller with SB3's ``predict`` (for ``spine_gym.agents.evaluate``).

    Observations go through the checkpoint's :class:`FrozenObsNorm`, the module's inference pass
    and RLlib's own ``unsquash_action`` to the action space, as an env runner does with
    ``explore=False`` (``deterministic=True``: the Gaussian's mean).
    """

    def __init__(self, module: RLModule, obs_norm: FrozenObsNorm, name: str = "rllib_ppo"):
        self.module = module
        self.obs_norm = obs_norm
        self.action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.name = name
        self._dist_cls = module.get_inference_action_dist_cls()

    @classmethod
    def from_checkpoint(cls, path: str | Path, name: str = "rllib_ppo") -> RLlibPolicy:
        path = Path(path)
        if not (path / MODULE_DIR).is_dir() or not (path / NORM_DIR).is_dir():
            raise ValueError(
                f"{path} is not a checkpoint of spine_gym.agents.rllib_ppo (no {MODULE_DIR} or {NORM_DIR})"
            )
        module = RLModule.from_checkpoint(str(path / MODULE_DIR))
        pipeline = ConnectorV2.from_checkpoint(str(path / NORM_DIR))
        norms = [c for c in pipeline.connectors if isinstance(c, FrozenObsNorm)]
        if len(norms) != 1:
            raise ValueError(f"{path}: expected one FrozenObsNorm in the env-to-module pipeline, got {norms}")
        return cls(module, norms[0], name)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        obs = np.asarray(observation, dtype=np.float32)
        if obs.ndim not in (1, 2) or not np.all(np.isfinite(obs)):
            raise ValueError(f"observation must be a finite array (d,) or (n_envs, d), got shape {obs.shape}")
        batch = self.obs_norm.normalize(obs.reshape(-1, obs.shape[-1]))
        with torch.no_grad():
            out = self.module.forward_inference({Columns.OBS: torch.from_numpy(batch)})
        dist = self._dist_cls.from_logits(out[Columns.ACTION_DIST_INPUTS])
        if deterministic:
            dist = dist.to_deterministic()
        actions = np.stack([unsquash_action(a, self.action_space) for a in dist.sample().numpy()])
        return (actions if obs.ndim == 2 else actions[0]).astype(np.float32), state

    def reset(self) -> None:
        """Stateless (feed-forward module); present for the controller interface."""


# --------------------------------------------------------------------------- CLI
#: this command's name as ``python -m <module>``
PROG = module_prog(__spec__.name)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0], allow_abbrev=False)
    p.add_argument("--env-runners", type=int, default=2, help="remote env runners (default 2)")
    p.add_argument("--envs-per-runner", type=int, default=8, help="sub-envs per runner (default 8)")
    p.add_argument("--vectorize", choices=sorted(VECTORIZE), default="native")
    p.add_argument("--iterations", type=int, default=20, help="training iterations (default 20)")
    p.add_argument(
        "--rollout-fragment-length", type=int, default=None, help="steps per sub-env per iteration"
    )
    p.add_argument("--num-epochs", type=int, default=None, help="override ppo.yml's n_epochs")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--restore", default=None, help="continue from this checkpoint folder")
    p.add_argument(
        "--suite", choices=sorted(SUITES), default="quick", help="evaluation suite (default quick)"
    )
    p.add_argument("--no-eval", action="store_true", help="skip the evaluation")
    p.add_argument(
        "--address", default=None, help="Ray cluster to join ('auto' or host:port); default: local"
    )
    p.add_argument("--num-cpus", type=int, default=None, help="CPUs of a local Ray cluster (default: all)")
    p.add_argument(
        "--runner-resources",
        type=json.loads,
        default=None,
        help="custom Ray resources per env runner, JSON (e.g. '{\"runner_slot\": 1}')",
    )
    p.add_argument("--out", default="runs/rllib/ppo", help="run folder (checkpoint, result.json)")
    return p


def _train(algo: Algorithm, iterations: int) -> list[dict]:
    history = []
    with tqdm(range(iterations), desc="rllib ppo", unit="it") as bar:
        for _ in bar:
            r = algo.train()
            runners = r.get("env_runners", {})
            row = {
                "iteration": int(r["training_iteration"]),
                "env_steps": int(runners.get("num_env_steps_sampled_lifetime", 0)),
                "episode_return_mean": float(runners.get("episode_return_mean", np.nan)),
            }
            history.append(row)
            bar.set_postfix(steps=row["env_steps"], ret=f"{row['episode_return_mean']:.1f}")
    return history


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; exit status 0 (the result is ``<out>/result.json``)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.iterations < 0:
        parser.error(f"--iterations must be >= 0, got {args.iterations}")
    if args.restore and not (Path(args.restore) / "rllib_checkpoint.json").is_file():
        parser.error(f"--restore: {args.restore} is not an RLlib checkpoint (no rllib_checkpoint.json)")
    config = None
    if not args.restore:
        try:
            config = build_config(
                env_runners=args.env_runners,
                envs_per_runner=args.envs_per_runner,
                vectorize=args.vectorize,
                rollout_fragment_length=args.rollout_fragment_length,
                seed=args.seed,
                num_epochs=args.num_epochs,
                runner_resources=args.runner_resources,
            )
        except ValueError as e:
            parser.error(str(e))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ray.init(address=args.address, num_cpus=args.num_cpus, include_dashboard=False)
    try:
        if config is None:
            algo = Algorithm.from_checkpoint(str(Path(args.restore).resolve()))
        else:
            algo = config.build_algo()
        envs = runner_env_classes(algo)
        print(f"env runners: {len(envs)}, env per runner: {sorted(set(envs))}")
        history = _train(algo, args.iterations)
        placement = runner_placement(algo)
        nodes = [{"node_id": n["NodeID"], "resources": n["Resources"]} for n in ray.nodes() if n["Alive"]]
        ckpt = algo.save_to_path(str((out / CHECKPOINT).resolve()))
        algo.stop()
    finally:
        ray.shutdown()
    result = {
        "command": shlex.join([sys.executable, "-m", __spec__.name, *(argv or sys.argv[1:])]),
        "runner_envs": envs,
        "runner_nodes": placement,
        "cluster_nodes": nodes,
        "history": history,
        "checkpoint": str(ckpt),
    }
    if not args.no_eval:
        policy = RLlibPolicy.from_checkpoint(ckpt)
        rows, _ = evaluate({"rllib_ppo": policy}, get_suite(args.suite))
        print(format_tables(summarize(rows), use_rich=False))
        result["evaluation"] = rows
    (out / "result.json").write_text(json.dumps(result, indent=2, default=float) + "\n")
    print(f"checkpoint {ckpt}; wrote {out / 'result.json'}")
    return 0


if __name__ == "__main__":
    # run the package module's main, not this __main__ copy: the classes and functions that Ray
    # ships to the runners and pickles into checkpoints must be importable as spine_gym.agents.rllib_ppo
    from spine_gym.agents.rllib_ppo import main as package_main

    sys.exit(package_main())
