"""Benchmark: what an SBX SAC run does inside, logged along its validation curve, on a tuning seed.

Trains ``algo`` (an SBX learner with an entropy coefficient: ``sbx_sac``, ``sbx_tqc``) on ``env_id``
with its YAML entry and the ``key=value`` overrides given, seed ``--seed`` (default 100, a tuning
seed), for ``-n`` env steps as the benchmark trains it (:func:`spine_gym.agents.benchmark_run.run_one`'s
envs, model and validation), and every ``--log-every`` env steps writes one row of ``diagnostics.csv``:

* ``ent_coef``, the actor's entropy estimate ``-log pi`` on a replay batch, and ``entropy_share``:
  the entropy bonus ``ent_coef * (-log pi)`` over the mean |reward| of the last transitions;
* ``q_mean`` (critics' mean on the batch) against ``q_reward`` (mean reward / (1 - gamma)) and
  ``q_soft`` (the same with the entropy bonus added): what the critic has learnt;
* ``sat_stoch`` / ``sat_det``: fraction of actions at |a| >= 0.99 among the actions taken and the
  deterministic policy's actions on the batch; ``a_det_mean``: the deterministic actions' mean;
* ``cut_frac``: fraction of wire-steps the driver's thermal cut-off switched off (applied volts
  below the commanded ones);
* ``norm_drift``: the largest shift of the observation normaliser's mean since the last row, in its
  standard deviations;
* ``err_deg`` / ``energy_J``: the training rollouts' mean |e| and energy per step.

    OMP_NUM_THREADS=1 python benchmarks/bench_sbx_dip.py sbx_sac SmaSpine3DEasy-v2 -n 20000 -o /tmp/dip/base

What it measured is in ``benchmarks/results/sbx_learners/README.md`` (section on the validation dip).
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import jax
import numpy as np
import yaml
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.utils import set_random_seed

from spine_gym.agents.benchmark_run import (
    RunSpec,
    ValidationCallback,
    live_policy,
    validation_env_kwargs,
    validation_means,
)
from spine_gym.agents.training import build_envs, build_model, resolve_config
from spine_gym.agents.runtime import validation_metrics
from spine_gym.envs import config_of

COLUMNS = (
    "step", "ent_coef", "neg_logp", "entropy_share", "q_mean", "q_reward", "q_soft", "sat_stoch",
    "sat_det", "a_det_mean", "cut_frac", "norm_drift", "err_deg", "energy_J",
)  # fmt: skip


class DiagnosticsCallback(BaseCallback):
    """Appends one row of :data:`COLUMNS` to ``path`` every ``every`` env steps."""

    def __init__(self, path: Path, every: int, v_max: float, error_scale: float):
        super().__init__(verbose=0)
        self.path, self.every, self.v_max, self.error_scale = Path(path), int(every), float(v_max), float(error_scale)
        self.next_log = every
        self.acc = {"sat": [], "cut": [], "err": [], "energy": [], "reward": []}
        self.last_mean = None
        self.key = jax.random.PRNGKey(0)

    def _on_training_start(self) -> None:
        with open(self.path, "w", newline="") as f:
            csv.writer(f).writerow(COLUMNS)

    def _on_step(self) -> bool:
        actions = np.asarray(self.locals["actions"])
        self.acc["sat"].append(np.mean(np.abs(actions) >= 0.99))
        commanded = (np.clip(actions, -1, 1) + 1) / 2 * self.v_max
        applied = np.array([i["voltage"] for i in self.locals["infos"]])
        self.acc["cut"].append(np.mean(applied < commanded - 1e-6))
        self.acc["err"].append(np.mean([-i["reward_tracking"] for i in self.locals["infos"]]))
        self.acc["energy"].append(np.mean([i["energy_J"] for i in self.locals["infos"]]))
        self.acc["reward"].append(np.mean(self.locals["rewards"]))
        if self.num_timesteps >= self.next_log and self.model.replay_buffer.size() > 32:
            self.next_log += self.every
            self._log()
        return True

    def _log(self) -> None:
        model = self.model
        vn = model.get_vec_normalize_env()
        batch = model.replay_buffer.sample(256, env=vn)
        obs, act = np.asarray(batch.observations), np.asarray(batch.actions)
        actor = model.policy.actor_state
        self.key, k = jax.random.split(self.key)
        dist = actor.apply_fn(actor.params, obs)
        logp = np.asarray(dist.log_prob(dist.sample(seed=k)))
        neg_logp = float(-np.mean(logp))
        a_det = np.asarray(dist.mode())
        qf = model.policy.qf_state
        q = np.asarray(qf.apply_fn(qf.params, obs, act))
        alpha = float(model.ent_coef_state.apply_fn({"params": model.ent_coef_state.params}))
        reward = float(np.mean(self.acc["reward"]))
        gamma = float(model.gamma)
        drift = float("nan")
        if vn is not None and vn.norm_obs:
            mean, std = vn.obs_rms.mean.copy(), np.sqrt(vn.obs_rms.var) + 1e-8
            if self.last_mean is not None:
                drift = float(np.max(np.abs(mean - self.last_mean) / std))
            self.last_mean = mean
        row = {
            "step": self.num_timesteps,
            "ent_coef": alpha,
            "neg_logp": neg_logp,
            "entropy_share": alpha * neg_logp / max(abs(reward), 1e-9),
            "q_mean": float(np.mean(q)),
            "q_reward": reward / (1 - gamma),
            "q_soft": (reward + gamma * alpha * neg_logp) / (1 - gamma),
            "sat_stoch": float(np.mean(self.acc["sat"])),
            "sat_det": float(np.mean(np.abs(a_det) >= 0.99)),
            "a_det_mean": float(np.mean(a_det)),
            "cut_frac": float(np.mean(self.acc["cut"])),
            "norm_drift": drift,
            "err_deg": float(np.mean(self.acc["err"])) * self.error_scale,
            "energy_J": float(np.mean(self.acc["energy"])),
        }
        self.acc = {k: [] for k in self.acc}
        with open(self.path, "a", newline="") as f:
            csv.writer(f).writerow([f"{row[c]:.6g}" for c in COLUMNS])
        print(" ".join(f"{c}={row[c]:.4g}" for c in COLUMNS), flush=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("algo")
    p.add_argument("env_id")
    p.add_argument("overrides", nargs="*", help="key=value over the YAML entry")
    p.add_argument("--seed", type=int, default=100)
    p.add_argument("-n", "--n-timesteps", type=int, default=20000)
    p.add_argument("--eval-freq", type=int, default=2500)
    p.add_argument("--log-every", type=int, default=1000)
    p.add_argument("--val-episodes", type=int, default=10)
    p.add_argument("-o", "--out", type=Path, required=True)
    a = p.parse_args()
    hp = {}
    for item in a.overrides:
        key, value = item.split("=", 1)
        hp[key] = value if key in ("policy_kwargs", "normalize") else yaml.safe_load(value)
    spec = RunSpec(a.algo, a.env_id, a.seed, a.n_timesteps, -1, a.eval_freq, a.val_episodes, hyperparams=hp)
    cfg = resolve_config(spec.algo, spec.env_id, n_timesteps=spec.n_timesteps, hyperparams=hp)
    set_random_seed(spec.seed)
    envs = build_envs(cfg, spec.seed)
    model = build_model(cfg, envs.env, spec.seed)
    meta = {"algo": spec.algo, "env_id": spec.env_id, "env_kwargs": cfg.env_kwargs, "seed": spec.seed, **envs.meta}
    val_kwargs = validation_env_kwargs({}, cfg.env_kwargs)

    def evaluate() -> dict:
        return validation_means(validation_metrics(live_policy(model, meta), spec.val_episodes, val_kwargs, spec.env_id))

    a.out.mkdir(parents=True, exist_ok=True)
    env_cfg = config_of(spec.env_id)
    diag = DiagnosticsCallback(a.out / "diagnostics.csv", a.log_every, env_cfg.v_max, env_cfg.error_scale)
    val = ValidationCallback(evaluate, a.eval_freq, a.out / "curve.csv")
    model.learn(cfg.n_timesteps, callback=CallbackList([diag, val]))
    for row in val.rows:
        print(f"val step={row['step']} rmse={row['rmse']:.2f} energy={row['energy_J']:.0f}", flush=True)


if __name__ == "__main__":
    main()
