"""Model-based policy optimisation (MBPO; Janner et al., NeurIPS 2019) on SBX's SAC: ``--algo sbx_mbpo``.

:class:`MBPO` is :class:`sbx.SAC` (its actor, critics and updates unchanged, so its policies save, load
and export as ``sbx_sac``'s) with

* a probabilistic ensemble dynamics model (:class:`DynamicsEnsemble`: ``n_members`` MLPs trained on the
  Gaussian negative log-likelihood, ``jax.vmap`` over the members) that predicts the change of the
  plant's observations and the reward from an observation and an action, fitted on the real replay
  buffer every ``model_train_freq`` env steps;
* short rollouts (``rollout_horizon`` steps) branched from real states of the replay buffer with the
  current policy, stored in a model buffer that keeps the last ``model_retain`` rounds;
* SAC's gradient steps on batches mixing real transitions (a fraction ``real_ratio``) and model ones
  (:class:`MixedReplayBuffer`).

The observation's parts are treated by what they are (:func:`observation_roles`, by the env's
``observation_names``): the targets and previews are exogenous — the model does not predict them, a
rollout reads them from the real trajectory it branched from (held at their last value past that
trajectory's end); the previous action is the action the rollout applied; the tracking errors are
target minus measured, recomputed. Only the plant's state (angles, rates, temperatures, resistances)
and the reward are learnt. With observations the names do not describe (observation wrappers), every
entry is learnt. The episodes end by a time limit only (truncation), so model transitions never end
an episode.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax.training.train_state import TrainState
from sbx import SAC
from stable_baselines3.common.buffers import ReplayBuffer
from stable_baselines3.common.type_aliases import ReplayBufferSamples

from .zoo_config import checked_number

# bounds of the members' log-variance (soft, as in PETS/MBPO: keeps the NLL from rewarding a collapsed variance)
MAX_LOGVAR, MIN_LOGVAR = 0.5, -10.0


# --------------------------------------------------------------------------- the observation's parts
@dataclass(frozen=True)
class ObservationRoles:
    """Index arrays into the observation: ``learned`` (the model predicts their change), ``exogenous``
    (targets and previews: from the real trajectory), ``action_obs`` / ``action_src`` (an entry that is
    the applied action ``action_src``), ``diff_obs`` / ``diff_plus`` / ``diff_minus`` (an entry that is
    one entry minus another)."""

    learned: np.ndarray
    exogenous: np.ndarray
    action_obs: np.ndarray
    action_src: np.ndarray
    diff_obs: np.ndarray
    diff_plus: np.ndarray
    diff_minus: np.ndarray

    @classmethod
    def all_learned(cls, n_obs: int) -> ObservationRoles:
        empty = np.zeros(0, dtype=np.int32)
        return cls(np.arange(n_obs, dtype=np.int32), empty, empty, empty, empty, empty, empty)


def _error_parts(name: str, names: tuple[str, ...]) -> tuple[str, str] | None:
    """(minuend, subtrahend) of a tracking-error entry: ``error_<s>`` is target minus measured,
    ``preview_error_<s>`` preview minus measured (``angle`` planar, ``bending_<s>`` otherwise)."""
    for prefix, ref in (("preview_error_", "preview"), ("error_", "target")):
        if name.startswith(prefix):
            suffix = name[len(prefix) :]
            plus = [f"{ref}_{suffix}", "target_preview" if ref == "preview" else "target"]
            minus = [suffix, f"bending_{suffix}"]
            plus = next((p for p in plus if p in names), None)
            minus = next((m for m in minus if m in names), None)
            return None if plus is None or minus is None else (plus, minus)
    return None


def observation_roles(names: tuple[str, ...] | None, n_obs: int) -> ObservationRoles:
    """The :class:`ObservationRoles` of an observation with entry ``names`` (``None``, or names that
    do not count ``n_obs`` entries: every entry learnt)."""
    if names is None or len(names) != n_obs:
        return ObservationRoles.all_learned(n_obs)
    names = tuple(names)
    learned, exo, act_obs, diff = [], [], [], []
    for i, name in enumerate(names):
        parts = _error_parts(name, names)
        if parts is not None:
            diff.append((i, names.index(parts[0]), names.index(parts[1])))
        elif name.startswith("previous_action"):
            act_obs.append(i)
        elif name.startswith(("target", "preview")):
            exo.append(i)
        else:
            learned.append(i)

    def ints(v):
        return np.asarray(v, dtype=np.int32).reshape(-1)

    d = np.asarray(diff, dtype=np.int32).reshape(-1, 3)
    return ObservationRoles(
        ints(learned), ints(exo), ints(act_obs), ints(range(len(act_obs))), d[:, 0], d[:, 1], d[:, 2]
    )


# --------------------------------------------------------------------------- the ensemble
class _Member(nn.Module):
    """One member: an MLP to the mean and (soft-bounded) log-variance of each output."""

    hidden: tuple[int, ...]
    out_dim: int

    @nn.compact
    def __call__(self, x: jax.Array) -> tuple[jax.Array, jax.Array]:
        for width in self.hidden:
            x = nn.swish(nn.Dense(width)(x))
        mean, logvar = jnp.split(nn.Dense(2 * self.out_dim)(x), 2, axis=-1)
        logvar = MAX_LOGVAR - nn.softplus(MAX_LOGVAR - logvar)
        return mean, MIN_LOGVAR + nn.softplus(logvar - MIN_LOGVAR)


def _nll(mean: jax.Array, logvar: jax.Array, target: jax.Array) -> jax.Array:
    """The Gaussian negative log-likelihood (without its constant), averaged."""
    return jnp.mean((mean - target) ** 2 * jnp.exp(-logvar) + logvar)


class DynamicsEnsemble:
    """``n_members`` probabilistic MLPs from normalised (input) to normalised (output), trained by
    :meth:`fit` on the Gaussian NLL, each on its own random minibatches; inputs and outputs are
    standardised with the statistics of the data of the latest :meth:`fit`."""

    def __init__(self, in_dim: int, out_dim: int, n_members: int, hidden: tuple[int, ...], lr: float, key):
        self.module = _Member(tuple(hidden), out_dim)
        self.n_members = n_members
        keys = jax.random.split(key, n_members)
        params = jax.vmap(self.module.init, in_axes=(0, None))(keys, jnp.zeros((1, in_dim)))
        self.state = TrainState.create(apply_fn=self.module.apply, params=params, tx=optax.adam(lr))
        self.stats = {
            "in_mean": jnp.zeros(in_dim), "in_std": jnp.ones(in_dim),
            "out_mean": jnp.zeros(out_dim), "out_std": jnp.ones(out_dim),
        }  # fmt: skip

    def set_statistics(self, x: np.ndarray, y: np.ndarray) -> None:
        """Standardise inputs and outputs by the mean and standard deviation of ``x`` and ``y``."""
        self.stats = {
            "in_mean": jnp.asarray(x.mean(0)), "in_std": jnp.asarray(x.std(0) + 1e-6),
            "out_mean": jnp.asarray(y.mean(0)), "out_std": jnp.asarray(y.std(0) + 1e-6),
        }  # fmt: skip

    def fit(self, x: np.ndarray, y: np.ndarray, steps: int, batch_size: int, rng: np.random.Generator) -> float:
        """``steps`` Adam steps of every member on minibatches of ``batch_size`` rows of (``x``, ``y``)
        (raw units); the last step's mean NLL."""
        self.set_statistics(x, y)
        idx = rng.integers(0, len(x), size=(steps, self.n_members, batch_size))
        xs = (x[idx] - np.asarray(self.stats["in_mean"])) / np.asarray(self.stats["in_std"])
        ys = (y[idx] - np.asarray(self.stats["out_mean"])) / np.asarray(self.stats["out_std"])
        self.state, loss = _fit(self.state, jnp.asarray(xs, jnp.float32), jnp.asarray(ys, jnp.float32))
        return float(loss)

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every member's mean and log-variance (raw units) on the rows ``x``: (members, rows, out) each."""
        mean, logvar = _predict(self.state.apply_fn, self.state.params, self.stats, jnp.asarray(x, jnp.float32))
        return np.asarray(mean), np.asarray(logvar)

    def predict_mean(self, x: np.ndarray) -> np.ndarray:
        """The members' mean prediction (raw units), averaged over the members."""
        return self.predict(x)[0].mean(0)


def _members(apply_fn, params, x: jax.Array):
    """Every member on the same rows ``x`` (normalised): (members, rows, out) means and log-variances."""
    return jax.vmap(apply_fn, in_axes=(0, None))(params, x)


@partial(jax.jit, static_argnums=0)
def _predict(apply_fn, params, stats, x: jax.Array):
    """Raw-unit means and log-variances of every member on raw rows ``x``."""
    mean, logvar = _members(apply_fn, params, (x - stats["in_mean"]) / stats["in_std"])
    return mean * stats["out_std"] + stats["out_mean"], logvar + 2 * jnp.log(stats["out_std"])


@jax.jit
def _fit(state: TrainState, xs: jax.Array, ys: jax.Array):
    """Adam steps over the leading axis of ``xs`` / ``ys`` (steps, members, batch, dim)."""

    def step(carry, batch):
        state, _ = carry
        x, y = batch

        def loss(params):
            mean, logvar = jax.vmap(state.apply_fn)(params, x)
            return _nll(mean, logvar, y)

        value, grads = jax.value_and_grad(loss)(state.params)
        return (state.apply_gradients(grads=grads), value), None

    (state, value), _ = jax.lax.scan(step, (state, jnp.array(0.0)), (xs, ys))
    return state, value


# --------------------------------------------------------------------------- rollouts
@partial(jax.jit, static_argnums=(0, 1))
def _rollout(model_apply, actor_apply, model_params, actor_params, stats, pi_norm, roles, bounds, obs, exo, key):
    """Branched rollouts of ``len(exo[0])`` steps from raw observations ``obs`` (rows), the policy's
    actions sampled, one random member per row and step; ``exo``: (values, valid) of the exogenous
    entries per step. Returns raw (obs, actions, next obs, rewards), each (steps, rows, ...)."""
    learned, exo_idx, act_obs, act_src, d_obs, d_plus, d_minus = roles
    low, high = bounds

    def step(carry, xs):
        obs, key = carry
        exo_values, exo_valid = xs
        key, k_pi, k_member, k_noise = jax.random.split(key, 4)
        pi_obs = jnp.clip((obs - pi_norm["mean"]) / pi_norm["std"], -pi_norm["clip"], pi_norm["clip"])
        action = actor_apply(actor_params, pi_obs).sample(seed=k_pi)
        mean, logvar = _members(model_apply, model_params, (jnp.concatenate([obs, action], -1) - stats["in_mean"]) / stats["in_std"])
        member = jax.random.randint(k_member, (obs.shape[0],), 0, mean.shape[0])
        rows = jnp.arange(obs.shape[0])
        out = mean[member, rows] + jnp.exp(0.5 * logvar[member, rows]) * jax.random.normal(k_noise, mean.shape[1:])
        out = out * stats["out_std"] + stats["out_mean"]
        nxt = obs.at[:, learned].add(out[:, :-1])
        nxt = nxt.at[:, exo_idx].set(jnp.where(exo_valid[:, None], exo_values, obs[:, exo_idx]))
        nxt = nxt.at[:, act_obs].set(low[act_src] + (action[:, act_src] + 1.0) * 0.5 * (high - low)[act_src])
        nxt = nxt.at[:, d_obs].set(nxt[:, d_plus] - nxt[:, d_minus])
        return (nxt, key), (obs, action, nxt, out[:, -1])

    _, traj = jax.lax.scan(step, (obs, key), exo)
    return traj


def exogenous_continuation(buffer: ReplayBuffer, rows: np.ndarray, envs: np.ndarray, exo: np.ndarray, horizon: int):
    """The exogenous entries ``exo`` of the next observations of the real trajectory from buffer row
    ``rows`` of env ``envs``, for each of ``horizon`` steps: (values (horizon, n, len(exo)), valid
    (horizon, n)); not valid past the trajectory's stored end or its episode's end."""
    size = buffer.buffer_size
    newest = (buffer.pos - 1 - rows) % size if buffer.full else buffer.pos - 1 - rows  # transitions after a row
    values = np.zeros((horizon, len(rows), len(exo)), dtype=np.float32)
    valid = np.zeros((horizon, len(rows)), dtype=bool)
    alive = np.ones(len(rows), dtype=bool)
    for k in range(horizon):
        at = (rows + k) % size
        alive &= newest >= k
        values[k] = buffer.next_observations[at, envs][:, exo]
        valid[k] = alive
        alive &= buffer.dones[at, envs] == 0
    return values, valid


# --------------------------------------------------------------------------- the mixed replay buffer
class MixedReplayBuffer(ReplayBuffer):
    """SB3's replay buffer of the real transitions plus a ring buffer of model transitions (raw units,
    never ending an episode); :meth:`sample` draws a fraction ``real_ratio`` of real rows (once model
    rows exist), the rest model rows, in random order."""

    def __init__(self, *args, real_ratio: float = 0.5, **kwargs):
        super().__init__(*args, **kwargs)
        self.real_ratio = real_ratio
        self.model_data: dict[str, np.ndarray] | None = None
        self.model_pos = self.model_size = 0

    def add_model(self, obs, actions, next_obs, rewards, capacity: int) -> None:
        """Append model transitions to the ring of ``capacity`` rows."""
        if self.model_data is None or len(self.model_data["obs"]) != capacity:
            self.model_data = {
                "obs": np.zeros((capacity, obs.shape[1]), np.float32),
                "next_obs": np.zeros((capacity, obs.shape[1]), np.float32),
                "actions": np.zeros((capacity, actions.shape[1]), np.float32),
                "rewards": np.zeros(capacity, np.float32),
            }
            self.model_pos = self.model_size = 0
        at = (self.model_pos + np.arange(len(obs))) % capacity
        for name, value in (("obs", obs), ("next_obs", next_obs), ("actions", actions), ("rewards", rewards)):
            self.model_data[name][at] = value
        self.model_pos = int((self.model_pos + len(obs)) % capacity)
        self.model_size = min(capacity, self.model_size + len(obs))

    def sample(self, batch_size: int, env=None) -> ReplayBufferSamples:
        n_real = batch_size if self.model_size == 0 else int(round(self.real_ratio * batch_size))
        real = super().sample(n_real, env=env) if n_real else None
        if n_real == batch_size:
            return real
        m = np.random.randint(0, self.model_size, size=batch_size - n_real)
        d = self.model_data
        model = (
            self._normalize_obs(d["obs"][m], env),
            d["actions"][m],
            self._normalize_obs(d["next_obs"][m], env),
            np.zeros((len(m), 1), np.float32),
            self._normalize_reward(d["rewards"][m].reshape(-1, 1), env),
        )
        parts = model if real is None else [np.concatenate([r.cpu().numpy(), x]) for r, x in zip(real[:5], model)]
        order = np.random.permutation(batch_size)
        return ReplayBufferSamples(*(self.to_torch(np.asarray(p, np.float32)[order]) for p in parts))


# --------------------------------------------------------------------------- the algorithm
class MBPO(SAC):
    """SBX's SAC with MBPO's model-generated transitions (the module's docstring).

    :param real_ratio: fraction of each SAC batch drawn from the real replay buffer (0-1; 1: SAC).
    :param model_train_freq: env steps between two rounds of model fitting and rollouts.
    :param model_train_steps: Adam steps of each ensemble member per round.
    :param model_batch_size: rows per member and Adam step.
    :param model_lr: the ensemble's Adam learning rate.
    :param n_members: ensemble size.
    :param model_hidden: widths of each member's hidden layers.
    :param rollout_horizon: model steps per branched rollout (1-20).
    :param rollout_batch_size: rollouts started per round (real states drawn from the replay buffer).
    :param model_retain: rounds of rollouts the model buffer keeps.
    """

    def __init__(
        self,
        policy,
        env,
        real_ratio: float = 0.5,
        model_train_freq: int = 1000,
        model_train_steps: int = 200,
        model_batch_size: int = 256,
        model_lr: float = 1e-3,
        n_members: int = 5,
        model_hidden: tuple[int, ...] = (128, 128),
        rollout_horizon: int = 1,
        rollout_batch_size: int = 2000,
        model_retain: int = 5,
        learning_rate=3e-4,
        qf_learning_rate=None,
        buffer_size: int = 1_000_000,
        learning_starts: int = 100,
        batch_size: int = 256,
        tau: float = 0.005,
        gamma: float = 0.99,
        train_freq=1,
        gradient_steps: int = 1,
        policy_delay: int = 1,
        action_noise=None,
        replay_buffer_class=None,
        replay_buffer_kwargs=None,
        n_steps: int = 1,
        ent_coef="auto",
        target_entropy="auto",
        use_sde: bool = False,
        sde_sample_freq: int = -1,
        use_sde_at_warmup: bool = False,
        stats_window_size: int = 100,
        tensorboard_log=None,
        policy_kwargs=None,
        param_resets=None,
        verbose: int = 0,
        seed=None,
        device: str = "auto",
        _init_setup_model: bool = True,
    ) -> None:
        self.mbpo = _checked_settings(
            real_ratio, model_train_freq, model_train_steps, model_batch_size, model_lr, n_members,
            model_hidden, rollout_horizon, rollout_batch_size, model_retain,
        )  # fmt: skip
        if replay_buffer_class not in (None, MixedReplayBuffer):
            raise ValueError(f"replay_buffer_class must be None for sbx_mbpo (its own MixedReplayBuffer), got {replay_buffer_class!r}")
        super().__init__(
            policy, env, learning_rate=learning_rate, qf_learning_rate=qf_learning_rate, buffer_size=buffer_size,
            learning_starts=learning_starts, batch_size=batch_size, tau=tau, gamma=gamma, train_freq=train_freq,
            gradient_steps=gradient_steps, policy_delay=policy_delay, action_noise=action_noise,
            replay_buffer_class=MixedReplayBuffer,
            replay_buffer_kwargs={**(replay_buffer_kwargs or {}), "real_ratio": self.mbpo["real_ratio"]},
            n_steps=n_steps, ent_coef=ent_coef, target_entropy=target_entropy, use_sde=use_sde,
            sde_sample_freq=sde_sample_freq, use_sde_at_warmup=use_sde_at_warmup,
            stats_window_size=stats_window_size, tensorboard_log=tensorboard_log, policy_kwargs=policy_kwargs,
            param_resets=param_resets, verbose=verbose, seed=seed, device=device, _init_setup_model=_init_setup_model,
        )  # fmt: skip

    def _setup_model(self) -> None:
        super()._setup_model()
        self._dynamics = None
        self._roles = None
        self._last_round = None
        self.model_history: list[dict] = []  # per round: env steps, NLL, error on the newest real data

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_dynamics", "_roles", "_last_round", "model_history"]

    def train(self, gradient_steps: int, batch_size: int) -> None:
        if self._last_round is None or self.num_timesteps - self._last_round >= self.mbpo["model_train_freq"]:
            self._model_round()
        super().train(gradient_steps, batch_size)

    # ---- a round: fit the ensemble, branch rollouts into the model buffer
    def _real_data(self) -> tuple[np.ndarray, ...]:
        """Every stored real transition, flattened over envs: obs, actions, next obs, rewards, row, env."""
        rb = self.replay_buffer
        n = rb.buffer_size if rb.full else rb.pos
        rows, envs = np.meshgrid(np.arange(n), np.arange(rb.n_envs), indexing="ij")
        return (
            rb.observations[:n].reshape(-1, rb.obs_shape[0]), rb.actions[:n].reshape(-1, rb.action_dim),
            rb.next_observations[:n].reshape(-1, rb.obs_shape[0]), rb.rewards[:n].reshape(-1),
            rows.reshape(-1), envs.reshape(-1),
        )  # fmt: skip

    def _model_round(self) -> None:
        obs, actions, next_obs, rewards, rows, envs = self._real_data()
        roles = self._observation_roles()
        x = np.concatenate([obs, actions], 1)
        y = np.concatenate([(next_obs - obs)[:, roles.learned], rewards[:, None]], 1)
        if self._dynamics is None:
            self.key, k = jax.random.split(self.key)
            s = self.mbpo
            self._dynamics = DynamicsEnsemble(x.shape[1], y.shape[1], s["n_members"], s["model_hidden"], s["model_lr"], k)
            fresh_error = float("nan")
        else:
            fresh_error = self._fresh_error(x, y, rows)
        nll = self._dynamics.fit(x, y, self.mbpo["model_train_steps"], self.mbpo["model_batch_size"], np.random.default_rng(int(self.num_timesteps)))
        self._rollouts(obs, rows, envs, roles)
        self._last_round = self.num_timesteps
        self.model_history.append({"step": self.num_timesteps, "nll": nll, "fresh_error": fresh_error})
        self.logger.record("model/nll", nll)
        self.logger.record("model/fresh_error", fresh_error)

    def _fresh_error(self, x: np.ndarray, y: np.ndarray, rows: np.ndarray) -> float:
        """Mean squared error of the ensemble's mean on the transitions collected since the last round,
        per output in units of that output's standard deviation (0: exact, ~1: no better than its mean)."""
        n_vec = max(1, (self.num_timesteps - self._last_round) // self.n_envs)
        newest = (self.replay_buffer.pos - 1 - rows) % self.replay_buffer.buffer_size < n_vec
        pred = self._dynamics.predict_mean(x[newest])
        return float(np.mean(((pred - y[newest]) / np.asarray(self._dynamics.stats["out_std"])) ** 2))

    def _observation_roles(self) -> ObservationRoles:
        if self._roles is None:
            try:
                names = self.env.get_attr("observation_names", indices=[0])[0]
            except (AttributeError, TypeError, NotImplementedError):
                names = None
            self._roles = observation_roles(names, int(self.observation_space.shape[0]))
        return self._roles

    def _rollouts(self, obs: np.ndarray, rows: np.ndarray, envs: np.ndarray, roles: ObservationRoles) -> None:
        s = self.mbpo
        start = np.random.randint(0, len(obs), size=s["rollout_batch_size"])
        exo = exogenous_continuation(self.replay_buffer, rows[start], envs[start], roles.exogenous, s["rollout_horizon"])
        self.key, k = jax.random.split(self.key)
        d = self._dynamics
        traj = _rollout(
            d.state.apply_fn, self.policy.actor_state.apply_fn, d.state.params, self.policy.actor_state.params,
            d.stats, self._policy_normalisation(), tuple(jnp.asarray(a) for a in _role_arrays(roles)),
            (jnp.asarray(self.action_space.low), jnp.asarray(self.action_space.high)),
            jnp.asarray(obs[start], jnp.float32), (jnp.asarray(exo[0]), jnp.asarray(exo[1])), k,
        )  # fmt: skip
        o, a, o2, r = (np.asarray(t).reshape(-1, *t.shape[2:]) for t in traj)
        capacity = s["rollout_batch_size"] * s["rollout_horizon"] * s["model_retain"]
        self.replay_buffer.add_model(o, a, o2, r, capacity)

    def _policy_normalisation(self) -> dict:
        """The observation normalisation the policy sees (VecNormalize's running statistics, or none)."""
        vn = self._vec_normalize_env
        n = self.observation_space.shape[0]
        if vn is None or not vn.norm_obs:
            return {"mean": jnp.zeros(n), "std": jnp.ones(n), "clip": jnp.inf}
        return {
            "mean": jnp.asarray(vn.obs_rms.mean, jnp.float32),
            "std": jnp.asarray(np.sqrt(vn.obs_rms.var + vn.epsilon), jnp.float32),
            "clip": jnp.float32(vn.clip_obs),
        }


def _role_arrays(r: ObservationRoles) -> tuple[np.ndarray, ...]:
    return (r.learned, r.exogenous, r.action_obs, r.action_src, r.diff_obs, r.diff_plus, r.diff_minus)


def _checked_settings(
    real_ratio, model_train_freq, model_train_steps, model_batch_size, model_lr, n_members, model_hidden,
    rollout_horizon, rollout_batch_size, model_retain,
) -> dict:  # fmt: skip
    """MBPO's settings, checked (a ValueError naming the first out of range)."""

    def integer(name, value, lo, hi=np.inf):
        v = checked_number(value, lambda x: x == int(x) and lo <= x <= hi, f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
        return int(v)

    hidden = tuple(model_hidden) if isinstance(model_hidden, (list, tuple)) else None
    if not hidden or any(not isinstance(w, int) or w < 1 for w in hidden):
        raise ValueError(f"model_hidden must be a non-empty list of positive integers, got {model_hidden!r}")
    return {
        "real_ratio": checked_number(real_ratio, lambda x: 0 <= x <= 1, f"real_ratio must be in [0, 1], got {real_ratio!r}"),
        "model_train_freq": integer("model_train_freq", model_train_freq, 1),
        "model_train_steps": integer("model_train_steps", model_train_steps, 1),
        "model_batch_size": integer("model_batch_size", model_batch_size, 1),
        "model_lr": checked_number(model_lr, lambda x: 0 < x < 1, f"model_lr must be in (0, 1), got {model_lr!r}"),
        "n_members": integer("n_members", n_members, 1, 20),
        "model_hidden": hidden,
        "rollout_horizon": integer("rollout_horizon", rollout_horizon, 1, 20),
        "rollout_batch_size": integer("rollout_batch_size", rollout_batch_size, 1),
        "model_retain": integer("model_retain", model_retain, 1),
    }
