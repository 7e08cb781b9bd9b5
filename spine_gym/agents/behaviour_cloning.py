"""Behaviour cloning from a Minari dataset of :mod:`spine_gym.agents.datasets`: a policy trained offline.

Example::

    python -m spine_gym.agents.datasets --env SmaSpine-v1 --controller pid --episodes 20
    python -m spine_gym.agents.behaviour_cloning --dataset spine_gym/SmaSpine-v1/pid-v0 --out runs/bc_pid \\
        --val-episodes 10

The student is the shipped PPO ``MlpPolicy`` of the dataset's env id (``spine_gym/agents/hyperparams/ppo.yml``),
its deterministic action (the Gaussian's mean) fitted by MSE to the dataset's actions on its
observations, normalised by their mean and variance (:func:`fit_student`, the regression the DAgger
study ``scripts/studies/distill.py`` uses too), on the (observation, action) pairs of
:func:`spine_gym.agents.minari_datasets.transitions`.
It is saved in the shipped format (``model.zip``, ``vecnormalize.pkl``, ``meta.json``:
:func:`spine_gym.agents.runtime.load_policy` reads it, ``python -m spine_gym.agents.train -i`` fine-tunes it).

With ``--val-episodes n`` the student and the dataset's controller (rebuilt from the dataset's
metadata) run the ``n`` validation episodes of the dataset's env and env kwargs (reset seeds
:data:`spine_gym.agents.runtime.VALIDATION_SEED_BASE` + i, disjoint from the dataset's): their mean RMSE and
energy go to ``<out>/bc.json`` and the console.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

import minari
import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.running_mean_std import RunningMeanStd
from stable_baselines3.common.vec_env import VecNormalize

from spine_gym.cli_conventions import module_prog

from .minari_datasets import datasets_path, load_metadata, transitions
from .runtime import SavedPolicy, build_controller, load_policy, make_env, validation_scores
from .vec_env import make_vec_env
from .zoo_config import load_hyperparams, preprocess_hyperparams

__all__ = [
    "obs_statistics",
    "mean_action",
    "fit_student",
    "action_error",
    "make_model",
    "behaviour_clone",
    "save_policy",
    "expert_of",
    "compare",
    "main",
]


def _check(name: str, ok: bool, value, what: str) -> None:
    if not ok:
        raise ValueError(f"{name} must be {what}, got {value!r}")


def _check_int(name: str, value, low: int) -> None:
    _check(name, isinstance(value, (int, np.integer)) and value >= low, value, f"an integer >= {low}")


def obs_statistics(x: np.ndarray) -> RunningMeanStd:
    """A ``RunningMeanStd`` of the rows of ``x`` (as ``VecNormalize`` keeps it)."""
    rms = RunningMeanStd(shape=x.shape[1:])
    rms.mean = x.mean(axis=0).astype(np.float64)
    rms.var = x.var(axis=0).astype(np.float64)
    rms.count = float(x.shape[0])
    return rms


def mean_action(model, obs_t: torch.Tensor) -> torch.Tensor:
    """The policy's deterministic action (the Gaussian's mean, before the clip to the space)."""
    policy = model.policy
    features = policy.extract_features(obs_t, policy.pi_features_extractor)
    return policy.action_net(policy.mlp_extractor.forward_actor(features))


def fit_student(
    model,
    x: np.ndarray,
    y: np.ndarray,
    obs_rms,
    epochs: int = 30,
    lr: float = 1e-3,
    batch_size: int = 256,
    seed: int = 0,
    clip_obs: float = 10.0,
    epsilon: float = 1e-8,
) -> list[float]:
    """Fit the student's mean action to ``y`` on ``x`` normalised by ``obs_rms`` (MSE, Adam);
    returns the mean loss per epoch. Only the actor (extractor, policy MLP, action net) moves."""
    _check_int("epochs", epochs, 1)
    _check("lr", float(lr) > 0.0, lr, "> 0")
    _check_int("batch_size", batch_size, 1)
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float32)
    if x.ndim != 2 or y.ndim != 2 or x.shape[0] != y.shape[0] or x.shape[0] == 0:
        raise ValueError(f"x and y must be non-empty (n, d) and (n, a) arrays, got {x.shape} and {y.shape}")
    xn = np.clip((x - obs_rms.mean) / np.sqrt(obs_rms.var + epsilon), -clip_obs, clip_obs).astype(np.float32)
    xt, yt = torch.as_tensor(xn), torch.as_tensor(y)
    policy = model.policy
    params = [
        *policy.pi_features_extractor.parameters(),
        *policy.mlp_extractor.policy_net.parameters(),
        *policy.action_net.parameters(),
    ]
    opt = torch.optim.Adam(params, lr=float(lr))
    gen = torch.Generator().manual_seed(int(seed))
    losses = []
    policy.set_training_mode(True)
    for _ in range(int(epochs)):
        perm = torch.randperm(xt.shape[0], generator=gen)
        total = 0.0
        for i in range(0, xt.shape[0], int(batch_size)):
            idx = perm[i : i + int(batch_size)]
            loss = torch.mean((mean_action(model, xt[idx]) - yt[idx]) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
        losses.append(total / xt.shape[0])
    policy.set_training_mode(False)
    return losses


def action_error(
    model, x: np.ndarray, y: np.ndarray, obs_rms, epsilon: float = 1e-8, clip_obs: float = 10.0
) -> float:
    """Mean squared error of the student's mean action against ``y`` on ``x``."""
    xn = (np.asarray(x, np.float64) - obs_rms.mean) / np.sqrt(obs_rms.var + epsilon)
    xn = np.clip(xn, -clip_obs, clip_obs)
    with torch.no_grad():
        a = mean_action(model, torch.as_tensor(xn.astype(np.float32))).numpy()
    return float(np.mean((a - np.asarray(y, np.float32)) ** 2))


def make_model(env_id: str, env_kwargs: dict, seed: int = 0):
    """A fresh PPO ``MlpPolicy`` with ``ppo.yml``'s settings for ``env_id``: ``(model, venv, hp)``."""
    hp, special = preprocess_hyperparams(load_hyperparams("ppo", env_id))
    venv = make_vec_env(env_id, 1, seed=seed, env_kwargs=env_kwargs, kind="dummy")
    model = PPO(special["policy"], venv, seed=seed, device="cpu", verbose=0, **hp)
    return model, venv, hp


def behaviour_clone(dataset, *, epochs: int = 30, lr: float = 1e-3, batch_size: int = 256, seed: int = 0):
    """Fit a student to ``dataset`` (a :class:`minari.MinariDataset` of :mod:`spine_gym.agents.minari_datasets`).

    Returns ``(policy, venv, hp, losses)``: the student as a :class:`spine_gym.agents.runtime.SavedPolicy`,
    its one-env training stack and hyperparameters (for :func:`save_policy`) and the loss per epoch.
    """
    meta = load_metadata(dataset)
    torch.manual_seed(seed)
    model, venv, hp = make_model(meta["env_id"], meta["env_kwargs"], seed)
    x, y = transitions(dataset)
    if x.shape[1:] != model.observation_space.shape or y.shape[1:] != model.action_space.shape:
        raise ValueError(
            f"dataset arrays {x.shape[1:]}, {y.shape[1:]} do not fit {meta['env_id']}'s spaces "
            f"{model.observation_space.shape}, {model.action_space.shape}"
        )
    obs_rms = obs_statistics(x)
    losses = fit_student(model, x, y, obs_rms, epochs=epochs, lr=lr, batch_size=batch_size, seed=seed)
    bc = {
        "dataset_id": dataset.spec.dataset_id,
        "samples": int(len(x)),
        "epochs": int(epochs),
        "lr": float(lr),
        "batch_size": int(batch_size),
        "loss_first": losses[0],
        "loss_last": losses[-1],
    }
    policy_meta = {
        "algo": "ppo",
        "env_id": meta["env_id"],
        "env_kwargs": dict(meta["env_kwargs"]),
        "seed": int(seed),
        "n_timesteps": 0,
        "behaviour_cloning": bc,
    }
    return SavedPolicy(model, obs_rms, meta=policy_meta, name="bc"), venv, hp, losses


def save_policy(folder: str | Path, policy: SavedPolicy, venv, hp: dict, command: str = "") -> Path:
    """Write ``model.zip``, ``vecnormalize.pkl``, ``meta.json`` (and ``command.txt``) to ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    policy.model.save(folder / "model.zip")
    vn = VecNormalize(venv, training=False, norm_obs=True, norm_reward=False, gamma=hp.get("gamma", 0.99))
    vn.obs_rms = policy.obs_rms
    vn.save(str(folder / "vecnormalize.pkl"))
    meta = {**policy.meta, "command": command}
    (folder / "meta.json").write_text(json.dumps(meta, indent=2))
    (folder / "command.txt").write_text(command + "\n")
    return folder


def expert_of(meta: dict):
    """The controller that recorded a dataset (its ``spine_gym`` metadata): registry entry or policy."""
    settings = meta["controller_settings"]
    if settings["kind"] == "policy":
        return load_policy(settings["path"])
    env = make_env(meta["env_kwargs"], env_id=meta["env_id"])
    return build_controller(meta["controller"], env)


def compare(policy, meta: dict, n_episodes: int) -> dict:
    """Mean RMSE and energy of ``policy`` and of the dataset's controller on ``n_episodes``
    validation episodes of the dataset's env id and env kwargs."""
    out = {"val_episodes": int(n_episodes)}
    for name, pol in (("expert", expert_of(meta)), ("bc", policy)):
        rmse, energy = validation_scores(pol, n_episodes, meta["env_kwargs"], meta["env_id"])
        out[name] = {"rmse": rmse, "energy_J": energy}
    return out


#: this command's name as ``python -m <module>``
PROG = module_prog(__spec__.name)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n")[0], allow_abbrev=False)
    p.add_argument("--dataset", required=True, help="dataset id (spine_gym/<env id>/<controller>-v<n>)")
    p.add_argument("--out", required=True, help="folder of the cloned policy")
    p.add_argument("--data-path", default=None, help="data directory (default: MINARI_DATASETS_PATH)")
    p.add_argument("--epochs", type=int, default=30, help="regression epochs (default: %(default)s)")
    p.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (default: %(default)s)")
    p.add_argument("--batch-size", type=int, default=256, help="mini-batch (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="network and shuffling seed (default: %(default)s)")
    p.add_argument("--val-episodes", type=int, default=0, help="validation episodes of both (default: none)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; exit status 0 (the report is ``<out>/bc.json``)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    torch.set_num_threads(1)
    command = f"{PROG} " + " ".join(shlex.quote(a) for a in argv)
    with datasets_path(args.data_path):
        dataset = minari.load_dataset(args.dataset)
    meta = load_metadata(dataset)
    policy, venv, hp, _ = behaviour_clone(
        dataset, epochs=args.epochs, lr=args.lr, batch_size=args.batch_size, seed=args.seed
    )
    out = save_policy(args.out, policy, venv, hp, command)
    report = {**policy.meta["behaviour_cloning"], "episodes": int(dataset.total_episodes)}
    if args.val_episodes:
        report.update(compare(policy, meta, args.val_episodes))
    (out / "bc.json").write_text(json.dumps(report, indent=2, default=np.asarray))
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
