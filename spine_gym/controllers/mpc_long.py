"""Long-horizon MPC of the planar spine: a plan over the wires' thermal time constant, in real time.

The wires heat and cool with a time constant of about 17 s (MODEL.md §8): what a voltage does to
the angle and to the wire temperature shows over tens of seconds, so a planner that looks 3 s
ahead cannot weigh the energy it spends now against the heat it will have to shed later, nor see
a wire drift towards the thermal cut-off. :class:`LongHorizonMPC` plans ``horizon`` seconds ahead
(15 s by default) and stays real time by three choices:

* **Move blocking.** The plan is piecewise constant over blocks of ``block`` seconds (1 s by
  default) fixed in time: the block that holds the current control period, then
  ``horizon / block`` whole blocks, one pair of voltages (right, left wire) each. Every control
  period the first voltages are applied and the plan is improved again; when the current block
  has run out the plan shifts by one block and its last block is repeated (the **warm start** is
  the shifted previous plan, exactly, as the blocks do not move in time). The prediction then
  covers between ``horizon`` and ``horizon + block`` seconds.
* **A coarser predictor.** The rollouts are the env's own physics
  (:func:`spine_gym.physics.planar.rollout.rollout_graded`: the same state, sub-model and adaptive
  sub-steps) with one output step per block (the remainder of the current block, then whole
  blocks; the first ``fine_steps`` control periods one by one, so the near-term error is scored
  at the control period) and the coupled scheme's error tolerance ``plan_tol_x`` (1e-3 by default, the env's
  1e-4): on 15-s rollouts from four states of a validation episode it moved the predicted angle
  by 0.3° RMS (1.5° at most) and the temperatures by 1 K at most, for less than half the
  sub-steps of the env's settings (the quasi-static tube makes a long output step exact but for the
  sub-steps' error).
* **Sampling** (MPPI, :func:`spine_gym.controllers.mpc.mppi_update`): ``n_samples`` block
  sequences are drawn, half around the plan and half around the **steady-state feedforward**
  (each block the voltage whose steady state is that block's target, on the wire that bends
  toward it: :func:`~spine_gym.controllers.steady_state.steady_state_map`, the map the PID's
  feedforward reads), Gaussian per block (``noise_std``) and clipped to the env's envelope
  [0, ``v_max``]; the plan itself, the feedforward, all off and full drive of either wire are
  always among them, and so is the best sequence of the previous period (shifted with the plan);
  the new plan is their average weighted by ``exp(−cost / λ)``, λ relative to the median cost
  minus the least (the full-drive samples cost orders of magnitude more than the rest; relative
  to the mean they made the weights flat and the plan the average of the noise). (Around the
  plan alone, from a cold start, the samples stayed below the transformation, where no voltage
  moves the angle and the cost tells the samples nothing.)

**Cost** of a rollout over its steps h of length Δt_h (the end time t_h of each)::

    w_track Σ Δt_h (θ(t_h) − θ*(t_h))²  [deg² s]
  + w_energy E                           [J]    (the electrical energy of the rollout)
  + w_temp Σ Δt_h Σ_wires max(0, T − T_lim)²  [K² s]

with T_lim = the plant's thermal cut-off (``-v2`` ids; else the env's temperature limit) minus
``temp_margin``: a soft constraint that keeps the wires below the point where the driver would
cut them. A rollout whose model step failed costs :data:`~spine_gym.controllers.mpc.FAILED_COST`.

**State** (causal, ``mode="estimated"``, the default): only the observation, through
:class:`~spine_gym.controllers.estimator.PhaseEstimator` (phase fractions from the resistances,
ambient temperature and martensite resistivity identified at the first observation, the plant's
austenite resistivity from the angle residual); the measured minus the estimated angle is an
output disturbance held over the horizon (offset-free MPC); the targets over the horizon come from
the observed target and its 1-s preview (:func:`spine_gym.controllers.mpc.preview_targets`),
continued at the preview's rate for ``extrapolate`` seconds past it and then held. The
``"oracle_causal"`` mode is **privileged**: it reads the env's true state and the episode's
parameters (``env.snapshot()``), the current load held, the same observed targets — the upper
bound of what this planner reaches with perfect state sensing.

The plan time per control period is measured in ``benchmarks/bench_mpc_plan_time.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..envs.planar import PlanarConfig
from ..envs.targets_planar import ANGLE_LIMIT
from ..physics.planar.rollout import rollout_graded
from .base import check_range
from .estimator import DisturbanceConfig, PhaseEstimator
from .mpc import (
    MAX_EXTRAPOLATED_RATE,
    OBS_PREVIEW,
    OBS_TARGET,
    EnvPlanner,
    mppi_update,
    preview_targets,
    rollout_buffers,
    rollout_energy,
    weighted_cost,
)
from .planar import PlanarController
from .steady_state import steady_state_map

__all__ = ["LONG_MODES", "LongMPCConfig", "LongHorizonMPC"]

LONG_MODES = ("estimated", "oracle_causal")  # oracle_causal: privileged (the env's true state)


@dataclass(frozen=True)
class LongMPCConfig:
    """Settings of :class:`LongHorizonMPC` (module docstring).

    Attributes:
        horizon: planned time after the current block [s], in [0.2, 60], a whole number of blocks.
        block: length of a voltage block [s], in [0.1, 10], a whole number of control periods
            (checked against the env's when the controller is built).
        n_samples: sampled block sequences per control period, in [4, 10000].
        noise_std: standard deviation of a block's perturbation [V], in (0, 10].
        temperature: MPPI's λ relative to (median − min) of the costs, in (0, 100].
        w_track: weight of the squared tracking error [1/(deg² s)], >= 0.
        w_energy: weight of the electrical energy [1/J], >= 0.
        w_temp: weight of the squared excess over T_lim [1/(K² s)], >= 0.
        temp_margin: T_lim = cut-off (or temperature limit) − margin [K], in [0, 100].
        plan_tol_x: error tolerance of the rollouts' coupled sub-steps, in (0, 0.1].
        iterations: MPPI updates per control period, in [1, 20].
        fine_steps: control periods at the start of the horizon whose tracking error is scored
            one by one (the rest once per block), in [0, 100].
        extrapolate: how long past the observed preview the preview's rate of change is continued
            [s], in [0, 60]; the target is then held. Default: over the whole horizon (on three
            validation episodes of ``SmaSpineEasy-v2`` holding after 0 s or 2 s tracked worse).
        disturbance: the estimator's disturbance filter, or None (nominal plant, no offset filter).
        seed: seed of the perturbation generator.
    """

    horizon: float = 15.0
    block: float = 1.0
    n_samples: int = 32
    noise_std: float = 1.0
    temperature: float = 0.05
    w_track: float = 1.0
    w_energy: float = 0.05
    w_temp: float = 10.0
    temp_margin: float = 5.0
    plan_tol_x: float = 1e-3
    iterations: int = 2
    fine_steps: int = 10
    extrapolate: float = 60.0
    disturbance: DisturbanceConfig | None = DisturbanceConfig()
    seed: int = 0

    def __post_init__(self):
        check_range("horizon", self.horizon, 0.2, 60.0)
        check_range("block", self.block, 0.1, 10.0)
        if self.block > self.horizon:
            raise ValueError(f"block must be in [0.1, horizon = {self.horizon:g}] s, got {self.block!r}")
        n_blocks = self.horizon / self.block
        if abs(n_blocks - round(n_blocks)) > 1e-9 * n_blocks:
            raise ValueError(
                f"horizon must be a whole number of blocks (block = {self.block:g} s), got {self.horizon!r}"
            )
        _count("n_samples", self.n_samples, 4, 10_000)
        _count("iterations", self.iterations, 1, 20)
        _count("fine_steps", self.fine_steps, 0, 100)
        check_range("extrapolate", self.extrapolate, 0.0, 60.0)
        check_range("noise_std", self.noise_std, 0.0, 10.0, lo_open=True)
        check_range("temperature", self.temperature, 0.0, 100.0, lo_open=True)
        for name in ("w_track", "w_energy", "w_temp"):
            check_range(name, getattr(self, name), 0.0, 1e9)
        check_range("temp_margin", self.temp_margin, 0.0, 100.0)
        check_range("plan_tol_x", self.plan_tol_x, 0.0, 0.1, lo_open=True)
        if self.disturbance is not None and not isinstance(self.disturbance, DisturbanceConfig):
            raise ValueError(
                f"disturbance must be a DisturbanceConfig or None, got {type(self.disturbance).__name__}"
            )

    @property
    def n_blocks(self) -> int:
        """Whole blocks planned after the current one."""
        return int(round(self.horizon / self.block))


def _count(name: str, value, lo: int, hi: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not lo <= value <= hi:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")


class LongHorizonMPC(PlanarController, EnvPlanner):
    """Move-blocked MPPI over the thermal time scale (module docstring).

    Args:
        config: the env's :class:`~spine_gym.envs.PlanarConfig` (``env.config``).
        mode: ``"estimated"`` (causal: the observation only) or ``"oracle_causal"`` (privileged:
            the env's true state; needs ``env``).
        env: the env the privileged mode reads (``snapshot()``); also settable with :meth:`bind`.
        settings: :class:`LongMPCConfig` (defaults if None).
        **kwargs: the ``temperature_limit`` guard of :class:`~spine_gym.controllers.base.BaseController`
            (``v_max`` and ``dt`` come from ``config``).
    """

    name = "mpc_long"

    def __init__(
        self, config: PlanarConfig, mode: str = "estimated", *, env=None, settings=None, **kwargs
    ):
        if not isinstance(config, PlanarConfig):
            raise ValueError(f"config must be a PlanarConfig (env.config), got {type(config).__name__}")
        if mode not in LONG_MODES:
            raise ValueError(f"mode must be one of {LONG_MODES}, got {mode!r}")
        s = LongMPCConfig() if settings is None else settings
        if not isinstance(s, LongMPCConfig):
            raise ValueError(f"settings must be a LongMPCConfig, got {type(s).__name__}")
        for key in ("v_max", "dt"):
            if key in kwargs:
                raise ValueError(f"{key} comes from config; do not pass it to LongHorizonMPC")
        block_steps = s.block / config.control_period
        if abs(block_steps - round(block_steps)) > 1e-9 * block_steps:
            raise ValueError(
                f"block must be a whole number of control periods ({config.control_period:g} s), "
                f"got {s.block!r}"
            )
        if s.n_samples < 4:  # pragma: no cover - LongMPCConfig checks it
            raise ValueError(f"n_samples must be >= 4, got {s.n_samples}")
        super().__init__(v_max=config.v_max, dt=config.control_period, **kwargs)
        self.settings, self.mode, self.env_config = s, mode, config
        self.name = "mpc_long" if mode == "estimated" else f"mpc_long_{mode}"
        self.block_steps = int(round(block_steps))
        p = config.params
        self._side_volume = p.wire_volume * p.n_w
        self._ks = config.solver.replace(scheme="coupled", tol_x=float(s.plan_tol_x)).to_kernel()
        cutoff = getattr(config, "thermal_cutoff", None)
        self._t_lim = (config.temperature_limit if cutoff is None else cutoff) - s.temp_margin
        self.ss_map = steady_state_map(p, v_max=self.v_max)
        self.estimator = (
            PhaseEstimator(config, disturbance=s.disturbance) if mode == "estimated" else None
        )
        self.env = None
        if env is not None:
            self.bind(env)
        self.plan_shape = (s.n_blocks + 1, 2)  # (current block + whole blocks, wires)
        h = s.n_blocks + 1 + s.fine_steps  # the most rollout steps of grid()
        bufs = rollout_buffers(s.n_samples, h, p.n_seg)
        self._work, self._angle, self._temp, self._joule, self._status = bufs
        self.reset()

    # ------------------------------------------------------------------ episode
    def reset(self) -> None:
        """New episode: zero plan, fresh generator and estimator, block clock at 0."""
        super().reset()
        self.best = self.plan.copy()  # the best sampled sequence of the last update
        self.step_in_block = 0

    # ------------------------------------------------------------------ one control period
    def grid(self) -> tuple[np.ndarray, np.ndarray]:
        """The rollout steps now: their lengths [s] and the plan block each falls in.

        The block ends (the rest of the current block, then whole blocks), with the first
        ``fine_steps`` control periods recorded one by one (their voltages those of their blocks),
        so that the near-term tracking error is scored at the control period."""
        s, k = self.settings, self.block_steps
        ends = (k - self.step_in_block) + k * np.arange(s.n_blocks + 1)  # control periods ahead
        fine = np.arange(1, min(s.fine_steps, ends[-1]) + 1)
        steps = np.union1d(fine, ends)
        dts = np.diff(np.concatenate([[0], steps])) * self.dt
        return dts, np.searchsorted(ends, steps)

    def step_lengths(self) -> np.ndarray:
        """(H,) lengths [s] of the rollout steps now (:meth:`grid`)."""
        return self.grid()[0]

    def _volts(self, obs, mem):
        problem = self._problem(obs[0])
        blocks = problem[3][1]
        block_end = np.flatnonzero(np.diff(np.append(blocks, -1)))  # each block's last rollout step
        reference = self.feedforward(problem[4][block_end])
        for _ in range(self.settings.iterations):
            self._improve(problem, reference)
        volts = self.plan[0].copy()
        self.step_in_block += 1
        if self.step_in_block == self.block_steps:  # the current block is used up: shift
            self.step_in_block = 0
            self.plan, self.best = shifted(self.plan), shifted(self.best)
        return volts[None, :]

    def _problem(self, obs):
        """Start state, constants, held loads, step lengths, targets [deg] at the steps' ends,
        angle offset [deg] and the wires' volume of one side [m³]."""
        dts, blocks = self.grid()
        steps = np.rint(np.cumsum(dts) / self.dt).astype(np.int64)  # control periods ahead
        p = self.env_config.preview_steps
        steps = np.minimum(steps, p + int(round(self.settings.extrapolate / self.dt)))  # then held
        targets = np.clip(
            preview_targets(
                obs[OBS_TARGET : OBS_TARGET + 1], obs[OBS_PREVIEW : OBS_PREVIEW + 1], self._last_preview,
                p, MAX_EXTRAPOLATED_RATE, steps, self.dt,
            )[:, 0],
            -ANGLE_LIMIT, ANGLE_LIMIT,
        )  # fmt: skip
        self._last_preview = obs[OBS_PREVIEW : OBS_PREVIEW + 1].copy()
        if self.mode == "oracle_causal":
            snap, (state0, kp) = self._oracle_snapshot("states", "kps")
            loads = np.zeros((self.env_config.params.n_seg, 2))
            loads[0] = snap.arrays["forces"][min(snap.step_index, snap.arrays["forces"].shape[0] - 1)]
            return state0, kp, loads, (dts, blocks), targets, 0.0, float(snap.arrays["wvol"][0])
        est = self.estimator
        state0 = est.update(obs)
        grid = (dts, blocks)
        return state0, est.kp, np.array(est.loads), grid, targets, est.angle_offset, self._side_volume

    def feedforward(self, targets: np.ndarray) -> np.ndarray:
        """(H, 2) block voltages whose steady states are ``targets`` [deg] (H,): the map's voltage
        on the right wire for a positive target, on the left for a negative one, the other off."""
        v = np.minimum(self.ss_map.voltage_for(targets), self.v_max)
        return np.stack([np.where(targets > 0.0, v, 0.0), np.where(targets < 0.0, v, 0.0)], axis=1)

    def sample(self, reference: np.ndarray | None = None) -> np.ndarray:
        """(N, n_blocks + 1, 2) block voltages: Gaussian noise per block around the plan (the
        second half around ``reference``, (n_blocks + 1, 2), if given), clipped to [0, v_max];
        row 0 the plan itself, 1 all off, 2 and 3 full drive of the right and of the left wire,
        4 the reference itself, 5 the best sequence of the last update."""
        s = self.settings
        centre = np.repeat(self.plan[None], s.n_samples, axis=0)
        if reference is not None:
            centre[s.n_samples // 2 :] = reference
        volts = centre + self.rng.normal(0.0, s.noise_std, size=centre.shape)
        volts = np.clip(volts, 0.0, self.v_max)
        volts[0] = self.plan
        volts[1] = 0.0
        volts[2] = [self.v_max, 0.0]
        volts[3] = [0.0, self.v_max]
        if reference is not None and s.n_samples > 4:
            volts[4] = reference
        if s.n_samples > 5:
            volts[5] = self.best
        return volts

    def _improve(self, problem, reference=None) -> None:
        volts = self.sample(reference)
        cost = self.score(volts, problem)
        self.plan, best = mppi_update(volts, cost, self.settings.temperature, robust=True)
        self.best = volts[best].copy()
        self.last_cost = float(cost[best])

    def score(self, volts: np.ndarray, problem) -> np.ndarray:
        """(N,) costs of the block voltages ``volts`` (N, n_blocks + 1, 2) on ``problem``."""
        state0, kp, loads, (dts, blocks), targets, offset, side_volume = problem
        h = dts.shape[0]
        rollout_graded(
            state0, kp, self._ks,
            np.ascontiguousarray(volts[:, blocks, 0]), np.ascontiguousarray(volts[:, blocks, 1]),
            np.ascontiguousarray(loads), dts,
            self._work, self._angle, self._temp, self._joule, self._status,
        )  # fmt: skip
        angle, temp = self._angle[:, :h], self._temp[:, :h]
        err = np.degrees(angle) + offset - targets[None, :]
        energy = rollout_energy(self._joule[:, h - 1, :], state0, side_volume)
        return self.cost(err * err, energy, temp, self._status, dts)

    def cost(self, sq_err, energy, temp, status, dts) -> np.ndarray:
        """(N,) costs from the squared tracking error (N, H) [deg²], the energy (N,) [J], the
        temperatures (N, H, 2) [K], the statuses (N,) and the step lengths (H,) [s]."""
        over = np.maximum(temp - self._t_lim, 0.0)
        heat = np.sum(over * over, axis=2) @ dts
        return weighted_cost(self.settings, sq_err @ dts, energy, heat, status)


def shifted(plan: np.ndarray) -> np.ndarray:
    """The warm start of the next block: ``plan`` one block on, its last block repeated."""
    return np.concatenate([plan[1:], plan[-1:]], axis=0)
