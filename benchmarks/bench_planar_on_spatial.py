"""Benchmark: the two-wire planar spine on the spatial core against the planar core, in one run.

The same physical spine (``ModelParams()``: the antagonistic pair of MODEL.md §7) is built twice:
on the planar core (``spine_gym/physics/planar/``) and as ``SpineLayout.planar()`` (wire 0 at 0° =
right, wire 1 at 180° = left) on the spatial core (``spine_gym/physics/spatial/``). Both get the
same inputs and the default solver (coupled step, dense output). Three workloads, each timed with
``time.perf_counter`` (wall) and ``time.process_time`` (CPU of this process), the two cores
alternating call by call (which goes first swaps every repeat), best and median of ``--repeats``:

* ``simulate`` — the 20-s run of ``bench_physics.py`` (MODEL.md §10.2: the right wire stepped to
  3.2 V at t = 0, 10-ms outputs) through ``spine_gym.simulate`` [ms per run];
* ``env_kernel`` — no env runs the two-wire layout (the spatial envs build four-wire
  ``SpineLayout.chain`` modules), so this is the physics of an env step alone, "the kernel alone"
  of ``bench_training_share.py``: ``spine_loops.step_many_serial`` against
  ``step_many_spatial_serial`` (the loops of each core's ``control.step_spine``), 16 spines,
  200 control periods of 0.1 s (the env's default; a 20-s episode) from rest, each spine with its
  own seeded random voltages in [0, 5 V] (``v_max``) on both wires, no external load
  [µs per spine and control period];
* ``mpc_rollouts`` — the MPC's planner kernels, each core's
  ``rollout.rollout_many_serial``: 32 open-loop rollouts of 30 control periods (the default
  MPPI's N and 3-s horizon) from the warm state at the end of the 20-s run, seeded random
  voltages [ms per plan].

Accuracy (the cores must agree, not only be timed): per workload the largest difference of the
bending angle Θ (planar ``angle``; spatial tip bending vector, first component) and of the two wire
temperatures over every output, control period and rollout step, against the gates of
tests/physics/test_spatial_coupled.py (SPATIAL.md §8.3: the two coupled steps linearise slightly
differently, so their step sequences differ): |ΔT| < 1e-3 K everywhere; |ΔΘ| < 1e-4° for the
smooth §10.2 drive (1.7e-5° measured over its 50 s), < 0.1° for drives that switch the wires (the
gate of the whole §10.3 alternate drive, whose snap-through amplifies the difference to 0.006°).
The env-kernel and rollout workloads switch both wires every 0.1 s, so they get the 0.1° gate; the
result also says whether they meet the 1e-4° one.

Writes ``benchmarks/results/planar_on_spatial.json`` and ``.png``; prints a table.

    OMP_NUM_THREADS=1 taskset -c 0 .venv/bin/python benchmarks/bench_planar_on_spatial.py --repeats 41
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import matplotlib
import numba
import numpy as np
from spine_loops import step_many_serial, step_many_spatial_serial  # the sibling module

import spine_gym
from spine_gym import ModelParams, SolverOptions, SpineLayout, simulate
from spine_gym.experiments import hysteresis_voltages
from spine_gym.physics.columns import OK
from spine_gym.physics.planar import columns as PL
from spine_gym.physics.planar import rollout as planar_rollout
from spine_gym.physics.planar.record import OUT_ANGLE, OUT_SIZE
from spine_gym.physics.spatial import columns as SL
from spine_gym.physics.spatial import rollout as spatial_rollout
from spine_gym.physics.spatial.integrate import init_state
from spine_gym.physics.spatial.record import record_size
from spine_gym.physics.spatial.work import sizes
from spine_gym.simulate import initial_state

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after the backend choice

OUT = Path(__file__).resolve().parent / "results"
DURATION = 20.0  # [s] the timed run of bench_physics.py
DT = 0.1  # [s] the envs' default control period (one physics step per control period)
N_SPINES, PERIODS = 16, 200  # env-kernel workload: a native vector env's 16 spines over a 20-s episode
V_MAX = 5.0  # [V] the envs' default v_max
N_ROLLOUTS, HORIZON = 32, 30  # MPPIConfig defaults: 32 samples, 3-s horizon at 0.1 s
# tests/physics/test_spatial_coupled.py, SPATIAL.md §8.3: [deg] smooth drive, drives that switch the
# wires; [K]
GATE_SMOOTH_DEG, GATE_SWITCHING_DEG, GATE_TEMP_K = 1e-4, 0.1, 1e-3
WORKLOADS = {  # name: (unit of the reported time, factor from seconds per call, angle gate [deg])
    "simulate": ("ms per 20-s run", 1e3, GATE_SMOOTH_DEG),
    "env_kernel": ("µs per spine and control period", 1e6 / (N_SPINES * PERIODS), GATE_SWITCHING_DEG),
    "mpc_rollouts": ("ms per 32 × 3-s rollouts", 1e3, GATE_SWITCHING_DEG),
}


class PlanarCore:
    """The pair on the planar core; every workload returns (Θ [deg], T_right [K], T_left [K])."""

    def __init__(self, params: ModelParams, solver: SolverOptions):
        self.params, self.solver = params, solver
        self.kp, self.ks = params.to_kernel(), solver.to_kernel()
        self.rest = initial_state(params, solver)
        self.warm = self.simulate(*inputs()[0])[3]

    def simulate(self, vr, vl):
        r = simulate(DURATION, vr, vl, params=self.params, solver=self.solver)
        return r.angle_deg, r.temperature_right, r.temperature_left, r.final_state

    def env_kernel(self, volts):
        b = volts.shape[1]
        states, backup = np.tile(self.rest, (b, 1)), np.empty((b, self.rest.shape[0]))
        kps, loads = np.tile(self.kp, (b, 1)), np.zeros((b, self.params.n_seg, 2))
        active, status = np.ones(b, dtype=np.bool_), np.empty(b, dtype=np.int64)
        meas = np.empty((volts.shape[0], b, OUT_SIZE))
        for k in range(volts.shape[0]):
            v_r, v_l = volts[k, :, 0].copy(), volts[k, :, 1].copy()
            resolve = np.full(b, k == 0)
            step_many_serial(
                states, backup, kps, self.ks, v_r, v_l, loads, resolve, active, DT, 1, status, meas[k]
            )
            assert (status == OK).all()
        return np.degrees(meas[..., OUT_ANGLE]), meas[..., PL.X_TR], meas[..., PL.X_TL]

    def mpc_rollouts(self, volts):
        b, h, _ = volts.shape
        work, angle = np.empty((b, self.warm.shape[0])), np.empty((b, h))
        temp, joule, status = np.empty((b, h, 2)), np.empty((b, h, 2)), np.empty(b, dtype=np.int64)
        v_r, v_l = volts[:, :, 0].copy(), volts[:, :, 1].copy()
        loads, resolve = np.zeros((h, self.params.n_seg, 2)), np.zeros(h, dtype=np.bool_)
        planar_rollout.rollout_many_serial(
            self.warm, self.kp, self.ks, v_r, v_l, loads, resolve, DT, 1, work, angle, temp, joule, status
        )
        assert (status == OK).all()
        return np.degrees(angle), temp[..., 0], temp[..., 1]


class SpatialCore:
    """The pair as ``SpineLayout.planar()`` on the spatial core (the same three workloads)."""

    def __init__(self, params: ModelParams, solver: SolverOptions):
        self.layout, self.solver = SpineLayout.planar(params), solver
        self.kp, self.kw, self.km = self.layout.to_kernel()
        self.ks = solver.to_kernel()
        self.nw, self.nm, self.ns = sizes(self.kw, self.km)
        self.rec_size = record_size(self.nw, self.nm, self.ns)
        self.bend = SL.sens_offset(self.nw, self.nm, self.ns) + 2 * self.nm  # record: tip bending vector
        self.temp = SL.wire_offset(SL.F_T, self.nw)  # record = state head: wire temperatures
        self.rest = np.zeros(self.layout.state_size())
        assert init_state(self.rest, self.kp, self.ks, self.kw, self.km, np.zeros((self.ns, 3))) == OK
        self.warm = self.simulate(*inputs()[0])[3]

    def simulate(self, vr, vl):
        r = simulate(DURATION, np.stack([vr, vl], axis=1), layout=self.layout, solver=self.solver)
        return r.tip_bending_deg[:, 0], r.temperature[:, 0], r.temperature[:, 1], r.final_state

    def _rows(self, rec):
        return np.degrees(rec[..., self.bend]), rec[..., self.temp], rec[..., self.temp + 1]

    def env_kernel(self, volts):
        b = volts.shape[1]
        states, backup = np.tile(self.rest, (b, 1)), np.empty((b, self.rest.shape[0]))
        kps, kws, kms = np.tile(self.kp, (b, 1)), np.stack([self.kw] * b), np.stack([self.km] * b)
        loads = np.zeros((b, self.ns, 3))
        active, status = np.ones(b, dtype=np.bool_), np.empty(b, dtype=np.int64)
        rec = np.empty((volts.shape[0], b, self.rec_size))
        for k in range(volts.shape[0]):
            v, resolve = volts[k], np.full(b, k == 0)
            step_many_spatial_serial(
                states, backup, kps, self.ks, kws, kms, v, loads, resolve, active, DT, 1, status, rec[k]
            )
            assert (status == OK).all()
        return self._rows(rec)

    def mpc_rollouts(self, volts):
        b, h, _ = volts.shape
        work, rec = np.empty((b, self.warm.shape[0])), np.empty((b, h, self.rec_size))
        status = np.empty(b, dtype=np.int64)
        loads, resolve = np.zeros((h, self.ns, 3)), np.zeros(h, dtype=np.bool_)
        spatial_rollout.rollout_many_serial(
            self.warm, self.kp, self.ks, self.kw, self.km, volts, loads, resolve, DT, 1, work, rec, status
        )
        assert (status == OK).all()
        return self._rows(rec)


def inputs() -> list[tuple]:
    """The arguments of the workloads simulate, env_kernel, mpc_rollouts (the same for both cores)."""
    vr, vl = (v[: int(round(DURATION / 0.01))].copy() for v in hysteresis_voltages())
    rng = np.random.default_rng(0)
    return [
        (vr, vl),
        (rng.uniform(0.0, V_MAX, (PERIODS, N_SPINES, 2)),),
        (rng.uniform(0.0, V_MAX, (N_ROLLOUTS, HORIZON, 2)),),
    ]


def accuracy(planar: tuple, spatial: tuple, gate_deg: float) -> dict:
    """Largest |Θ_spatial − Θ_planar| [deg] and |ΔT| of either wire [K], against the gates."""
    d_angle = float(np.abs(spatial[0] - planar[0]).max())
    d_temp = float(max(np.abs(spatial[j] - planar[j]).max() for j in (1, 2)))
    return {
        "max_abs_angle_diff_deg": d_angle,
        "max_abs_temp_diff_K": d_temp,
        "gate_angle_deg": gate_deg,
        "gate_temp_K": GATE_TEMP_K,
        "passes": d_angle < gate_deg and d_temp < GATE_TEMP_K,
        "within_smooth_drive_gate": d_angle < GATE_SMOOTH_DEG,
    }


def timed(call, args) -> tuple[float, float]:
    """(wall, CPU) seconds of one call."""
    w0, c0 = time.perf_counter(), time.process_time()
    call(*args)
    return time.perf_counter() - w0, time.process_time() - c0


def summary(samples: dict, factor: float) -> dict:
    """Best and median, wall and CPU, per core in the workload's unit, and spatial / planar."""
    out = {}
    for core, runs in samples.items():
        for i, clock in enumerate(("wall", "cpu")):
            vals = [r[i] * factor for r in runs]
            out[f"{core}_{clock}_best"] = min(vals)
            out[f"{core}_{clock}_median"] = statistics.median(vals)
    for clock in ("wall", "cpu"):
        for stat in ("best", "median"):
            out[f"ratio_{clock}_{stat}"] = out[f"spatial_{clock}_{stat}"] / out[f"planar_{clock}_{stat}"]
    return out


def machine() -> dict:
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout
    return {
        "cpu_count": os.cpu_count(),
        "load_average_start": os.getloadavg(),
        "python": platform.python_version(),
        "numba": numba.__version__,
        "numpy": np.__version__,
        "spine_gym": spine_gym.__version__,
        "git_commit": commit.strip() or "unknown",
    }


def plot(res: dict, path: Path) -> None:
    fig, (ax_t, ax_r) = plt.subplots(1, 2, figsize=(10, 4))
    names = list(WORKLOADS)
    x = np.arange(len(names))
    for k, core in enumerate(("planar", "spatial")):
        vals = [res[n]["time"][f"{core}_cpu_median"] for n in names]
        ax_t.bar(x + 0.38 * (k - 0.5), vals, 0.36, label=f"{core} core")
    ax_t.set_xticks(x, [f"{n}\n[{WORKLOADS[n][0]}]".replace(" per ", "\nper ") for n in names], fontsize=7)
    ax_t.set_ylabel("process CPU time, median (units below)")
    ax_t.legend(loc="upper left")
    for k, clock in enumerate(("cpu", "wall")):
        vals = [res[n]["time"][f"ratio_{clock}_median"] for n in names]
        ax_r.bar(x + 0.38 * (k - 0.5), vals, 0.36, label=f"{clock} time")
    ax_r.axhline(1.0, color="k", lw=0.8)
    ax_r.set_xticks(x, names)
    ax_r.set_ylabel("spatial / planar (medians)")
    ax_r.set_ylim(0.0, 2.8)
    ax_r.legend(loc="upper left", ncols=2)
    fig.suptitle("two-wire spine: SpineLayout.planar() on the spatial core vs the planar core", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=41)
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    params, solver = ModelParams(), SolverOptions()
    cores = {"planar": PlanarCore(params, solver), "spatial": SpatialCore(params, solver)}  # compiles
    work = dict(zip(WORKLOADS, inputs(), strict=True))
    # one call of each: compiles, and the accuracy (the same numbers every repeat)
    res = {
        n: {"accuracy": accuracy(*(getattr(c, n)(*a)[:3] for c in cores.values()), WORKLOADS[n][2])}
        for n, a in work.items()
    }
    mach = machine()
    samples = {n: {c: [] for c in cores} for n in WORKLOADS}
    for rep in range(args.repeats):
        order = list(cores) if rep % 2 == 0 else list(cores)[::-1]
        for name, a in work.items():
            for c in order:
                samples[name][c].append(timed(getattr(cores[c], name), a))
    mach["load_average_end"] = os.getloadavg()
    print(
        f"{'workload':13s} {'unit':33s} {'planar cpu':>10s} {'spatial cpu':>11s} {'ratio cpu':>9s} "
        f"{'ratio wall':>10s}  |ΔΘ| [deg] (gate)   |ΔT| [K] (gate)"
    )
    for name, (unit, factor, gate) in WORKLOADS.items():
        t = res[name]["time"] = summary(samples[name], factor)
        a = res[name]["accuracy"]
        print(
            f"{name:13s} {unit:33s} {t['planar_cpu_median']:10.3f} {t['spatial_cpu_median']:11.3f} "
            f"{t['ratio_cpu_median']:9.2f} {t['ratio_wall_median']:10.2f}  "
            f"{a['max_abs_angle_diff_deg']:.1e} ({gate:g})  "
            f"{a['max_abs_temp_diff_K']:.1e} ({GATE_TEMP_K:g}) {'ok' if a['passes'] else 'FAILS'}"
        )
    units = {n: u for n, (u, _, _) in WORKLOADS.items()}
    out = {"settings": {"repeats": args.repeats, "units": units}, "machine": mach, "results": res}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "planar_on_spatial.json").write_text(json.dumps(out, indent=2))
    plot(res, args.out / "planar_on_spatial.png")
    return 0 if all(r["accuracy"]["passes"] for r in res.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
