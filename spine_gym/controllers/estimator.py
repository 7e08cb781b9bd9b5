"""State estimators: the hidden phase fractions of a spine from what its env observes.

The env observes the bending angle, both wire temperatures and both wire resistances (and the
action it applied). The model state behind them (``spine_gym.physics.planar.columns``) also holds, per
wire, the martensite fractions x₊ (tension variant) and x₋ (compression variant) and the shape of
the tube. :class:`PhaseEstimator` keeps a full model state and, each control period, does

1. **predict** — advance its state by one control period with the voltages the env applied (the
   observation's previous action), nominal parameters and no external load (the loads are not
   observed), on the env's physics (:func:`spine_gym.physics.planar.integrate.advance`, same sub-steps);
2. **correct** — replace what is measured:

   * the temperatures by the measured ones;
   * the austenite fraction of each wire from its resistance. The resistivity mixes as
     ρ_e = λ_A x_A + λ_M (x₊ + x₋) (MODEL.md §3.7, one λ_M for both martensite variants), and the
     env reports R = ρ_e L0 / A_w, so x_A = (R A_w / L0 − λ_M) / (λ_A − λ_M), clipped to [0, 1].
     The resistance does not tell x₊ from x₋; the martensite 1 − x_A is split in the predicted
     ratio x₊ : x₋ (all x₊ if the prediction holds no martensite, as a wire that re-transforms
     under its tensile stress does, MODEL.md §3.3);
   * then the tube shape is solved again for the corrected fractions (the composite solve).

With ``identify=True`` (the default) the first observation of an episode also identifies two
parameters of a randomised plant, before anything is predicted: the env starts a spine at ambient
temperature with both wires in martensite (x_A = 0, MODEL.md §3.10), so the mean of the two
measured temperatures is the ambient temperature T_E and the mean resistance gives the martensite
resistivity λ_M = R A_w / L0 (clipped to the ranges ``ModelParams`` accepts). The other
randomised parameters (convection, tube modulus, λ_A) stay nominal.

The angle is not forced onto the state (the fractions are already pinned by the resistance).
What the angle does tell is the load the spine carries: with ``disturbance`` set (a
:class:`DisturbanceConfig`, the default) the estimator also keeps an **equivalent tip force**
f = (f_x, f_y) [N] on the top disk, the load the model assumes from then on (predict, correct and
the MPC's rollouts). Because the tube is quasi-static (MODEL.md §4), the bending angle is an
algebraic function θ(x, f) of the corrected wire state and the load, so f is the state of a
Kalman filter with a random-walk model: each period P += Q (Q = diag(walk_x², walk_y²): pushes
come and go, a payload stays), the sensitivity J = ∂θ/∂f is taken by finite differences of the
composite solve, and the innovation ``measured − model angle`` corrects f by the gain
P Jᵀ / (J P Jᵀ + angle_std²). A payload is f_y = −m g and a horizontal push f_x; at a bent
shape both components move the angle, so holding different angles separates them (a straight
spine does not see f_y, and the filter then keeps its prior). It also absorbs what the nominal
model gets wrong about the moment balance (the tube modulus of a randomised plant). The
remaining difference ``measured − estimated angle`` is returned as :attr:`angle_offset` and used
by MPC as an output disturbance. How well it recovers the
fractions on seeded episodes is tested in ``tests/controllers/test_mpc.py`` and quoted in ``docs/agents.md``.

:class:`SpatialPhaseEstimator` is the same estimator for ``SmaSpine3D-v0`` and
``SmaSpineChain-v0`` (every wire group of the layout, the spatial core, each wire's own length in
the resistance inversion; tested in ``tests/controllers/test_mpc_spatial.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..envs.drive import action_to_volts
from ..envs.planar import OBS_NAMES, PlanarConfig, planar_obs_index
from ..envs.spatial import SpatialConfig
from ..physics import columns as L
from ..physics.planar import columns as PL
from ..physics.planar.composite import composite
from ..physics.planar.integrate import advance, init_state
from ..physics.planar.stability import needs_stability_check
from ..physics.spatial import columns as SL
from ..physics.spatial.composite import composite as spatial_composite
from ..physics.spatial.integrate import advance as spatial_advance
from ..physics.spatial.integrate import init_state as spatial_init_state
from ..physics.spatial.stability import needs_stability_check as spatial_needs_check
from ..physics.spatial.work import make_work

__all__ = ["DisturbanceConfig", "PhaseEstimator", "SpatialPhaseEstimator", "austenite_from_resistance"]

# SmaSpine-v0's observation indices, from its table (right before left in each pair)
OBS_DIM = len(OBS_NAMES)
OBS_ANGLE = planar_obs_index("angle_deg")
OBS_TEMP_R = planar_obs_index("temperature")
OBS_TEMP_L = OBS_TEMP_R + 1
OBS_PREV_R = planar_obs_index("previous_action")
OBS_PREV_L = OBS_PREV_R + 1
OBS_RES_R = planar_obs_index("resistance")
OBS_RES_L = OBS_RES_R + 1


@dataclass(frozen=True)
class DisturbanceConfig:
    """Kalman filter of :class:`PhaseEstimator`'s augmented state (λ_A, f_x, f_y) (module docstring).

    Attributes:
        lam_a_std: prior standard deviation of λ_A relative to the nominal, in (0, 1] (the env's
            randomisation draws λ_A × U(0.95, 1.05): 0.029); the estimate stays within ±3 of it.
        force_std: prior standard deviation of either tip-force component [N], in (0, 10].
        walk_x: random walk of the horizontal component per control period [N] (tip pushes), in (0, 10].
        walk_y: random walk of the vertical component per control period [N] (a payload stays), in (0, 10].
        angle_std: angle measurement and model error [deg], in (0, 90].
        limit: each force component is clipped to [−limit, limit] [N], in (0, 5] (5.59 N down
            buckles the straight spine, README).
        forces: estimate the tip force too (default False: λ_A alone; the force components then
            keep zero variance and stay zero). On hard-like validation episodes the force estimate
            made the MPC track worse (docs/agents.md): at a held angle the angle cannot tell a
            payload from a λ_A error or a stiffer tube, and knowing the true payload did not help
            the planner either.
    """

    lam_a_std: float = 0.03
    force_std: float = 0.5
    walk_x: float = 0.01
    walk_y: float = 0.003
    angle_std: float = 1.0
    limit: float = 1.5
    forces: bool = False

    def __post_init__(self):
        if not isinstance(self.forces, bool):
            raise ValueError(f"forces must be a bool, got {self.forces!r}")
        for name, hi in (("lam_a_std", 1.0), ("force_std", 10.0), ("walk_x", 10.0), ("walk_y", 10.0),
                         ("angle_std", 90.0), ("limit", 5.0)):  # fmt: skip
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 < v <= hi:
                raise ValueError(f"{name} must be a number in (0, {hi:g}], got {v!r}")


def austenite_from_resistance(resistance: np.ndarray, params, length=None) -> np.ndarray:
    """x_A of a wire from its measured resistance [Ohm] (MODEL.md §3.7 inverted), clipped to [0, 1].

    ``length``: the wire's length [m] (scalar or per wire; default ``params.L0``, the seed's wire;
    a chain module's wires are shorter, SPATIAL.md §6)."""
    length = params.L0 if length is None else np.asarray(length, dtype=np.float64)
    lam = np.asarray(resistance, dtype=np.float64) * params.wire_area / length
    return np.clip((lam - params.lam_M) / (params.lam_A - params.lam_M), 0.0, 1.0)


class PhaseEstimator:
    """Model state of one spine inferred from the observations (see the module docstring).

    Args:
        config: the env's :class:`~spine_gym.envs.PlanarConfig` (nominal parameters, solver, periods,
            ``v_max``). Loads and sensor noise of an episode are not known.
        identify: identify T_E and λ_M from each episode's first observation (module docstring).
        disturbance: settings of the equivalent tip-force filter, or None for no load estimate
            (the loads then stay zero).
    """

    def __init__(
        self,
        config: PlanarConfig,
        identify: bool = True,
        disturbance: DisturbanceConfig | None = DisturbanceConfig(),
    ):
        if not isinstance(config, PlanarConfig):
            raise ValueError(f"config must be a PlanarConfig, got {type(config).__name__}")
        self.config = config
        self.identify = bool(identify)
        if disturbance is not None and not isinstance(disturbance, DisturbanceConfig):
            raise ValueError(
                f"disturbance must be a DisturbanceConfig or None, got {type(disturbance).__name__}"
            )
        self.disturbance = disturbance
        self.nominal = config.params
        self.params = config.params
        self.kp = self.params.to_kernel()
        self.ks = config.solver.to_kernel()
        n = self.params.n_seg
        # assumed vertex loads [N]: the equivalent tip force on the top disk (row 0), else none
        self.loads = np.zeros((n, 2))
        self.identified = self.nominal  # the parameters before the λ_A estimate
        self.lam_a_scale = 1.0  # estimated λ_A / nominal λ_A
        self.cov = np.zeros((3, 3))  # covariance of the augmented estimate (λ_A scale, f_x, f_y)
        self.state = np.zeros(PL.state_size(n))
        self._work = np.empty(n)
        self._saved = np.empty(n)
        self.angle_offset = 0.0  # [deg] measured − estimated angle after the last update
        self._started = False

    def reset(self) -> None:
        """The env's starting state (MODEL.md §3.10, straight at ambient) under the assumed loads,
        with the nominal parameters until the first observation identifies them."""
        self.loads[:] = 0.0
        self.lam_a_scale = 1.0
        d = self.disturbance
        self.cov = np.zeros((3, 3)) if d is None else np.diag(self._walk_or_prior(d, prior=True))
        self._set_params(self.nominal)
        self.angle_offset = 0.0
        self._started = False

    def _set_params(self, params) -> None:
        self.identified = params
        self._use_params(params.replace(lam_A=params.lam_A * self.lam_a_scale))
        st = init_state(self.state, self.kp, self.ks, self.loads)
        if st != L.OK:  # pragma: no cover - the nominal unloaded start always solves
            raise RuntimeError(L.STATUS_TEXT.get(st, str(st)))

    def _use_params(self, params) -> None:
        self.params = params
        self.kp = params.to_kernel()

    def _identify(self, obs: np.ndarray) -> None:
        """T_E and λ_M from the first observation of an episode (see the module docstring)."""
        lo_t, hi_t = self.nominal._RANGES["T_E"]
        lo_m, hi_m = self.nominal._RANGES["lam_M"]
        t_e = float(np.clip(0.5 * (obs[OBS_TEMP_R] + obs[OBS_TEMP_L]), lo_t, hi_t))
        r0 = 0.5 * (obs[OBS_RES_R] + obs[OBS_RES_L])
        lam_m = float(np.clip(r0 * self.nominal.wire_area / self.nominal.L0, lo_m, hi_m))
        lam_m = min(lam_m, self.nominal.lam_A * (1.0 - 1e-6))  # keep λ_A > λ_M (the x_A inversion)
        self._set_params(self.nominal.replace(T_E=t_e, lam_M=lam_m))

    @property
    def angle_deg(self) -> float:
        """Bending angle of the estimated state [deg]."""
        return self._angle_of(self.state)

    def _angle_of(self, state: np.ndarray) -> float:
        n = self.params.n_seg
        return float(np.degrees(state[PL.X_HEAD : PL.X_HEAD + n].sum()))

    @property
    def tip_force(self) -> np.ndarray:
        """Estimated equivalent tip force (f_x, f_y) [N] (global; a payload m is (0, −m g))."""
        return self.loads[0].copy()

    @property
    def lam_a(self) -> float:
        """Estimated austenite resistivity λ_A [Ω m]."""
        return self.params.lam_A

    @property
    def fractions(self) -> np.ndarray:
        """Estimated (x₊ right, x₋ right, x₊ left, x₋ left)."""
        return self.state[[PL.X_PR, PL.X_MR, PL.X_PL, PL.X_ML]].copy()

    def update(self, obs: np.ndarray) -> np.ndarray:
        """Predict over the control period just taken (unless this is the first observation of the
        episode), correct with ``obs`` and return the estimated state (a view, do not modify)."""
        obs = np.asarray(obs, dtype=np.float64)
        if obs.ndim != 1 or obs.shape[0] < OBS_DIM:  # -v1/-v2 append their error entries to -v0's
            raise ValueError(
                f"obs must be one planar observation of shape (d,), d >= {OBS_DIM} (SmaSpine-v0's entries "
                f"first), got {obs.shape}"
            )
        obs = obs[:OBS_DIM]
        if self._started:
            self._predict(obs)
        elif self.identify:
            self._identify(obs)
        self._started = True
        predicted = self.state.copy()
        self._correct(obs)
        if self.disturbance is not None:
            self._estimate_disturbance(obs, predicted)
        self.angle_offset = float(obs[OBS_ANGLE]) - self.angle_deg
        return self.state

    def _predict(self, obs: np.ndarray) -> None:
        coef = self.config.volt_coef
        v_r = action_to_volts(obs[OBS_PREV_R], coef)
        v_l = action_to_volts(obs[OBS_PREV_L], coef)
        backup = self.state.copy()
        for _ in range(self.config.n_sub):
            st, _, _ = advance(
                self.state, self.kp, self.ks, v_r, v_l, self.loads, self.config.physics_dt, False
            )
            if st != L.OK:  # keep the last valid estimate; the correction re-anchors it
                self.state[:] = backup
                return

    def _corrected(self, predicted: np.ndarray, obs: np.ndarray, params, loads: np.ndarray):
        """(status, state): ``predicted`` with the measured temperatures, the austenite fractions
        of the resistances (under ``params``' λ_A, λ_M) and the shape solved under ``loads``."""
        s = predicted.copy()
        s[PL.X_TR] = obs[OBS_TEMP_R]
        s[PL.X_TL] = obs[OBS_TEMP_L]
        xa = austenite_from_resistance(obs[[OBS_RES_R, OBS_RES_L]], params)
        for (ip, im), x_a in zip(((PL.X_PR, PL.X_MR), (PL.X_PL, PL.X_ML)), xa, strict=True):
            mart = s[ip] + s[im]
            share = s[ip] / mart if mart > 1e-12 else 1.0
            s[ip] = (1.0 - x_a) * share
            s[im] = (1.0 - x_a) * (1.0 - share)
        kp = params.to_kernel()
        check = needs_stability_check(loads, kp)
        st, _ = composite(s, loads, kp, self.ks, self._work, self._saved, check)
        return st, s

    def _correct(self, obs: np.ndarray) -> None:
        st, s = self._corrected(self.state, obs, self.params, self.loads)
        if st == L.OK:
            self.state[:] = s

    def _with(self, aug: np.ndarray):
        """(params, loads) of the augmented estimate ``aug`` = (λ_A scale, f_x, f_y)."""
        loads = self.loads.copy()
        loads[0] = aug[1:]
        return self.identified.replace(lam_A=self.identified.lam_A * aug[0]), loads

    @staticmethod
    def _walk_or_prior(d: DisturbanceConfig, prior: bool) -> np.ndarray:
        """Variances of (λ_A scale, f_x, f_y): the prior at reset or the random walk per period
        (λ_A is constant); the force terms are zero unless ``d.forces``."""
        on = 1.0 if d.forces else 0.0
        if prior:
            return np.array([d.lam_a_std**2, on * d.force_std**2, on * d.force_std**2])
        return np.array([0.0, on * d.walk_x**2, on * d.walk_y**2])

    def _estimate_disturbance(self, obs: np.ndarray, predicted: np.ndarray) -> None:
        """One Kalman update of (λ_A scale, f_x, f_y) from the measured angle (module docstring);
        the state is corrected again under the new estimate. A failed solve keeps the previous one."""
        d = self.disturbance
        base = self.angle_deg
        aug = np.array([self.lam_a_scale, *self.loads[0]])
        steps = (1e-2, 0.1, 0.1)  # finite-difference steps (relative λ_A, N, N): above the solve tolerance
        jac = np.zeros(3)
        for k in range(3 if d.forces else 1):
            trial = aug.copy()
            trial[k] += steps[k]
            st, s = self._corrected(predicted, obs, *self._with(trial))
            if st != L.OK:
                return
            jac[k] = (self._angle_of(s) - base) / steps[k]
        cov = self.cov + np.diag(self._walk_or_prior(d, prior=False))
        gain = cov @ jac / (jac @ cov @ jac + d.angle_std**2)
        new = aug + gain * (float(obs[OBS_ANGLE]) - base)
        lim = 3.0 * d.lam_a_std
        new = np.clip(new, (1.0 - lim, -d.limit, -d.limit), (1.0 + lim, d.limit, d.limit))
        params, loads = self._with(new)
        st, s = self._corrected(predicted, obs, params, loads)
        if st != L.OK:
            return
        self.state[:] = s
        self.loads[:] = loads
        self.lam_a_scale = float(new[0])
        self._use_params(params)
        self.cov = cov - np.outer(gain, jac @ cov)


def _identified(nominal, temperatures: np.ndarray, resistance: np.ndarray, lengths: np.ndarray):
    """``nominal`` with T_E and λ_M of the first observation of an episode (all wires in
    martensite at ambient temperature, MODEL.md §3.10, §3.7), clipped to the ranges ``ModelParams``
    accepts and keeping λ_A > λ_M."""
    lo_t, hi_t = nominal._RANGES["T_E"]
    lo_m, hi_m = nominal._RANGES["lam_M"]
    t_e = float(np.clip(np.mean(temperatures), lo_t, hi_t))
    lam_m = float(np.clip(np.mean(resistance * nominal.wire_area / lengths), lo_m, hi_m))
    lam_m = min(lam_m, nominal.lam_A * (1.0 - 1e-6))
    return nominal.replace(T_E=t_e, lam_M=lam_m)


class SpatialPhaseEstimator:
    """:class:`PhaseEstimator` for a spatial or chained spine (``SmaSpine3D-v0``, ``SmaSpineChain-v0``).

    The same predict/correct cycle on the spatial core (SPATIAL.md), per wire group: predict one
    control period with the applied voltages (the observation's previous actions, the env's
    per-wire scale), nominal parameters and no external load
    (:func:`spine_gym.physics.spatial.integrate.advance`); correct the temperatures to the measured
    ones and each wire's austenite fraction to its resistance (MODEL.md §3.7 with the wire's own
    length, split of the martensite as predicted); solve the shape again (the composite solve).
    ``identify=True`` takes T_E and λ_M from the first observation as the planar estimator does.

    Args:
        config: the env's :class:`~spine_gym.envs.spatial.SpatialConfig` (layout, periods, solver).
        index: observation indices of the entries read, ``{"temperature", "resistance",
            "previous_action"} -> slice`` (``env.unwrapped.obs_index``).
        identify: identify T_E and λ_M from each episode's first observation.
    """

    KEYS = ("temperature", "resistance", "previous_action")

    def __init__(self, config: SpatialConfig, index: dict, identify: bool = True):
        if not isinstance(config, SpatialConfig):
            raise ValueError(f"config must be a SpatialConfig, got {type(config).__name__}")
        missing = [k for k in self.KEYS if k not in index]
        if missing:
            raise ValueError(f"index must give the observation slices of {self.KEYS}, missing {missing}")
        self.config = config
        self.index = {k: index[k] for k in self.KEYS}
        self.identify = bool(identify)
        self.nominal = config.params
        self.ks = config.solver.to_kernel()
        lay = config.layout
        self.n_wires, self.n_modules, self.n_seg = lay.n_wires, lay.n_modules, lay.n_seg
        self.loads = np.zeros((self.n_seg, 3))  # assumed loads: none (not observed)
        self.state = np.zeros(lay.state_size())
        self.volt_coef = np.broadcast_to(np.asarray(config.volt_coef, dtype=np.float64), (self.n_wires,))
        self._started = False

    def reset(self) -> None:
        """The env's starting state (straight at ambient, MODEL.md §3.10) under the assumed loads,
        with the nominal parameters until the first observation identifies them."""
        self._set_params(self.nominal)
        self._started = False

    def _set_params(self, params) -> None:
        self.params = params
        self.kp, self.kw, self.km = self.config.layout_for(params).to_kernel()
        self._wk = make_work(self.n_wires, self.n_modules, self.n_seg)
        st = spatial_init_state(self.state, self.kp, self.ks, self.kw, self.km, self.loads)
        if st != L.OK:  # pragma: no cover - the nominal unloaded start always solves
            raise RuntimeError(L.STATUS_TEXT.get(st, str(st)))

    def _read(self, obs: np.ndarray, key: str) -> np.ndarray:
        return obs[self.index[key]]

    def _block(self, field: int) -> np.ndarray:
        """View of the per-wire block ``field`` (``spatial.columns.F_*``) of the estimated state."""
        o = SL.wire_offset(field, self.n_wires)
        return self.state[o : o + self.n_wires]

    @property
    def fractions(self) -> np.ndarray:
        """Estimated (W, 2) martensite fractions (x₊, x₋) of every wire group."""
        return np.stack([self._block(SL.F_XP), self._block(SL.F_XM)], axis=1)

    def update(self, obs: np.ndarray) -> np.ndarray:
        """Predict over the control period just taken (unless this is the first observation of the
        episode), correct with ``obs`` and return the estimated state (a view, do not modify)."""
        obs = np.asarray(obs, dtype=np.float64)
        if obs.ndim != 1:
            raise ValueError(f"obs must be one observation of shape (d,), got {obs.shape}")
        if self._started:
            self._predict(obs)
        elif self.identify:
            lengths = self.kw[:, SL.W_L0]
            self._set_params(
                _identified(
                    self.nominal, self._read(obs, "temperature"), self._read(obs, "resistance"), lengths
                )
            )
        self._started = True
        self._correct(obs)
        return self.state

    def _predict(self, obs: np.ndarray) -> None:
        volts = action_to_volts(self._read(obs, "previous_action"), self.volt_coef)
        backup = self.state.copy()
        for _ in range(self.config.n_sub):
            st, _, _ = spatial_advance(
                self.state,
                self.kp,
                self.ks,
                self.kw,
                self.km,
                volts,
                self.loads,
                self.config.physics_dt,
                False,
            )
            if st != L.OK or not np.all(np.isfinite(self.state)):  # keep the last valid estimate
                self.state[:] = backup
                return

    def _correct(self, obs: np.ndarray) -> None:
        s = self.state
        backup = s.copy()
        self._block(SL.F_T)[:] = self._read(obs, "temperature")
        xa = austenite_from_resistance(self._read(obs, "resistance"), self.params, self.kw[:, SL.W_L0])
        xp = self._block(SL.F_XP)
        xm = self._block(SL.F_XM)
        mart = xp + xm
        share = np.where(mart > 1e-12, xp / np.maximum(mart, 1e-300), 1.0)
        xp[:] = (1.0 - xa) * share
        xm[:] = (1.0 - xa) * (1.0 - share)
        check = spatial_needs_check(self.loads, self.kp, self.km)
        st, _ = spatial_composite(s, self.loads, self.kp, self.ks, self.kw, self.km, self._wk, check)
        if st != L.OK or not np.all(np.isfinite(s)):
            s[:] = backup
