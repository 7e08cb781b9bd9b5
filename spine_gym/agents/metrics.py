"""Tracking metrics of one closed-loop episode (pure numpy; used by the evaluation and the tuning).

An episode is recorded as a :class:`Trajectory` from the env's ``info`` dicts (keys of the env
contract: ``time``, the tracked quantity and its target (``angle_deg``, ``target_deg`` for
``SmaSpine-v0``; the task and target entries of a spatial env's table), ``voltage``,
``temperature``, ``energy_J``, ``cost``). Vector tasks (a 3-D tip bending vector, a tip position)
use the Euclidean norm of the error. :func:`episode_metrics` turns it into the numbers of the
evaluation table.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Trajectory", "episode_metrics", "METRIC_COLUMNS", "TIME_OVER_LIMIT_CAP_S", "settling_times"]

# column name -> (header, format) of the evaluation table, in display order
METRIC_COLUMNS = {
    "rmse_deg": ("RMSE [deg]", "{:.2f}"),
    "max_error_deg": ("max err [deg]", "{:.1f}"),
    "settling_time_s": ("settling [s]", "{:.1f}"),
    "energy_J": ("energy [J]", "{:.0f}"),
    "peak_temperature_K": ("peak T [K]", "{:.0f}"),
    "time_over_limit_s": ("T>limit [s]", "{:.1f}"),
}

#: [s] the thermal constraint of the constrained rankings: at most this much time per episode with a
#: wire over the temperature limit (``time_over_limit_s``), as a cost threshold in Safety-Gymnasium
TIME_OVER_LIMIT_CAP_S = 0.5


#: info keys (tracked quantity, target) of the planar env; the spatial envs name theirs in their table
PLANAR_KEYS = ("angle_deg", "target_deg")


@dataclass
class Trajectory:
    """One episode sampled at the control period (row k = state after action k).

    Attributes:
        time: (n,) [s];
        angle_deg, target_deg: the tracked quantity and its target, (n,) for the planar angle
            [deg], (n, d) for a vector: the tip bending vector [deg] (``SmaSpine3D-v0``) or the
            tip position [mm] (``SmaSpineChain-v0``);
        voltage: (n, W) [V] per wire (planar: right, left); temperature: (n, W) [K];
        energy_J: (n,) electrical energy of each step [J]; cost: (n,) over-temperature cost of
        each step; action: (n, W) raw actions.
    """

    time: np.ndarray
    angle_deg: np.ndarray
    target_deg: np.ndarray
    voltage: np.ndarray
    temperature: np.ndarray
    energy_J: np.ndarray
    cost: np.ndarray
    action: np.ndarray
    reward: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @classmethod
    def from_infos(
        cls, infos: list[dict], actions: list, rewards: list, keys: tuple[str, str] = PLANAR_KEYS
    ) -> Trajectory:
        """Stack the per-step ``info`` dicts of an episode; ``keys`` = (tracked, target) info keys."""
        if not infos:
            raise ValueError("an episode needs at least one step")

        def col(key):
            return np.array([np.asarray(i[key], dtype=np.float64) for i in infos])

        n_wires = np.size(infos[0]["voltage"])
        return cls(
            time=col("time").reshape(-1),
            angle_deg=col(keys[0]),
            target_deg=col(keys[1]),
            voltage=col("voltage").reshape(len(infos), n_wires),
            temperature=col("temperature").reshape(len(infos), n_wires),
            energy_J=col("energy_J").reshape(-1),
            cost=col("cost").reshape(-1),
            action=np.asarray(actions, dtype=np.float64).reshape(len(infos), -1),
            reward=np.asarray(rewards, dtype=np.float64),
        )

    @property
    def error(self) -> np.ndarray:
        """(n,) tracking error: signed for the planar angle, the Euclidean norm for a vector."""
        e = self.angle_deg - self.target_deg
        return e if e.ndim == 1 else np.linalg.norm(e, axis=1)

    def to_columns(self) -> dict[str, np.ndarray]:
        """Flat columns for a CSV (one row per step)."""
        if self.angle_deg.ndim == 1 and self.voltage.shape[1] == 2:
            return {
                "time_s": self.time,
                "angle_deg": self.angle_deg,
                "target_deg": self.target_deg,
                "voltage_right_V": self.voltage[:, 0],
                "voltage_left_V": self.voltage[:, 1],
                "temperature_right_K": self.temperature[:, 0],
                "temperature_left_K": self.temperature[:, 1],
                "energy_J": self.energy_J,
                "cost": self.cost,
            }
        cols = {"time_s": self.time}
        for name, arr in (("tracked", self.angle_deg), ("target", self.target_deg)):
            for c in range(arr.shape[1]):
                cols[f"{name}_{c}"] = arr[:, c]
        for name, arr in (("voltage_V", self.voltage), ("temperature_K", self.temperature)):
            for w in range(arr.shape[1]):
                cols[f"{name}_{w}"] = arr[:, w]
        return cols | {"energy_J": self.energy_J, "cost": self.cost}


def settling_times(
    time: np.ndarray, angle: np.ndarray, target: np.ndarray, tol_deg: float, min_jump_deg: float = 1.0
) -> np.ndarray:
    """Settling time after each step of a piecewise-constant target [s].

    A step is a jump of the target by more than ``min_jump_deg`` between two samples (for a
    vector target (n, d): of its Euclidean norm, and the error is the norm of the difference). Its settling
    time is the time from the jump until the error enters ``tol_deg`` for good (until the next
    jump or the end). A step that never settles counts its whole segment length, and NaN is
    returned for targets without steps (ramps, sines).
    """
    angle, target = np.asarray(angle, dtype=np.float64), np.asarray(target, dtype=np.float64)
    if target.ndim == 1:
        angle, target = angle[:, None], target[:, None]
    jumps = np.flatnonzero(np.linalg.norm(np.diff(target, axis=0), axis=1) > min_jump_deg) + 1
    if target.shape[0] and np.linalg.norm(target[0]) > min_jump_deg:
        jumps = np.concatenate([[0], jumps])
    if jumps.size == 0:
        return np.array([np.nan])
    # a "step" target is piecewise constant: every sample between jumps equals its segment's value
    bounds = np.concatenate([jumps, [target.shape[0]]])
    out = []
    dt = float(np.median(np.diff(time))) if time.size > 1 else 0.0
    t0_series = time - dt  # the jump is applied with the action that leads to sample k
    for s, e in zip(bounds[:-1], bounds[1:], strict=True):
        seg = slice(s, e)
        if np.max(np.ptp(target[seg], axis=0)) > 1e-9:
            return np.array([np.nan])  # not piecewise constant: not a step target
        err = np.linalg.norm(angle[seg] - target[seg], axis=1)
        outside = np.flatnonzero(err > tol_deg)
        if outside.size == 0:
            out.append(0.0)
        elif outside[-1] == err.size - 1:
            out.append(time[e - 1] - t0_series[s])  # never settled: whole segment
        else:
            out.append(time[s + outside[-1] + 1] - t0_series[s])
    return np.asarray(out)


def episode_metrics(
    traj: Trajectory, *, temperature_limit: float, dt: float, settle_tol_deg: float = 2.0
) -> dict[str, float]:
    """The evaluation-table numbers of one episode.

    Args:
        traj: the episode.
        temperature_limit: wire temperature above which time is counted as over the limit [K].
        dt: control period [s].
        settle_tol_deg: settling band [deg].

    Returns:
        dict with ``rmse_deg``, ``max_error_deg``, ``settling_time_s`` (mean over target steps,
        NaN without steps), ``energy_J``, ``peak_temperature_K``, ``time_over_limit_s``.
    """
    err = traj.error
    st = settling_times(traj.time, traj.angle_deg, traj.target_deg, settle_tol_deg)
    return {
        "rmse_deg": float(np.sqrt(np.mean(err**2))),
        "max_error_deg": float(np.max(np.abs(err))),
        "settling_time_s": float(np.mean(st)) if np.all(np.isfinite(st)) else float("nan"),
        "energy_J": float(np.sum(traj.energy_J)),
        "peak_temperature_K": float(np.max(traj.temperature)),
        "time_over_limit_s": float(dt * np.sum(np.any(traj.temperature > temperature_limit, axis=1))),
    }
