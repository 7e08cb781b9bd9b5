"""A constrained energy budget for training (Lagrangian relaxation, dual ascent on the weight).

The env's reward has a fixed energy weight; which weight gives a policy that uses *no more energy
than the tuned PID* is only found by trial. Here the weight of the env's energy term becomes a
Lagrange multiplier λ: the env's reward with its energy term replaced,

    r = r_env − r_energy − λ · E / E_ref = r_tracking − cost_weight · cost − λ · E / E_ref

(``r_env`` the env's reward, ``r_energy`` = −energy_weight · E / E_ref and ``E`` [J] its
``info["reward_energy"]`` / ``info["energy_J"]``, ``E_ref`` the env's energy normaliser; every other
term of the env's reward, the temperature cost among them, is kept), and after every rollout λ
follows the constraint "mean episode energy ≤ budget":

    λ ← clip(λ · exp(η · (Ē / budget − 1)), λ_min, λ_max)

with Ē the mean energy of the episodes finished in the last rollouts: the last ``window`` of them,
or (``window = 0``) only those finished since the previous dual step. A long window lags: from a
random initial policy the mean stayed ~1.75 × the budget for ~20 rollouts while λ climbed to its
cap (as measured in a budgeted run), and then needs as long to come down; ``window = 0`` reacts at once. The budget is the tuned PID's
mean episode energy on the training distribution (validation reset seeds, never the evaluation
suite): :func:`spine_gym.agents.runtime.validation_scores`.

* :class:`EnergyBudgetVecEnv` — an SB3 ``VecEnvWrapper`` that adjusts the reward (sits below
  ``VecNormalize``, above ``VecMonitor``/:class:`spine_gym.agents.residual.ResidualVecEnv`).
* :class:`LagrangianCallback` — the dual update, logged as ``lagrangian/lambda`` and
  ``lagrangian/energy_ratio``.
* :class:`EnergyRelabelReplayBuffer` — the replay buffer of an off-policy learner under a budget:
  it keeps each transition's reward without its energy term and the term's energy apart, and
  samples them with the current λ (a plain buffer would replay every transition with the λ it was
  collected under).
"""

from __future__ import annotations

from collections import deque

import numpy as np
from stable_baselines3.common.buffers import ReplayBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.type_aliases import ReplayBufferSamples
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

__all__ = ["EnergyBudgetVecEnv", "EnergyRelabelReplayBuffer", "LagrangianCallback", "check_budget_args", "dual_step"]


def check_budget_args(budget_J: float, energy_ref_J: float, lam0: float, eta: float) -> None:
    """Raise ``ValueError`` naming the first argument out of range."""
    for name, v in (("energy_budget", budget_J), ("energy_ref", energy_ref_J)):
        if not np.isfinite(v) or v <= 0.0:
            raise ValueError(f"{name} must be a finite number > 0 J, got {v}")
    if not np.isfinite(lam0) or not 0.0 <= lam0 <= 100.0:
        raise ValueError(f"lagrangian_init must be in [0, 100], got {lam0}")
    if not np.isfinite(eta) or not 0.0 < eta <= 10.0:
        raise ValueError(f"lagrangian_lr must be in (0, 10], got {eta}")


def dual_step(lam: float, energy_ratio: float, eta: float, lam_range: tuple[float, float]) -> float:
    """One multiplicative dual-ascent step: ``clip(λ · exp(η · (ratio − 1)), *lam_range)``."""
    return float(np.clip(lam * np.exp(eta * (energy_ratio - 1.0)), *lam_range))


class EnergyBudgetVecEnv(VecEnvWrapper):
    """Reward = the env's reward with its energy term's weight replaced by λ (module docstring);
    records each finished episode's energy [J].

    Args:
        venv: the vector env whose infos carry ``reward_energy`` and ``energy_J`` per step.
        budget_J: the energy budget per episode [J].
        energy_ref_J: the env's energy normaliser E_ref [J] (one control period at full power).
        lam0: initial λ; ``None``: the env's own ``energy_weight`` (so the reward starts as the
            env's).
        window: how many finished episodes the mean energy Ē is taken over (>= 0; 0: those
            finished since the previous :meth:`dual_ratio`).
    """

    def __init__(
        self,
        venv: VecEnv,
        budget_J: float,
        energy_ref_J: float,
        lam0: float | None = None,
        window: int = 32,
    ):
        if lam0 is None:
            lam0 = float(venv.get_attr("config", [0])[0].energy_weight)
        check_budget_args(budget_J, energy_ref_J, lam0, 1.0)
        if isinstance(window, bool) or int(window) != window or window < 0:
            raise ValueError(f"budget_window must be an integer >= 0 (0: since the last dual step), got {window!r}")
        super().__init__(venv)
        self.budget = float(budget_J)
        self.energy_ref = float(energy_ref_J)
        self.lam = float(lam0)
        self._episode_energy = np.zeros(self.num_envs)
        self.window = int(window)
        self.finished = deque(maxlen=self.window or None)

    def reset(self) -> np.ndarray:
        self._episode_energy[:] = 0.0
        return self.venv.reset()

    def step_wait(self):
        obs, env_rewards, dones, infos = self.venv.step_wait()
        energy = np.array([float(info["energy_J"]) for info in infos])
        env_energy_term = np.array([float(info["reward_energy"]) for info in infos])
        self._episode_energy += energy
        for i in np.flatnonzero(dones):
            self.finished.append(self._episode_energy[i])
            self._episode_energy[i] = 0.0
        rewards = np.asarray(env_rewards, dtype=np.float64) - env_energy_term
        rewards -= self.lam * energy / self.energy_ref
        return obs, rewards.astype(np.float32), dones, infos

    def state_dict(self) -> dict:
        """What a checkpoint keeps to resume the dual ascent: λ, the budget and the finished-episode
        energies of the current window (the episodes under way restart on a resume)."""
        return {"lam": self.lam, "budget_J": self.budget, "window": self.window, "finished": list(self.finished)}

    def load_state_dict(self, state: dict) -> None:
        """Restore :meth:`state_dict` (λ checked against ``lagrangian_init``'s range, the budget and
        window against this env's)."""
        lam = float(state["lam"])
        check_budget_args(float(state["budget_J"]), self.energy_ref, lam, 1.0)
        if float(state["budget_J"]) != self.budget or int(state["window"]) != self.window:
            raise ValueError(
                f"the checkpoint's energy budget / window ({state['budget_J']} J, {state['window']}) differ "
                f"from this run's ({self.budget} J, {self.window})"
            )
        self.lam = lam
        self.finished.clear()
        self.finished.extend(float(e) for e in state["finished"])

    def energy_ratio(self) -> float | None:
        """Mean finished-episode energy / budget (``None`` before the first episode ends)."""
        return float(np.mean(self.finished)) / self.budget if self.finished else None

    def dual_ratio(self) -> float | None:
        """:meth:`energy_ratio` for the dual step; with ``window = 0`` it starts a new window."""
        ratio = self.energy_ratio()
        if self.window == 0:
            self.finished.clear()
        return ratio


class LagrangianCallback(BaseCallback):
    """Dual ascent on λ of an :class:`EnergyBudgetVecEnv` after each rollout (multiplicative)."""

    def __init__(
        self, budget_env: EnergyBudgetVecEnv, eta: float = 0.5, lam_range=(0.02, 20.0), verbose: int = 0
    ):
        check_budget_args(budget_env.budget, budget_env.energy_ref, budget_env.lam, eta)
        super().__init__(verbose)
        self.budget_env = budget_env
        self.eta = float(eta)
        self.lam_range = (float(lam_range[0]), float(lam_range[1]))

    def _on_training_start(self) -> None:
        self._sync_buffer()

    def _on_step(self) -> bool:
        return True

    def _sync_buffer(self) -> None:
        buffer = getattr(self.model, "replay_buffer", None)
        if isinstance(buffer, EnergyRelabelReplayBuffer):
            buffer.lam = self.budget_env.lam

    def _on_rollout_end(self) -> None:
        ratio = self.budget_env.dual_ratio()
        if ratio is None:
            return
        self.budget_env.lam = dual_step(self.budget_env.lam, ratio, self.eta, self.lam_range)
        self._sync_buffer()
        self.logger.record("lagrangian/lambda", self.budget_env.lam)
        self.logger.record("lagrangian/energy_ratio", ratio)
        if self.verbose:
            lam = self.budget_env.lam
            print(f"step {self.num_timesteps}: energy/budget {ratio:.3f}  lambda {lam:.3f}", flush=True)


class EnergyRelabelReplayBuffer(ReplayBuffer):
    """SB3's replay buffer for rewards of an :class:`EnergyBudgetVecEnv` (``r = r_rest − λ · E / E_ref``):
    it stores ``r_rest`` and ``E / E_ref`` (``E`` from ``info["energy_J"]``) and samples
    ``r_rest − λ · E / E_ref`` with the λ of now (:attr:`lam`, set by :class:`LagrangianCallback`
    after each dual step and equal to the env's while transitions are added).

    Args (beyond SB3's ``ReplayBuffer``'s):
        energy_ref: the env's energy normaliser E_ref [J] (> 0).
    """

    def __init__(self, *args, energy_ref: float = 1.0, **kwargs):
        if not np.isfinite(energy_ref) or energy_ref <= 0.0:
            raise ValueError(f"energy_ref must be a finite number > 0 J, got {energy_ref}")
        super().__init__(*args, **kwargs)
        self.energy_ref = float(energy_ref)
        self.lam = 0.0
        self.energy_terms = np.zeros((self.buffer_size, self.n_envs), dtype=np.float32)

    def add(self, obs, next_obs, action, reward, done, infos) -> None:
        terms = np.array([float(info["energy_J"]) for info in infos]) / self.energy_ref
        self.energy_terms[self.pos] = terms
        super().add(obs, next_obs, action, np.asarray(reward) + self.lam * terms, done, infos)

    def _get_samples(self, batch_inds: np.ndarray, env=None) -> ReplayBufferSamples:
        env_indices = np.random.randint(0, high=self.n_envs, size=(len(batch_inds),))
        if self.optimize_memory_usage:
            next_obs = self.observations[(batch_inds + 1) % self.buffer_size, env_indices, :]
        else:
            next_obs = self.next_observations[batch_inds, env_indices, :]
        rewards = self.rewards[batch_inds, env_indices] - self.lam * self.energy_terms[batch_inds, env_indices]
        dones = self.dones[batch_inds, env_indices] * (1 - self.timeouts[batch_inds, env_indices])
        data = (
            self._normalize_obs(self.observations[batch_inds, env_indices, :], env),
            self.actions[batch_inds, env_indices, :],
            self._normalize_obs(next_obs, env),
            dones.reshape(-1, 1),
            self._normalize_reward(rewards.reshape(-1, 1).astype(np.float32), env),
        )
        return ReplayBufferSamples(*tuple(map(self.to_torch, data)))
