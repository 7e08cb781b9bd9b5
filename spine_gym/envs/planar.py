"""The planar plant of ``SmaSpine-v0``: :class:`TableBatch` over the planar kernel (MODEL.md).

The planar pair keeps its specialised kernel (:func:`spine_gym.physics.env_kernels.step_spine`,
proven equal to the spatial core in the planar case, SPATIAL.md §7.1), stepped with the env's
bookkeeping in one call (:func:`._step_kernels.planar_step`); everything above the
physics — sensors, observation, reward, info, snapshots — is the table-driven layer every env
shares.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..params import ModelParams
from ..physics import env_kernels
from ..physics.planar import batch
from ..physics.planar import columns as PL
from ..physics.planar.solver import init_state
from . import _bookkeeping as bk
from . import _step_kernels as sk
from .table_batch import TableBatch
from .task import TargetProfile

__all__ = ["PlanarBatch"]


class PlanarBatch(TableBatch):
    """The batch of ``SmaSpine-v0``: planar spines, targets are :class:`TargetProfile` s [deg]."""

    PLANT = sk.PLANAR_PLANT

    def _alloc_plant(self, b: int) -> None:
        p = self.cfg.params
        self.nominal_kp = p.to_kernel()
        self.states = np.zeros((b, PL.state_size(p.n_seg)))
        self.kps = np.tile(self.nominal_kp, (b, 1))

    def record_size(self) -> int:
        return batch.OUT_SIZE

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
        env_kernels.record_many(self.states, self.kps, rows, self.meas)

    def _probe(self, rows: np.ndarray) -> None:
        bk.planar_probe(rows, self.meas, self.ohm, self.wvol, self.probe_cols, self.probe)

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
            "voltage": (self.mem.prev_action[i] + 1.0) * 0.5 * self.cfg.v_max,
        }
