"""Distil a planning expert (``mpc_oracle``) into a feed-forward PPO policy by DAgger.

A study, not part of the runtime: it informed the decision not to ship a distilled policy (the
students and their PPO fine-tunes did not beat the shipped ``ppo_bud`` on the selection rule;
``docs/studies/distillation/``: the runs, their commands, the rule and the scores). Run it from the repository root; the regression it fits with is
:func:`spine_gym.agents.behaviour_cloning.fit_student`.

Example::

    python scripts/studies/distill.py --out runs/dag --iterations 4 --episodes 10 --duration 30 \\
        --obs-history 5 --w-energy 0.05

DAgger (Ross et al. 2011) with the registry's privileged MPPI (true state, parameters, future
targets and loads) as the expert and a student that sees only what a learned policy sees (the
env's observation with a 3-s target preview, optionally the frame history of
:mod:`spine_gym.agents.observations` and the error integral of :mod:`spine_gym.agents.observations`, which let it infer the
unobserved loads from how the angle answered recent actions):

1. iteration k rolls out ``episodes`` episodes of the env's own samplers (reset seeds
   ``seed_base + …``, below :data:`spine_gym.agents.runtime.VALIDATION_SEED_BASE`) from the hard-like
   training distribution :data:`spine_gym.agents.scenarios.HARD_LIKE_KWARGS` (a ``default_fraction`` of them
   from the env's default one), each step executing the expert's action with probability
   β_k = ``beta0`` × ``beta_decay``^k and the student's otherwise;
2. the expert labels every visited state (its action there; it plans on the env's true state
   through the env's snapshot API, whoever acts);
3. the student — an SB3 PPO ``MlpPolicy`` with the shipped architecture
   (``spine_gym/agents/hyperparams/ppo.yml``) — is fitted on the aggregate of all iterations by MSE between
   its deterministic action (the Gaussian's mean) and the expert's, on observations normalised by
   the aggregate's mean and variance (a ``VecNormalize``).

The student is saved in the shipped format (``model.zip``, ``vecnormalize.pkl``, ``meta.json``,
``command.txt``, ``config.yml``: :func:`spine_gym.agents.runtime.load_policy` reads it, ``python -m
spine_gym.agents.train -i <out>/model.zip`` fine-tunes it with PPO given the same ``obs_history`` /
``obs_integral`` params), after every iteration in ``<out>/iter_<k>/`` and at the end in
``<out>/``; the aggregated data set goes to ``<out>/data.npz`` (``--init-data`` starts from one).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import torch
import yaml
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize
from tqdm import tqdm

from spine_gym.agents.behaviour_cloning import fit_student, obs_statistics
from spine_gym.agents.observations import (
    HistoryObsPolicy,
    HistoryObsVecEnv,
    HistorySpec,
    IntegralObsPolicy,
    IntegralObsVecEnv,
    IntegralSpec,
)
from spine_gym.agents.runtime import (
    ORACLE_NAMES,
    VALIDATION_SEED_BASE,
    SavedPolicy,
    build_controller,
    energy_weighted_oracle,
    make_env,
    validation_scores,
)
from spine_gym.agents.scenarios import HARD_LIKE_KWARGS
from spine_gym.agents.training import yaml_safe
from spine_gym.agents.vec_env import make_vec_env
from spine_gym.agents.zoo_config import ENV_ID, load_hyperparams, preprocess_hyperparams

__all__ = [
    "STUDENT_ENV_KWARGS",
    "make_student",
    "build_expert",
    "student_controller",
    "collect_episode",
    "save_student",
    "distill",
    "main",
]

PREVIEW = 3.0  # target preview [s] of the student (the shipped policies')
# the student's training distribution as recorded in meta.json (spine_gym.agents.train -i and spine_gym.agents.selection read it)
STUDENT_ENV_KWARGS = {"target_preview": PREVIEW, **HARD_LIKE_KWARGS}
DEFAULT_SEED_BASE = 200_000  # DAgger's reset seeds: above the training runs' (0…), below validation's


class _Tap:
    """The innermost model of a student controller: records the observation the network gets
    (the env's ++ integral ++ history, un-normalised) and answers with the student's action."""

    def __init__(self, student: SavedPolicy):
        self.student = student
        self.last = None
        self.name = student.name
        self.meta = student.meta
        self.env_kwargs = student.env_kwargs

    def reset(self) -> None:
        self.last = None

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        self.last = np.asarray(observation, dtype=np.float32).copy()
        return self.student.predict(observation, state, episode_start, deterministic)


def _check(name: str, ok: bool, value, what: str) -> None:
    if not ok:
        raise ValueError(f"{name} must be {what}, got {value!r}")


def _check_int(name: str, value, low: int) -> None:
    _check(name, isinstance(value, (int, np.integer)) and value >= low, value, f"an integer >= {low}")


def _specs(obs_history: int | None, obs_integral: float | None):
    """(HistorySpec | None, IntegralSpec | None) on the student's env."""
    probe = make_env(STUDENT_ENV_KWARGS)
    hspec = None if obs_history is None else HistorySpec.from_env(probe, obs_history)
    ispec = None if obs_integral is None else IntegralSpec.from_env(probe, obs_integral)
    probe.close()
    return hspec, ispec


def make_student(obs_history: int | None = None, obs_integral: float | None = None, seed: int = 0):
    """A fresh PPO ``MlpPolicy`` student with ``ppo.yml``'s settings, on the observation space that
    ``spine_gym.agents.train`` builds with the same ``obs_history`` / ``obs_integral`` (so ``-i`` resumes it).

    Returns ``(model, venv, hp, special)``: ``venv`` the one-env training stack (for the
    ``VecNormalize`` to save), ``hp``/``special`` the hyperparameters used.
    """
    if obs_history is not None:
        _check_int("obs_history", obs_history, 1)
    if obs_integral is not None:
        _check("obs_integral", float(obs_integral) > 0.0, obs_integral, "a time constant > 0 [s] or None")
    hp_raw = load_hyperparams("ppo", ENV_ID)
    hp_raw["obs_history"] = obs_history
    hp_raw["obs_integral"] = obs_integral
    hp, special = preprocess_hyperparams(hp_raw)
    hspec, ispec = _specs(obs_history, obs_integral)
    venv = make_vec_env(ENV_ID, 1, seed=seed, env_kwargs=STUDENT_ENV_KWARGS, kind="dummy")
    if ispec is not None:  # spine_gym.agents.train's order: the integral, then the history
        venv = IntegralObsVecEnv(venv, ispec)
    if hspec is not None:
        venv = HistoryObsVecEnv(venv, hspec)
    model = PPO(special["policy"], venv, seed=seed, device="cpu", verbose=0, **hp)
    return model, venv, hp, special


def build_expert(env, name: str = "mpc_oracle", w_energy: float | None = None):
    """The registry's ``name`` for ``env``; for a privileged MPC (``mpc_oracle``,
    ``mpc_oracle_causal``) with ``w_energy`` [1/J] set, the same planner with that energy weight
    (:func:`spine_gym.agents.runtime.energy_weighted_oracle`)."""
    if w_energy is None:
        return build_controller(name, env)
    _check("w_energy", float(w_energy) >= 0.0, w_energy, "a weight >= 0 [1/J] or None")
    if name not in ORACLE_NAMES:
        raise ValueError(f"w_energy applies to the experts {ORACLE_NAMES} only, got expert {name!r}")
    return energy_weighted_oracle(env, w_energy, name)


def _saved(model, obs_rms, meta: dict) -> SavedPolicy:
    return SavedPolicy(model, obs_rms, meta=meta, name="student")


def student_controller(model, obs_rms, hspec: HistorySpec | None, ispec: IntegralSpec | None, meta=None):
    """The student as :func:`spine_gym.agents.runtime.load_policy` rebuilds it, with a :class:`_Tap` inside:
    returns ``(controller, tap)``; ``tap.last`` is the network's last (raw) input."""
    tap = _Tap(_saved(model, obs_rms, meta or {}))
    ctrl = tap
    if hspec is not None:
        ctrl = HistoryObsPolicy(ctrl, hspec, name="student")
    if ispec is not None:
        ctrl = IntegralObsPolicy(ctrl, ispec, name="student")
    return ctrl, tap


def collect_episode(env, expert, student, tap, seed: int, beta: float, rng: np.random.Generator):
    """One DAgger episode: per step the expert's action with probability ``beta``, else the
    student's; returns ``(X, Y, rmse_deg, energy_J)``, X the student's inputs at the visited states
    and Y the expert's actions there."""
    _check("beta", 0.0 <= beta <= 1.0, beta, "in [0, 1]")
    for c in (expert, student):
        if hasattr(c, "bind"):
            c.bind(env)
        if hasattr(c, "reset"):
            c.reset()
    obs, _ = env.reset(seed=seed)
    start = np.ones((1,), dtype=bool)
    shape = env.action_space.shape
    xs, ys, err, energy = [], [], [], 0.0
    while True:
        a_exp, _ = expert.predict(obs[None, :], None, start, True)
        a_stu, _ = student.predict(obs[None, :], None, start, True)
        a_exp = np.asarray(a_exp, dtype=np.float32).reshape(shape)
        xs.append(tap.last.reshape(-1))
        ys.append(a_exp)
        act = a_exp if rng.random() < beta else np.asarray(a_stu, dtype=np.float32).reshape(shape)
        start = np.zeros((1,), dtype=bool)
        obs, _, terminated, truncated, info = env.step(act)
        err.append(float(info["tracking_error_deg"]))
        energy += float(np.sum(info["energy_J"]))
        if terminated or truncated:
            break
    rmse = float(np.sqrt(np.mean(np.square(err))))
    return np.asarray(xs, np.float32), np.asarray(ys, np.float32), rmse, energy


def _validate(model, obs_rms, hspec, ispec, n: int) -> dict:
    """Mean RMSE [deg] and energy [J] of the student on ``n`` validation episodes of the default
    and the hard-like distribution (60 s, the student's preview: ``spine_gym.agents.selection``'s episodes)."""
    pol, _ = student_controller(model, obs_rms, hspec, ispec)
    out = {}
    for name, kw in (("default", {"target_preview": PREVIEW}), ("hard_like", dict(STUDENT_ENV_KWARGS))):
        out[f"val_{name}"] = validation_scores(pol, n, kw)
    return out


def save_student(folder: Path, model, venv, obs_rms, hp: dict, special: dict, meta: dict) -> Path:
    """Write the shipped layout (``spine_gym/agents/policies/ppo_bud/``) to ``folder``; returns it."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    model.save(folder / "model.zip")
    vn = VecNormalize(venv, training=False, norm_obs=True, norm_reward=False, gamma=hp.get("gamma", 0.99))
    vn.obs_rms = obs_rms
    vn.save(str(folder / "vecnormalize.pkl"))
    (folder / "meta.json").write_text(json.dumps(meta, indent=2))
    (folder / "command.txt").write_text(meta["command"] + "\n")
    config = {
        **hp,
        **special,
        "n_envs": special.get("n_envs", 8),
        "n_timesteps": 0,
        "env_kwargs": dict(STUDENT_ENV_KWARGS),
    }
    (folder / "config.yml").write_text(yaml.safe_dump({ENV_ID: yaml_safe(config)}))
    return folder


def distill(
    out: str | Path,
    *,
    iterations: int = 4,
    episodes: int = 10,
    duration: float = 30.0,
    beta0: float = 1.0,
    beta_decay: float = 0.5,
    default_fraction: float = 0.25,
    expert: str = "mpc_oracle",
    w_energy: float | None = None,
    obs_history: int | None = 5,
    obs_integral: float | None = None,
    epochs: int = 30,
    lr: float = 1e-3,
    batch_size: int = 256,
    seed: int = 0,
    seed_base: int = DEFAULT_SEED_BASE,
    val_episodes: int = 0,
    init_data: str | Path | None = None,
    command: str = "",
    log_std: float | None = None,
) -> Path:
    """Run DAgger (module docstring) and save the student to ``out``; returns ``out``."""
    _check_int("iterations", iterations, 0)
    if iterations == 0 and init_data is None:
        raise ValueError("iterations must be >= 1 without init_data (0: only fit on init_data)")
    _check("episodes", isinstance(episodes, (int, np.integer)) and episodes >= 1, episodes, "an integer >= 1")
    _check("duration", float(duration) > 0.0, duration, "> 0 [s]")
    _check("beta0", 0.0 <= float(beta0) <= 1.0, beta0, "in [0, 1]")
    _check("beta_decay", 0.0 <= float(beta_decay) <= 1.0, beta_decay, "in [0, 1]")
    _check("default_fraction", 0.0 <= float(default_fraction) <= 1.0, default_fraction, "in [0, 1]")
    _check_int("val_episodes", val_episodes, 0)
    _check(
        "seed_base",
        isinstance(seed_base, (int, np.integer))
        and 0 <= seed_base
        and seed_base + iterations * episodes <= VALIDATION_SEED_BASE,
        seed_base,
        f"an integer >= 0 with seed_base + iterations x episodes <= {VALIDATION_SEED_BASE} "
        "(the validation seeds)",
    )
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(seed)
    model, venv, hp, special = make_student(obs_history, obs_integral, seed)
    if log_std is not None:
        with torch.no_grad():
            model.policy.log_std.fill_(float(log_std))
    hspec, ispec = _specs(obs_history, obs_integral)
    params = []
    if obs_integral is not None:
        params.append(f"obs_integral:{obs_integral}")
    if obs_history is not None:
        params.append(f"obs_history:{obs_history}")
    base_meta = {
        "algo": "ppo",
        "env_id": ENV_ID,
        "env_kwargs": dict(STUDENT_ENV_KWARGS),
        "seed": int(seed),
        "n_envs": 8,
        "n_timesteps": 0,
        "command": command or "python scripts/studies/distill.py --out " + shlex.quote(str(out)),
        "resumed_from": None,
        "fine_tune_params": params,
    }
    if hspec is not None:
        base_meta["obs_history"] = hspec.to_dict()
    if ispec is not None:
        base_meta["obs_integral"] = ispec.to_dict()
    settings = {
        "expert": expert,
        "w_energy": w_energy,
        "duration_s": float(duration),
        "episodes_per_iteration": int(episodes),
        "beta0": float(beta0),
        "beta_decay": float(beta_decay),
        "default_fraction": float(default_fraction),
        "epochs": int(epochs),
        "lr": float(lr),
        "batch_size": int(batch_size),
        "seed_base": int(seed_base),
        "init_data": None if init_data is None else str(init_data),
    }
    rng = np.random.default_rng(seed)
    xs, ys, its = [], [], []
    if init_data is not None:
        d = np.load(init_data)
        xs, ys, its = [d["x"]], [d["y"]], [d["iteration"] - d["iteration"].max() - 1]
    obs_rms = None
    history = []
    meta = dict(base_meta)
    if xs:  # start from the student fitted on the earlier data
        obs_rms = obs_statistics(xs[0])
        t1 = time.time()
        losses = fit_student(
            model, xs[0], ys[0], obs_rms, epochs=epochs, lr=lr, batch_size=batch_size, seed=seed + 10_000
        )
        rec = {"iteration": -1, "samples_total": int(len(xs[0])), "fit_wall_s": round(time.time() - t1, 1),
               "loss_first": losses[0], "loss_last": losses[-1]}  # fmt: skip
        if val_episodes:
            rec.update(_validate(model, obs_rms, hspec, ispec, val_episodes))
        history.append(rec)
        tqdm.write(json.dumps(rec))
        meta = {**base_meta, "distill": {**settings, "iterations": history}}
        np.savez_compressed(out / "data.npz", x=xs[0], y=ys[0], iteration=its[0])
    envs = {
        "hard_like": make_env({**STUDENT_ENV_KWARGS, "episode_duration": float(duration)}),
        "default": make_env({"target_preview": PREVIEW, "episode_duration": float(duration)}),
    }
    experts = {k: build_expert(e, expert, w_energy) for k, e in envs.items()}
    t_start = time.time()
    for k in range(iterations):
        beta = float(beta0) * float(beta_decay) ** k
        t0, x_it, stats = time.time(), [], []
        ctrl, tap = student_controller(model, obs_rms, hspec, ispec)
        for i in tqdm(range(episodes), desc=f"DAgger {k + 1}/{iterations} (beta {beta:.2f})", unit="ep"):
            dist = "default" if rng.random() < default_fraction else "hard_like"
            ep_seed = seed_base + k * episodes + i
            x, y, r, e = collect_episode(envs[dist], experts[dist], ctrl, tap, ep_seed, beta, rng)
            xs.append(x)
            ys.append(y)
            its.append(np.full(len(x), k))
            x_it.append(len(x))
            stats.append((dist, r, e))
        t_collect = time.time() - t0
        X, Y = np.concatenate(xs), np.concatenate(ys)
        obs_rms = obs_statistics(X)
        t1 = time.time()
        losses = fit_student(model, X, Y, obs_rms, epochs=epochs, lr=lr, batch_size=batch_size, seed=seed + k)
        t_fit = time.time() - t1
        rec = {
            "iteration": k,
            "beta": beta,
            "samples_new": int(sum(x_it)),
            "samples_total": int(len(X)),
            "rollout_rmse_deg": float(np.mean([s[1] for s in stats])),
            "rollout_energy_J": float(np.mean([s[2] for s in stats])),
            "episodes_hard_like": sum(s[0] == "hard_like" for s in stats),
            "collect_wall_s": round(t_collect, 1),
            "fit_wall_s": round(t_fit, 1),
            "loss_first": losses[0],
            "loss_last": losses[-1],
        }
        if val_episodes:
            rec.update(_validate(model, obs_rms, hspec, ispec, val_episodes))
        history.append(rec)
        tqdm.write(json.dumps(rec))
        np.savez_compressed(out / "data.npz", x=X, y=Y, iteration=np.concatenate(its))
        settings["wall_s"] = round(time.time() - t_start, 1)
        meta = {**base_meta, "distill": {**settings, "iterations": history}}
        save_student(out / f"iter_{k}", model, venv, obs_rms, hp, special, meta)
    save_student(out, model, venv, obs_rms, hp, special, meta)
    for e in envs.values():
        e.close()
    return out


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python scripts/studies/distill.py", description=__doc__.split("\n")[0])
    p.add_argument(
        "--out", required=True, help="output folder (the student, per-iteration students, data.npz)"
    )
    p.add_argument(
        "--iterations", type=int, default=4, help="DAgger iterations (0: fit on --init-data only; default: 4)"
    )
    p.add_argument("--episodes", type=int, default=10, help="episodes per iteration (default: %(default)s)")
    p.add_argument("--duration", type=float, default=30.0, help="episode length [s] (default: %(default)s)")
    p.add_argument(
        "--beta0", type=float, default=1.0, help="expert share of iteration 1 (default: %(default)s)"
    )
    p.add_argument(
        "--beta-decay", type=float, default=0.5, help="beta_k = beta0 x decay^k (default: %(default)s)"
    )
    p.add_argument(
        "--default-fraction", type=float, default=0.25, help="share of episodes from the default distribution"
    )
    p.add_argument(
        "--expert", default="mpc_oracle", help="registry controller of the expert (default: %(default)s)"
    )
    p.add_argument(
        "--w-energy", type=float, default=None, help="the oracle's energy weight [1/J] (default: registry's)"
    )
    p.add_argument(
        "--obs-history", type=int, default=5, help="frames of history (0: none; default: %(default)s)"
    )
    p.add_argument(
        "--obs-integral", type=float, default=None, help="integral time constant [s] (default: none)"
    )
    p.add_argument(
        "--epochs", type=int, default=30, help="regression epochs per iteration (default: %(default)s)"
    )
    p.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (default: %(default)s)")
    p.add_argument("--batch-size", type=int, default=256, help="regression mini-batch (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="seed (network, mixing, distribution draws)")
    p.add_argument(
        "--seed-base", type=int, default=DEFAULT_SEED_BASE, help="first reset seed (default: %(default)s)"
    )
    p.add_argument(
        "--val-episodes", type=int, default=0, help="validation episodes per iteration and distribution"
    )
    p.add_argument(
        "--init-data", default=None, help="data.npz of an earlier run: fitted first, then aggregated with"
    )
    p.add_argument(
        "--log-std", type=float, default=None, help="set the saved policy's log std (default: ppo.yml's)"
    )
    return p


def main(argv: list[str] | None = None) -> Path:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    torch.set_num_threads(1)
    command = "python scripts/studies/distill.py " + " ".join(shlex.quote(a) for a in argv)
    return distill(
        args.out,
        iterations=args.iterations,
        episodes=args.episodes,
        duration=args.duration,
        beta0=args.beta0,
        beta_decay=args.beta_decay,
        default_fraction=args.default_fraction,
        expert=args.expert,
        w_energy=args.w_energy,
        obs_history=args.obs_history or None,
        obs_integral=args.obs_integral,
        epochs=args.epochs,
        lr=args.lr,
        batch_size=args.batch_size,
        seed=args.seed,
        seed_base=args.seed_base,
        val_episodes=args.val_episodes,
        init_data=args.init_data,
        command=command,
        log_std=args.log_std,
    )


if __name__ == "__main__":
    main()
