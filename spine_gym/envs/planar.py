"""``SmaSpine-v0``'s plant: its configuration, its declarative table and its batch.

:class:`PlanarConfig` adds the planar task (target angles) to :class:`.config.BaseEnvConfig` and
declares the observation/info table (:meth:`PlanarConfig.table`, see :mod:`.table`);
:data:`OBS_NAMES`, :data:`OBS_UNITS` and :func:`planar_obs_index` give its layout to controllers.
:class:`PlanarBatch` is :class:`.batch.TableBatch` over the planar kernel (MODEL.md): the
planar pair keeps its specialised kernel (:func:`spine_gym.physics.planar.control.step_spine`,
proven equal to the spatial core in the planar case, SPATIAL.md §7.1), stepped with the env's
readout in one call (:func:`.step_kernels.planar_step`); everything above the physics — sensors,
observation, reward, info, snapshots — is the table-driven layer every env shares. The env classes
(their docstrings are the documentation pages) are in :mod:`.planar_env`; ``EnvConfig`` is the
former name of :class:`PlanarConfig` (kept for one release).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..params import ModelParams
from ..physics.planar import columns as PL
from ..physics.planar.control import record_many
from ..physics.planar.integrate import init_state
from ..physics.planar.record import OUT_SIZE
from . import readout as ro
from . import step_kernels as sk
from .batch import TableBatch
from .config import ANGLE_OBS_LIMIT, RATE_OBS_LIMIT, TARGET_REACH, BaseEnvConfig, _pair
from .drive import action_to_volts, volt_coef
from .table import Entry, Table
from .targets_planar import ANGLE_LIMIT, TARGET_KINDS, TargetProfile

__all__ = ["PlanarConfig", "EnvConfig", "PlanarBatch", "OBS_NAMES", "OBS_UNITS", "planar_obs_index"]


@dataclass(frozen=True)
class PlanarConfig(BaseEnvConfig):
    """Validated arguments of ``SmaSpine-v0`` (see :class:`spine_gym.envs.SmaSpineEnv` for meanings)."""

    target_range: tuple[float, float] = (-45.0, 45.0)
    target_kinds: tuple[str, ...] = TARGET_KINDS
    sine_period_range: tuple[float, float] = (20.0, 60.0)

    def _check_task(self) -> None:
        s = object.__setattr__
        s(self, "target_range", _pair("target_range", self.target_range, -TARGET_REACH, TARGET_REACH))
        self._check_kinds(TARGET_KINDS, "sine_period_range")

    @property
    def energy_reference(self) -> float:
        """Largest electrical energy of one control period [J]: both sides at v_max, nominal
        martensite/austenite resistivity, whichever is lower (the normaliser of the energy term)."""
        p = self.params
        r_min = min(p.lam_A, p.lam_M) * p.L0 / p.wire_area  # [Ω] one wire
        return 2.0 * p.n_w * self.v_max**2 / r_min * self.control_period

    def initial_status(self, params: ModelParams, payload: float) -> int:
        state = np.zeros(PL.state_size(params.n_seg))
        return init_state(
            state, params.to_kernel(), self.solver.to_kernel(), self.initial_loads(params, payload)
        )

    def resistance_bound(self) -> float:
        """Upper bound of the resistance entries [Ω]: 2x the largest one-wire resistance over the
        nominal and randomised parameters (values above it are clipped)."""
        cands = self.extreme_params()
        r = max(max(p.lam_A, p.lam_M) * p.L0 / p.wire_area for p in cands)
        return float(2.0 * r + 10.0 * self.sensor_noise[2])

    # ------------------------------------------------------------------ the plant and the table
    n_wires = 2  # right, left
    n_modules = 1
    force_dim = 2  # global (x, y)

    @property
    def n_seg(self) -> int:
        return self.params.n_seg

    @property
    def volt_coef(self) -> float:
        """Volts per unit of (action + 1) (:func:`.drive.volt_coef`)."""
        return volt_coef(self.v_max)

    def table(self) -> Table:
        """The declarative observation/info table of ``SmaSpine-v0`` (one place per entry)."""
        lim = (-ANGLE_LIMIT, ANGLE_LIMIT)
        rl = ("right", "left")
        temp, prev, res = self.wire_entries(rl, "wire resistance (one wire)")
        entries = (
            Entry(
                "voltage", "voltage", "V", "applied voltage [right, left]", ("voltage_right", "voltage_left")
            ),
            Entry(
                "angle_deg",
                "angle",
                "deg",
                "bending angle θ (sum of segment angles)",
                ("angle",),
                (-ANGLE_OBS_LIMIT, ANGLE_OBS_LIMIT),
                noise="angle",
            ),
            Entry("target_deg", "target", "deg", "current target θ*(t)", ("target",), lim),
            Entry("tracking_error_deg", "error", "deg", "target − angle", ("tracking_error",)),
            Entry("energy_J", "energy", "J", "electrical energy of the step (both sides)", ("energy",)),
            Entry("power_W", "power", "W", "mean electrical power per side", ("power_right", "power_left")),
            Entry("cost", "cost", "K", "Σ over both wires of max(0, T − temperature_limit)", ("cost",)),
            temp,
            Entry(
                "angle_rate",
                "rate",
                "deg/s",
                "angle rate (difference of measured angles)",
                ("angle_rate",),
                (-RATE_OBS_LIMIT, RATE_OBS_LIMIT),
                info=False,
            ),
            Entry(
                "target_preview",
                "preview",
                "deg",
                "target preview θ*(t + target_preview)",
                ("target_preview",),
                lim,
                info=False,
            ),
            prev,
            res,
            Entry("time", "time", "s", "time at the end of the step", ("time",)),
            Entry(
                "tip_force",
                "force",
                "N",
                "force on the top disk (events + payload weight), global x/y",
                ("fx", "fy"),
            ),
            *self.reward_entries(),
            *self.error_entries("deg", ("angle",), ANGLE_OBS_LIMIT + ANGLE_LIMIT),
        )
        return Table(entries, "angle_deg", self.noise_sigma)


EnvConfig = PlanarConfig  # the former name (kept for one release)


class PlanarBatch(TableBatch):
    """The batch of ``SmaSpine-v0``: planar spines, targets are :class:`TargetProfile` s [deg]."""

    PLANT = sk.PLANAR_PLANT

    def _alloc_plant(self, b: int) -> None:
        p = self.cfg.params
        self.nominal_kp = p.to_kernel()
        self.states = np.zeros((b, PL.state_size(p.n_seg)))
        self.kps = np.tile(self.nominal_kp, (b, 1))

    def record_size(self) -> int:
        return OUT_SIZE

    def _parse_target(self, target) -> TargetProfile:
        if isinstance(target, int | float | np.number) and not isinstance(target, bool):
            target = TargetProfile.constant(float(target))
        if not isinstance(target, TargetProfile):
            raise ValueError(f"options['target'] must be a TargetProfile or a number [deg], got {target!r}")
        return target

    def _sample_target(self, rng: np.random.Generator) -> TargetProfile:
        cfg = self.cfg
        return TargetProfile.sample(
            rng, cfg.episode_duration, cfg.target_range, cfg.target_kinds, cfg.sine_period_range
        )

    def _target_grid(self, i: int, target: TargetProfile) -> np.ndarray:
        return np.asarray(target(self.time_grid))[:, None]

    def _set_episode(self, i: int, params: ModelParams, kp: np.ndarray | None) -> None:
        if params.n_seg != self.cfg.params.n_seg:
            raise ValueError(
                f"options['params'].n_seg must equal the env's n_seg = {self.cfg.params.n_seg}, "
                f"got {params.n_seg}"
            )
        self.kps[i] = params.to_kernel() if kp is None else kp
        self.ohm[i] = params.L0 / params.wire_area
        self.wvol[i] = params.wire_volume * params.n_w

    def _init_state(self, i: int, vforce: np.ndarray) -> int:
        return init_state(self.states[i], self.kps[i], self.ks, vforce)

    def _step_kernel(self):
        return sk.planar_step if self.parallel else sk.planar_step_serial

    def _record(self, rows: np.ndarray) -> None:
        record_many(self.states, self.kps, rows, self.meas)

    def _probe(self, rows: np.ndarray) -> None:
        ro.planar_probe(rows, self.meas, self.ohm, self.wvol, self.probe_cols, self.probe)

    def state_summary(self, i: int) -> dict[str, Any]:
        """What the renderer needs for environment ``i``."""
        n = self.cfg.params.n_seg
        _, _, params = self.episodes[i]
        k = int(self.mem.k[i])
        return {
            "dth": self.states[i, PL.X_HEAD : PL.X_HEAD + n].copy(),
            "kp": self.kps[i].copy(),
            "temperature": (float(self.states[i, PL.X_TR]), float(self.states[i, PL.X_TL])),
            "ambient": float(params.T_E),
            "target_deg": float(self.targets[i, min(k, self.targets.shape[1] - 1), 0]),
            "angle_deg": float(np.degrees(self.states[i, PL.X_HEAD : PL.X_HEAD + n].sum())),
            "tip_force": self.forces[i, min(k, self.cfg.n_steps - 1)].copy(),
            "time": k * self.cfg.control_period,
            "voltage": action_to_volts(self.mem.prev_action[i], self.cfg.volt_coef),
        }


# the planar observation layout, from its table (units and names of the default configuration)
_PLANAR_TABLE = PlanarConfig().table()
OBS_NAMES = _PLANAR_TABLE.obs_names
OBS_UNITS = tuple(e.unit for e in _PLANAR_TABLE.entries if e.obs is not None for _ in e.names)


def planar_obs_index(key: str) -> int:
    """Observation index of the first component of ``SmaSpine-v0``'s table entry ``key`` (e.g.
    ``"angle_deg"``, ``"target_deg"``, ``"target_preview"``, ``"temperature"``, ``"previous_action"``,
    ``"resistance"``); controllers derive their indices from it."""
    return _PLANAR_TABLE.obs_index(key).start
