"""Sampling model-predictive control (MPPI) of ``SmaSpine-v0`` on the env's own physics.

Every control period :class:`MPPIController` plans the next ``horizon`` seconds of both wire
voltages by model-predictive path integral control (Williams et al., "Information theoretic MPC",
2017): ``n_samples`` voltage sequences are drawn around the current plan, rolled out from the
current state in one parallel numba call (:func:`spine_gym.physics.planar.rollout.rollout_many`, the
env's step loop), scored, and the plan becomes their average weighted by ``exp(−cost / λ)``. The
first voltages are applied; the plan shifted by one period warm-starts the next step.

* **Smooth sequences**: the perturbations are Gaussian at knots every ``knot_period`` seconds,
  linearly interpolated in between, so the sampled voltages are smooth over a few seconds (the
  wires' thermal time constant is ~17 s; white noise per 0.1-s step would average away).
* **Cost** of a rollout, summed over the horizon h = 1 … H with the target θ*_h:
  ``w_track Σ (θ_h − θ*_h)² [deg²] + w_energy E [J] + w_temp Σ Σ_wires max(0, T − T_lim)² [K²]``
  with E the electrical energy of the rollout (the env's Joule accounting) and T_lim the env's
  temperature limit minus ``temp_margin``; a failed rollout costs :data:`FAILED_COST`.
  λ = ``temperature`` × (mean − min of the costs), so the weighting is scale-free.
* **State modes**:

  - ``"oracle"`` — **privileged**: the controller reads the env's true full state through
    ``env.snapshot()`` (phase fractions, the episode's randomised parameters) and plans with the
    episode's future targets and loads (tip-force pulses, payload). No real controller has this;
    it is the upper bound of what the plant allows with this planner.
  - ``"oracle_causal"`` — **privileged, but causal**: the true full state and the episode's
    parameters as ``"oracle"`` (``env.snapshot()``), but nothing of the future: the load over the
    horizon is the current one held constant (the tip force plus payload weight the env applies
    over the coming step, i.e. the force at the current instant, held for the whole horizon), and
    the targets come from the observed target and its preview as in ``"estimated"``. It sees the
    plant and the current load, which no real controller does, but not a push before it starts
    nor a target beyond the preview: what a controller with perfect state, parameter and force
    sensing could reach.
  - ``"estimated"`` — only the observation: a :class:`~spine_gym.controllers.estimator.PhaseEstimator`
    infers the state (phase fractions from the resistances) and identifies the ambient
    temperature and the martensite resistivity from the episode's first observation; the other
    parameters are nominal, the loads are unknown (none assumed) and the targets over the horizon
    come from the observed target and its 1-s preview (linear in between, then continued at the
    preview's rate of change). The estimator's disturbance filter (``MPPIConfig.disturbance``)
    also estimates the plant's austenite resistivity from the angle residual (and, optionally, an
    equivalent tip force, which the rollouts then carry); the observed angle minus the estimated
    one is an output disturbance held over the horizon (offset-free MPC).

The sampling, the weighting and the warm start are :class:`MPPIBase`, shared with
:class:`~spine_gym.controllers.mpc_spatial.SpatialMPPIController` (the same planner, one voltage
sequence per wire, for ``SmaSpine3D-v0`` and ``SmaSpineChain-v0``). What every planner on the env's
model does the same (one env, bound to it; a zero plan and a fresh generator each episode) is
:class:`EnvPlanner`, and the update of the plan from its scored samples :func:`mppi_update`, both
shared with :class:`~spine_gym.controllers.mpc_long.LongHorizonMPC` too.

:class:`MPPIController` is a :class:`~spine_gym.controllers.planar.PlanarController`, so it has
SB3's ``predict`` and runs in ``spine_gym.agents.evaluate`` like any baseline. It plans for one env
(observation batches of one row).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..envs.planar import PlanarConfig, planar_obs_index
from ..envs.targets_planar import ANGLE_LIMIT
from ..params import SolverOptions
from ..physics import columns as L
from ..physics.planar import columns as PL
from ..physics.planar.rollout import rollout_many, rollout_many_serial
from .base import BaseController, check_range
from .estimator import DisturbanceConfig, PhaseEstimator
from .planar import PlanarController

__all__ = [
    "MPPIConfig",
    "EnvPlanner",
    "MPPIBase",
    "MPPIController",
    "MODES",
    "PRIVILEGED_MODES",
    "FAILED_COST",
    "min_samples",
    "mppi_weights",
    "mppi_update",
    "rollout_buffers",
    "rollout_energy",
    "weighted_cost",
    "preview_targets",
]

OBS_TARGET = planar_obs_index("target_deg")  # SmaSpine-v0's observation indices, from its table
OBS_PREVIEW = planar_obs_index("target_preview")

MODES = ("oracle", "oracle_causal", "estimated")
PRIVILEGED_MODES = ("oracle", "oracle_causal")  # read the env's snapshot()
FAILED_COST = 1e12  # cost of a rollout whose model step failed
# PlanarConfig fields the plan depends on (an env to bind to must agree on them; episode length may differ)
MAX_EXTRAPOLATED_RATE = 10.0  # [deg/s] faster preview changes are taken as steps (not extrapolated)
PLAN_FIELDS = (
    "v_max",
    "control_period",
    "physics_dt",
    "target_preview",
    "temperature_limit",
    "params",
    "solver",
)


@dataclass(frozen=True)
class MPPIConfig:
    """Settings of :class:`MPPIController` (defaults: real time on 2 cores, see benchmarks/bench_mpc.py).

    With the defaults on the env's defaults the rollouts are the env's own step loop (0.1-s
    physics step, coupled scheme, the env's error control): a rollout of the true state is the
    env's trajectory bit for bit (tested).

    Attributes:
        n_samples: rollouts per control step, in [4, 100000] (the current plan, all off and full
            heating of either side are always among them).
        horizon: planning horizon [s], a multiple of the control period, in (0, 60].
        knot_period: spacing of the perturbation knots [s], in (0, 60].
        noise_std: standard deviation of the voltage perturbation [V], in (0, 100].
        temperature: λ relative to (mean − min) of the costs, in (0, 100].
        w_track: weight of the squared tracking error [1/deg²], >= 0.
        w_energy: weight of the electrical energy [1/J], >= 0.
        w_temp: weight of the squared over-temperature [1/K²], >= 0.
        temp_margin: T_lim = env temperature limit − margin [K], in [0, 100].
        plan_physics_dt: physics step of the rollouts [s]; ``None``: the env's ``physics_dt`` (the
            rollouts then reproduce the env exactly); a whole fraction of the control period.
        plan_step_c: adaptive sub-step criterion c of the rollouts (MODEL.md §6.1 b: rate × h <= c),
            in (0, 1]; ``None``: the env's (``SolverOptions.step_c``). It acts only on the
            frozen-rate scheme; the coupled scheme (the default of every env)
            chooses its sub-steps by ``tol_x``. (Before, the planning default 0.03 took a third of
            the frozen scheme's sub-steps.)
        plan_h_min: smallest adaptive sub-step of the rollouts [s], in (0, plan_physics_dt];
            ``None``: the env's (``SolverOptions.h_min``). It caps the sub-steps a rollout takes
            per physics step at ``plan_physics_dt / plan_h_min`` — and so the plan time when every
            rollout crosses a phase transformation, where the rate criterion alone asks for
            hundreds (the phase update is implicit, so coarse sub-steps stay stable).
        plan_scheme: time-stepping scheme of the rollouts (``SolverOptions.scheme``: ``"coupled"``
            or ``"frozen"``); ``None``: the env's. benchmarks/bench_mpc.py compares the plan time
            of both.
        disturbance: the estimated mode's disturbance filter
            (:class:`~spine_gym.controllers.estimator.DisturbanceConfig`: λ_A of the plant and,
            if enabled, an equivalent tip force, held over the horizon), or None (nominal λ_A,
            no load). Planar env only (the spatial estimator has neither).
        iterations: MPPI updates per control step, in [1, 100].
        parallel: run the rollouts with the ``prange`` kernel (default: its serial twin; on the
            shared 2-core machine the OpenMP threads of the parallel loop waited on each other and
            a plan took up to 10x longer, see benchmarks/bench_mpc.py).
        seed: seed of the perturbation generator.
    """

    n_samples: int = 32
    horizon: float = 3.0
    knot_period: float = 1.0
    noise_std: float = 1.0
    temperature: float = 0.02
    w_track: float = 1.0
    w_energy: float = 0.05
    w_temp: float = 10.0
    temp_margin: float = 5.0
    plan_physics_dt: float | None = 0.1
    plan_step_c: float | None = None
    plan_h_min: float | None = None
    plan_scheme: str | None = None
    disturbance: DisturbanceConfig | None = DisturbanceConfig()
    iterations: int = 1
    parallel: bool = False
    seed: int = 0

    def __post_init__(self):
        if (
            isinstance(self.n_samples, bool)
            or not isinstance(self.n_samples, int)
            or not 4 <= self.n_samples <= 100_000
        ):
            raise ValueError(f"n_samples must be an integer in [4, 100000], got {self.n_samples!r}")
        if (
            isinstance(self.iterations, bool)
            or not isinstance(self.iterations, int)
            or not 1 <= self.iterations <= 100
        ):
            raise ValueError(f"iterations must be an integer in [1, 100], got {self.iterations!r}")
        check_range("horizon", self.horizon, 0.0, 60.0, lo_open=True)
        check_range("knot_period", self.knot_period, 0.0, 60.0, lo_open=True)
        check_range("noise_std", self.noise_std, 0.0, 100.0, lo_open=True)
        check_range("temperature", self.temperature, 0.0, 100.0, lo_open=True)
        for name in ("w_track", "w_energy", "w_temp"):
            check_range(name, getattr(self, name), 0.0, 1e9)
        check_range("temp_margin", self.temp_margin, 0.0, 100.0)
        if self.plan_physics_dt is not None:
            check_range("plan_physics_dt", self.plan_physics_dt, 0.0, 10.0, lo_open=True)
        if self.plan_step_c is not None:
            check_range("plan_step_c", self.plan_step_c, 0.0, 1.0, lo_open=True)
        if self.plan_h_min is not None:
            hi = 10.0 if self.plan_physics_dt is None else self.plan_physics_dt
            check_range("plan_h_min", self.plan_h_min, 0.0, hi, lo_open=True)
        if self.disturbance is not None and not isinstance(self.disturbance, DisturbanceConfig):
            raise ValueError(
                f"disturbance must be a DisturbanceConfig or None, got {type(self.disturbance).__name__}"
            )
        if self.plan_scheme is not None and self.plan_scheme not in L.SCHEMES:
            raise ValueError(
                f"plan_scheme must be None or one of {sorted(L.SCHEMES)}, got {self.plan_scheme!r}"
            )

    def plan_solver(self, solver: SolverOptions) -> SolverOptions:
        """The env's solver options with the rollouts' sub-step settings applied."""
        changes = {}
        if self.plan_step_c is not None:
            changes["step_c"] = float(self.plan_step_c)
        if self.plan_h_min is not None:
            changes["h_min"] = float(self.plan_h_min)
        if self.plan_scheme is not None:
            changes["scheme"] = self.plan_scheme
        return solver.replace(**changes) if changes else solver


def min_samples(extremes: np.ndarray) -> int:
    """Smallest ``n_samples`` of a spine whose (E, W) full-drive patterns ``extremes`` are always
    sampled (with the plan and all off)."""
    return int(extremes.shape[0]) + 2


def _whole(name: str, value: float, unit: float) -> int:
    n = int(round(value / unit))
    if n < 1 or abs(n * unit - value) > 1e-9 * max(value, 1.0):
        raise ValueError(f"{name} must be a whole multiple of {unit:g} s, got {value!r}")
    return n


def preview_targets(
    target: np.ndarray,
    preview: np.ndarray,
    last_preview: np.ndarray | None,
    preview_steps: int,
    rate_limit: float,
    steps: np.ndarray,
    dt: float,
) -> np.ndarray:
    """(len(steps), d) targets ``steps`` control periods ahead, from the observation alone.

    Linear from the current target to the preview (``preview_steps`` ahead), then continued
    with the preview's own rate of change (its difference from ``last_preview``, the previous
    period's, over ``dt``) if that is at most ``rate_limit`` (a ramp, a sine or a circle; a jump
    of the preview is a step, which is then held; no previous preview: held).
    """
    p_steps = max(preview_steps, 1)
    steps = np.asarray(steps, dtype=np.float64)[:, None]
    rate = np.zeros_like(preview) if last_preview is None else (preview - last_preview) / dt
    if np.linalg.norm(rate) > rate_limit:
        rate = np.zeros_like(preview)
    ahead = np.maximum(steps - p_steps, 0) * dt
    return target + np.minimum(steps / p_steps, 1.0) * (preview - target) + rate * ahead


def mppi_weights(cost: np.ndarray, temperature: float, *, robust: bool = False) -> np.ndarray:
    """(N,) MPPI weights of the costs: ``exp(−(cost − min) / λ)`` normalised, with λ =
    ``temperature`` × (mean − min) of the costs (scale-free), or × (median − min) if ``robust``
    (a few samples far worse than the rest, such as full drive, then do not flatten the weights)."""
    best = cost.min()
    lam = temperature * max((np.median(cost) if robust else cost.mean()) - best, 1e-9)
    w = np.exp(-(cost - best) / lam)
    return w / w.sum()


def mppi_update(
    volts: np.ndarray, cost: np.ndarray, temperature: float, *, robust: bool = False
) -> tuple[np.ndarray, int]:
    """One MPPI update from the sampled sequences ``volts`` (N, H, W) and their costs (N,): the new
    plan (H, W), the samples' average weighted by :func:`mppi_weights` (``temperature``,
    ``robust`` as there), and the index of the least-cost sample."""
    w = mppi_weights(cost, temperature, robust=robust)
    return np.einsum("n,nhc->hc", w, volts), int(np.argmin(cost))


def rollout_buffers(n: int, h: int, n_seg: int) -> tuple[np.ndarray, ...]:
    """The out arrays of ``n`` planar rollouts of ``h`` steps (``physics.planar.rollout``): state
    scratch (n, S), angle (n, h), temperatures and Joule heats (n, h, 2), statuses (n,)."""
    return (
        np.empty((n, PL.state_size(n_seg))),
        np.empty((n, h)),
        np.empty((n, h, 2)),
        np.empty((n, h, 2)),
        np.empty(n, dtype=np.int64),
    )


def rollout_energy(joule_end: np.ndarray, state0: np.ndarray, side_volume: float) -> np.ndarray:
    """(N,) electrical energy [J] of planar rollouts from ``state0`` whose accumulated Joule heats
    per unit volume at their ends are ``joule_end`` (N, 2), ``side_volume`` [m³] the wires of one side."""
    q0 = np.array([state0[PL.X_QJR], state0[PL.X_QJL]])
    return np.sum(joule_end - q0[None, :], axis=1) * side_volume


def weighted_cost(settings, track, energy, heat, status) -> np.ndarray:
    """(N,) costs ``w_track · track + w_energy · energy + w_temp · heat`` (weights of ``settings``),
    :data:`FAILED_COST` where the rollout's status is not OK."""
    s = settings
    cost = s.w_track * track + s.w_energy * energy + s.w_temp * heat
    return np.where(status == L.OK, cost, FAILED_COST)


class EnvPlanner(BaseController):
    """What a sampling planner on the env's own model does the same on every spine: it plans for
    one env, binds to it (the privileged modes read its state), and starts each episode with a zero
    plan, a fresh generator (``settings.seed``) and a fresh estimator.

    A subclass sets ``settings`` (with a ``seed``), ``mode``, ``plan_shape`` (the shape of its
    plan), ``env_config`` (the env configuration it plans for) and ``estimator`` (or None) before
    its first :meth:`reset`.
    """

    plan_fields: tuple = PLAN_FIELDS  # configuration fields an env to bind to must agree on

    def bind(self, env) -> None:
        """Plan on ``env`` (the privileged modes read its state each step; ``spine_gym.agents.runtime.run_episode``
        binds each episode's env); ValueError if its configuration is of another type or differs
        in a field of :attr:`plan_fields`."""
        env = getattr(env, "unwrapped", env)
        cfg = getattr(env, "config", None)
        if type(cfg) is not type(self.env_config) or any(
            getattr(cfg, f) != getattr(self.env_config, f) for f in self.plan_fields
        ):
            raise ValueError(
                f"env.config differs from the config this controller was built for in {self.plan_fields}"
            )
        if not hasattr(env, "snapshot"):
            raise ValueError(f"env must have snapshot() (a spine_gym env), got {type(env).__name__}")
        self.env = env

    def reset(self) -> None:
        """New episode: zero plan, fresh generator and estimator."""
        super().reset()
        self.plan = np.zeros(self.plan_shape)
        self.rng = np.random.default_rng(self.settings.seed)
        self.last_cost = math.nan
        self._last_preview = None
        if self.estimator is not None:
            self.estimator.reset()

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """SB3 ``predict`` for one env (observation ``(d,)`` or ``(1, d)``); ``state`` is unused."""
        obs, _ = self._check_obs(observation)
        if obs.shape[0] != 1:
            raise ValueError(
                f"{type(self).__name__} plans for one env: observation batch must have 1 row, "
                f"got {obs.shape[0]}"
            )
        if episode_start is not None and bool(np.asarray(episode_start).reshape(-1)[0]):
            self.reset()
        action, _ = super().predict(observation, None, None, deterministic)
        return action, None

    def _oracle_env(self):
        if self.env is None:
            raise ValueError(
                f"{self.mode} mode needs the env: {type(self).__name__}(..., {self.mode!r}, env=env) "
                "or bind(env)"
            )
        return self.env

    def _oracle_snapshot(self, *names: str):
        """The bound env's ``snapshot()`` and writable copies of its arrays ``names`` (the ones the
        rollout kernels take). A snapshot's arrays are read-only, and numba compiles a kernel once per
        argument type, read-only arrays included: passed as they are, they would make the privileged
        modes compile every rollout kernel a second time next to the estimated mode's writable arrays."""
        snap = self._oracle_env().snapshot()
        return snap, tuple(np.array(snap.arrays[name]) for name in names)

    def config(self) -> dict:
        return {"mode": self.mode, **vars(self.settings), "temperature_limit": self.temperature_limit}


class MPPIBase(EnvPlanner):
    """What MPPI does the same on every spine: sampling, weighting, warm start (module docstring).

    A subclass builds the planning problem of one control step from the observation
    (:meth:`_problem`, a tuple) and scores the sampled voltage sequences on it (:meth:`_score`:
    (N, H, W) volts -> (N,) costs). Voltages are seed-equivalent volts in [0, ``v_max``] per wire
    group (a chain's shorter wires get them scaled by the subclass); the plan is (H, W).

    Args:
        settings: :class:`MPPIConfig`.
        mode: one of :data:`MODES`.
        n_wires: wire groups W (voltage sequences per wire).
        control_period, physics_dt: the env's [s] (the rollouts' step is ``plan_physics_dt``).
        extremes: (E, W) 0/1 masks of wires driven at ``v_max`` over the whole horizon, each
            always sampled (default: every wire alone).
        v_max, temperature_limit: :class:`BaseController` (full scale, guard).
    """

    name = "mpc"

    def __init__(
        self,
        settings: MPPIConfig | None,
        mode: str,
        n_wires: int,
        control_period: float,
        physics_dt: float,
        extremes: np.ndarray | None = None,
        **kwargs,
    ):
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        settings = MPPIConfig() if settings is None else settings
        if not isinstance(settings, MPPIConfig):
            raise ValueError(f"settings must be an MPPIConfig, got {type(settings).__name__}")
        extremes = np.eye(n_wires) if extremes is None else np.asarray(extremes, dtype=np.float64)
        if settings.n_samples < min_samples(extremes):
            raise ValueError(
                f"n_samples must be >= {extremes.shape[0] + 2} for this spine (the plan, all off and "
                f"{extremes.shape[0]} full-drive patterns are always sampled), got {settings.n_samples}"
            )
        self._extremes = extremes
        super().__init__(dt=control_period, **kwargs)
        self.mode = mode
        self.settings = s = settings
        self.name = f"mpc_{mode}"
        self.n_wires = int(n_wires)
        self.horizon_steps = _whole("horizon", s.horizon, control_period)
        self.plan_shape = (self.horizon_steps, self.n_wires)
        self.plan_dt = physics_dt if s.plan_physics_dt is None else float(s.plan_physics_dt)
        self.plan_sub = _whole("control_period (with plan_physics_dt)", control_period, self.plan_dt)
        if s.plan_h_min is not None and s.plan_h_min > self.plan_dt:
            raise ValueError(
                f"plan_h_min must be in (0, {self.plan_dt:g}] s (the rollouts' physics step), "
                f"got {s.plan_h_min!r}"
            )
        knot_steps = max(1, int(round(s.knot_period / control_period)))
        n_knots = math.ceil((self.horizon_steps - 1) / knot_steps) + 1
        # (H, n_knots) linear interpolation from knots to control steps
        pos = np.arange(self.horizon_steps) / knot_steps
        self._interp = np.maximum(0.0, 1.0 - np.abs(pos[:, None] - np.arange(n_knots)[None, :]))
        self._n_knots = n_knots
        self.env = None
        self.env_config = None  # the subclass's env configuration
        self.estimator = None  # the subclass's state estimator (estimated mode)

    def _volts(self, obs, mem):
        problem = self._problem(obs[0])
        for _ in range(self.settings.iterations):
            self._improve(problem)
        volts = self.plan[0].copy()
        self.plan[:-1] = self.plan[1:]  # warm start: shift, repeat the last
        return volts[None, :]

    def _snapshot_loads(self, snap, n_seg: int) -> tuple[np.ndarray, np.ndarray]:
        """Loads (H, n_seg, dim) on the top disk and resolve flags (H,) over the horizon from an env
        snapshot: the episode's future loads (``oracle``), or the load of the current step held
        for the whole horizon (``oracle_causal``: resolved at the first step if it just changed,
        as the env does, never again)."""
        a = snap.arrays
        h, k = self.horizon_steps, snap.step_index
        n_steps = a["forces"].shape[0]
        steps = np.full(h, k) if self.mode == "oracle_causal" else np.arange(k, k + h)
        idx = np.minimum(steps, n_steps - 1)
        loads = np.zeros((h, n_seg, a["forces"].shape[1]))
        loads[:, 0, :] = a["forces"][idx]
        resolve = a["resolve_plan"][idx] & (steps < n_steps)
        if self.mode == "oracle_causal":
            resolve[1:] = False
        return loads, resolve

    def _snapshot_targets(self, snap) -> np.ndarray:
        """The episode's targets over the horizon (``oracle``; (H,) or (H, d))."""
        t, k = snap.arrays["targets"], snap.step_index
        return t[np.minimum(np.arange(k + 1, k + 1 + self.horizon_steps), t.shape[0] - 1)]

    # ------------------------------------------------------------------ one MPPI update
    def _sample(self) -> np.ndarray:
        """(N, H, W) voltage sequences: the plan plus smooth noise, clipped; row 0 the plan itself,
        row 1 all off, row 2 + e the full-drive pattern e (``extremes``)."""
        s = self.settings
        n, w = s.n_samples, self.n_wires
        knots = self.rng.normal(0.0, s.noise_std, size=(n, self._n_knots, w))
        knots[0] = 0.0  # the current plan itself
        noise = np.einsum("hk,nkc->nhc", self._interp, knots)
        volts = np.clip(self.plan[None, :, :] + noise, 0.0, self.v_max)
        volts[1] = 0.0  # every wire off
        m = self._extremes.shape[0]
        volts[2 : 2 + m] = self.v_max * self._extremes[:, None, :]  # full-drive patterns
        return volts

    def _improve(self, problem) -> None:
        volts = self._sample()
        cost = self._score(volts, problem)
        self.plan, best = mppi_update(volts, cost, self.settings.temperature)
        self.last_cost = float(cost[best])

    def _cost(self, sq_err, energy, temp, status) -> np.ndarray:
        """(N,) costs from the squared tracking error (N, H), the rollouts' electrical energy (N,)
        [J], the temperatures (N, H, W) [K] and the statuses (N,)."""
        over = np.maximum(temp - self._t_lim, 0.0)
        heat = np.sum(over * over, axis=(1, 2))
        return weighted_cost(self.settings, np.sum(sq_err, axis=1), energy, heat, status)

    def _preview_targets(
        self, target: np.ndarray, preview: np.ndarray, preview_steps: int, rate_limit: float
    ):
        """(H, d) targets over the horizon from the observation alone (:func:`preview_targets` at
        control steps 1 … H)."""
        out = preview_targets(
            target, preview, self._last_preview, preview_steps, rate_limit,
            np.arange(1, self.horizon_steps + 1), self.dt,
        )  # fmt: skip
        self._last_preview = preview.copy()
        return out

    def _problem(self, obs):  # pragma: no cover - abstract
        raise NotImplementedError

    def _score(self, volts, problem) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

class MPPIController(PlanarController, MPPIBase):
    """MPPI on the env's physics (see the module docstring).

    Args:
        config: the env's :class:`~spine_gym.envs.PlanarConfig` (``env.config``).
        mode: ``"oracle"`` (privileged: needs ``env``), ``"oracle_causal"`` (privileged state and
            parameters, current load held, observed targets: needs ``env``) or ``"estimated"``.
        env: the :class:`~spine_gym.envs.SmaSpineEnv` whose state the privileged modes read
            (``snapshot()``);
            it can also be given later with :meth:`bind`.
        settings: :class:`MPPIConfig` (default settings if None).
        **kwargs: ``temperature_limit`` guard of :class:`BaseController` (``v_max`` and ``dt``
            come from ``config``).
    """

    def __init__(
        self,
        config: PlanarConfig,
        mode: str = "estimated",
        *,
        env=None,
        settings: MPPIConfig | None = None,
        **kwargs,
    ):
        if not isinstance(config, PlanarConfig):
            raise ValueError(f"config must be a PlanarConfig (env.config), got {type(config).__name__}")
        for key in ("v_max", "dt"):
            if key in kwargs:
                raise ValueError(f"{key} comes from config; do not pass it to MPPIController")
        super().__init__(
            settings, mode, 2, config.control_period, config.physics_dt, v_max=config.v_max, **kwargs
        )
        s = self.settings
        self.env_config = config
        self._kernel = rollout_many if s.parallel else rollout_many_serial
        p = config.params
        self._side_volume = p.wire_volume * p.n_w
        self._ks = s.plan_solver(config.solver).to_kernel()
        self._t_lim = config.temperature_limit - s.temp_margin
        self.estimator = (
            PhaseEstimator(config, disturbance=s.disturbance) if mode == "estimated" else None
        )
        if env is not None:
            self.bind(env)
        bufs = rollout_buffers(s.n_samples, self.horizon_steps, p.n_seg)
        self._work, self._angle, self._temp, self._joule, self._status = bufs
        self.reset()

    # ------------------------------------------------------------------ the planning problem
    def _problem(self, obs):
        """Start state, constants, loads and resolve flags, targets [deg] and angle offset [deg]."""
        h = self.horizon_steps
        if self.mode in PRIVILEGED_MODES:
            snap, (state0, kp) = self._oracle_snapshot("states", "kps")
            loads, resolve = self._snapshot_loads(snap, self.env_config.params.n_seg)
            targets = (
                self._snapshot_targets(snap)[:, 0] if self.mode == "oracle" else self._planar_targets(obs)
            )
            return state0, kp, loads, resolve, targets, 0.0, float(snap.arrays["wvol"][0])
        est = self.estimator
        state0 = est.update(obs)
        loads = np.broadcast_to(est.loads, (h, *est.loads.shape))
        resolve = np.zeros(h, dtype=np.bool_)
        targets = self._planar_targets(obs)
        return state0, est.kp, loads, resolve, targets, est.angle_offset, self._side_volume

    def _planar_targets(self, obs) -> np.ndarray:
        """(H,) targets over the horizon [deg] from the observed target and its preview
        (:meth:`MPPIBase._preview_targets`), clipped to the env's target bounds."""
        out = self._preview_targets(
            obs[OBS_TARGET : OBS_TARGET + 1],
            obs[OBS_PREVIEW : OBS_PREVIEW + 1],
            self.env_config.preview_steps,
            MAX_EXTRAPOLATED_RATE,
        )[:, 0]
        return np.clip(out, -ANGLE_LIMIT, ANGLE_LIMIT)

    def _score(self, volts, problem) -> np.ndarray:
        state0, kp, loads, resolve, targets, offset, side_volume = problem
        self._kernel(
            state0,
            kp,
            self._ks,
            np.ascontiguousarray(volts[:, :, 0]),
            np.ascontiguousarray(volts[:, :, 1]),
            np.ascontiguousarray(loads),
            np.ascontiguousarray(resolve),
            self.plan_dt,
            self.plan_sub,
            self._work,
            self._angle,
            self._temp,
            self._joule,
            self._status,
        )
        err = np.degrees(self._angle) + offset - targets[None, :]
        energy = rollout_energy(self._joule[:, -1, :], state0, side_volume)
        return self._cost(err * err, energy, self._temp, self._status)
