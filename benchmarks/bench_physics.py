"""Benchmark: speed and accuracy of the physics core on the 20-s hysteresis run (MODEL.md §6, §10.2).

The seed paper needed "under one minute" for 20 s of simulated time at a 0.01 s step. The target
of this project: the 20-s run (right wire at 3.2 V, 0–20 s of the §10.2 hysteresis run)
in ≤ 5 ms on one core after compilation, with the angle within 0.5° of the fine-step reference at
every output.

Measured in one process, interleaved round-robin so that machine load hits every peer alike
(median and minimum of ``--repeats`` runs, ``time.perf_counter``):

* ``newton``    — default :class:`SolverOptions` (coupled Newton composite solve, coupled linearly
  implicit phase step with error-controlled sub-steps, tol_x = 1e-4, sub-steps across the held
  output steps with dense output, dense_h_max = 50 ms: MODEL.md §6.5);
* ``stepped``   — ``SolverOptions(dense_output=False)``: the same step cut at every 10-ms output
  (the default before dense output);
* ``dense_h*``  — the default with another ``dense_h_max`` (0.1 s, 0.02 s, inf: only tol_x limits
  the sub-steps across outputs): the accuracy/speed trade-off of the cap;
* ``frozen``    — ``SolverOptions(scheme="frozen")``: the default before the coupled step, MODEL.md
  §6.1 as written (rates frozen over a sub-step, r·h <= c = 0.01): the slow reference scheme;
* ``illinois``  — ``SolverOptions(method="illinois")`` (bracketed regula falsi);
* ``bisect``    — ``SolverOptions(method="bisect")``, the seed's algorithm (MODEL.md §5.2);
* ``reference`` — :data:`spine_gym.params.FINE_REFERENCE`: frozen rates, fixed 0.1-ms sub-steps (§6.2).

For each: median/min/quartiles [s], ratio to the default, sub-steps and shape passes, time per
simulated second, per sub-step and per output step (2 000), and the maximum |Θ − Θ_reference|
over the run. Also the whole 50-s hysteresis run (default, stepped, frozen) against its own
fine-step reference, and the §10.3/§10.4 gates of the default, the ``dense_h*`` variants, stepped
and frozen. On a loaded machine the times are upper bounds; the ratios (same run, interleaved) are
what carries over.

Spatial core (SPATIAL.md), 20-s runs timed in the same round-robin, as ratios to the planar default,
each with the default (coupled, MODEL.md §6.5, dense output) step, stepped to every output
(``*_stepped``) and with ``scheme="frozen"`` (``*_frozen``):

* ``spatial``  — :meth:`SpineLayout.seed` (one four-wire module), wire 0 at the §10.2 drive, the other
  three unpowered: the planar run on the generic core (its |Θ − Θ_reference| is reported too);
* ``chain``    — :meth:`SpineLayout.chain` (two four-wire modules, 8 wires), wire 0 of the lower and
  wire 1 of the upper module at the drive scaled to their wire length (3.2 V × 0.5): a 3-D bend.

Each is printed beside its target (≤ 2× and ≤ 4× the planar default), split into the
sub-step count ratio × the cost-per-sub-step ratio, with its error against the spatial fine-step
reference on the same layout (FINE_REFERENCE, run once, not timed): the maximum over the run of
|tip bending vector − reference| [deg].

Compile times: a subprocess with ``NUMBA_CACHE_DIR`` pointed at an empty temporary folder times
``import spine_gym``, the first planar ``simulate()`` call and then the first spatial one (a 20-s
module run; cold: numba compiles every kernel and writes the cache); a second subprocess with the
same folder times the same (cached: numba loads machine code). Compile time = first call − a warm
call in the same subprocess.

Writes ``benchmarks/results/physics_speed.json`` and ``benchmarks/results/physics_speed.png``.

    .venv/bin/python benchmarks/bench_physics.py [--repeats 21] [--compile-repeats 1] [--no-compile]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from spine_gym import ModelParams, SolverOptions, SpineLayout, simulate
from spine_gym.capacity import capacity_metrics
from spine_gym.experiments import (
    ALTERNATE_REFERENCE,
    ALTERNATE_SWING_TIMES,
    ANGLE_TOL_DEG,
    CAPACITY_REFERENCE,
    SWING_TOL_DEG,
    alternate_voltages,
    hysteresis_voltages,
)
from spine_gym.experiments.references import CAPACITY_FIELDS
from spine_gym.params import FINE_REFERENCE
from spine_gym.plotting import plot_timings

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
DURATION = 20.0  # [s] simulated time of the timed run
PAPER_SECONDS = 60.0  # [s] the seed's "under one minute" for 20 s (an upper bound, Table 3 lost)
TARGET_SECONDS = 0.005  # [s] project target per 20-s run
TARGET_ANGLE_DEG = 0.5  # [deg] accuracy target against the fine-step reference

CONFIGS = {
    "newton": SolverOptions(),
    "stepped": SolverOptions(dense_output=False),
    "dense_h0.1": SolverOptions(dense_h_max=0.1),
    "dense_h0.02": SolverOptions(dense_h_max=0.02),
    "dense_hinf": SolverOptions(dense_h_max=math.inf),
    "frozen": SolverOptions(scheme="frozen"),
    "illinois": SolverOptions(method="illinois"),
    "bisect": SolverOptions(method="bisect"),
    "reference": FINE_REFERENCE,
}
LABELS = {
    "newton": "newton + coupled step + dense output (default)",
    "stepped": "newton + coupled step, stepped to every output",
    "dense_h0.1": "default, dense_h_max = 0.1 s",
    "dense_h0.02": "default, dense_h_max = 0.02 s",
    "dense_hinf": "default, dense_h_max = inf (tol_x only)",
    "frozen": "newton + frozen rates, c = 0.01 (before)",
    "illinois": "illinois + coupled step",
    "bisect": "bisect (seed's solve) + coupled step",
    "reference": "fine-step reference (h = 0.1 ms)",
}

SPATIAL_LABELS = {
    "spatial": "spatial module (4 wires), coupled + dense (default)",
    "spatial_stepped": "spatial module (4 wires), coupled, stepped",
    "spatial_frozen": "spatial module (4 wires), frozen rates",
    "chain": "spatial 2-module chain (8 wires), coupled + dense",
    "chain_stepped": "spatial 2-module chain (8 wires), coupled, stepped",
    "chain_frozen": "spatial 2-module chain (8 wires), frozen",
}
SPATIAL_TARGETS = {"spatial": 2.0, "chain": 4.0}  # run time / the planar default's
SPATIAL_SOLVERS = {
    "": SolverOptions(),
    "_stepped": SolverOptions(dense_output=False),
    "_frozen": SolverOptions(scheme="frozen"),
}


def _spatial_runs(vr: np.ndarray) -> dict[str, tuple[SpineLayout, np.ndarray, SolverOptions]]:
    """(layout, (n, W) voltages, solver) of the spatial 20-s runs (see the module docstring)."""
    seed = SpineLayout.seed()
    v_seed = np.zeros((vr.shape[0], seed.n_wires))
    v_seed[:, 0] = vr
    chain = SpineLayout.chain(2)
    v_chain = np.zeros((vr.shape[0], chain.n_wires))
    scale = chain.voltage_scale
    v_chain[:, 0] = vr * scale[0]
    v_chain[:, 4 + 1] = vr * scale[5]
    return {
        base + suffix: (lay, v, solver)
        for base, (lay, v) in {"spatial": (seed, v_seed), "chain": (chain, v_chain)}.items()
        for suffix, solver in SPATIAL_SOLVERS.items()
    }


_COMPILE_SCRIPT = r"""
import json, sys, time
t0 = time.perf_counter()
import spine_gym
from spine_gym import SpineLayout, simulate
t1 = time.perf_counter()
simulate(20.0, 3.2, 0.0)
t2 = time.perf_counter()
simulate(20.0, 3.2, 0.0)
t3 = time.perf_counter()
lay = SpineLayout.seed()
simulate(20.0, (3.2, 0.0, 0.0, 0.0), layout=lay)
t4 = time.perf_counter()
simulate(20.0, (3.2, 0.0, 0.0, 0.0), layout=lay)
t5 = time.perf_counter()
print(json.dumps({"import_s": t1 - t0, "first_call_s": t2 - t1, "warm_call_s": t3 - t2,
                  "spatial_first_call_s": t4 - t3, "spatial_warm_call_s": t5 - t4}))
"""


def _inputs(duration: float) -> tuple[np.ndarray, np.ndarray]:
    vr, vl = hysteresis_voltages()
    n = int(round(duration / 0.01))
    return vr[:n].copy(), vl[:n].copy()


def _time_interleaved(
    configs: dict, vr, vl, duration: float, repeats: int, spatial: dict | None = None
) -> dict[str, list[float]]:
    """Round-robin timings of the planar ``configs`` (name → SolverOptions) and ``spatial`` runs."""
    calls = {
        name: (lambda s=solver: simulate(duration, vr, vl, solver=s)) for name, solver in configs.items()
    }
    for name, (layout, volts, solver) in (spatial or {}).items():
        calls[name] = lambda lay=layout, v=volts, s=solver: simulate(duration, v, layout=lay, solver=s)
    times: dict[str, list[float]] = {k: [] for k in calls}
    for _ in range(repeats):
        for name, call in calls.items():
            t0 = time.perf_counter()
            call()
            times[name].append(time.perf_counter() - t0)
    return times


def _gates(solver: SolverOptions) -> dict:
    """MODEL.md §10.3 alternate drive and §10.4 capacity rows: worst |model − table| / tolerance."""
    vr, vl = alternate_voltages()
    alt = simulate(vr.shape[0] * 0.01, vr, vl, solver=solver)
    worst_alt = 0.0
    for t, ref in ALTERNATE_REFERENCE.items():
        tol = SWING_TOL_DEG if t in ALTERNATE_SWING_TIMES else ANGLE_TOL_DEG
        worst_alt = max(worst_alt, abs(alt.angle_deg[alt.at(t)] - ref) / tol)
    worst_cap = 0.0
    rows = {}
    for case, (changes, ref) in CAPACITY_REFERENCE.items():
        m = capacity_metrics(ModelParams(**changes), solver=solver)
        for key, field, _label, _unit, tol, rel in CAPACITY_FIELDS:
            got = getattr(m, field)
            dev = abs(got - ref[key]) / (tol * abs(ref[key]) if rel else tol)
            rows[f"{case}: {key}"] = float(got)
            worst_cap = max(worst_cap, dev)
    return {
        "alternate_worst_deviation_over_tolerance": worst_alt,
        "capacity_worst_deviation_over_tolerance": worst_cap,
        "capacity_values": rows,
        "pass": bool(worst_alt <= 1.0 and worst_cap <= 1.0),
    }


def _stats(ts: list[float]) -> dict[str, float]:
    q = np.percentile(ts, [25, 75])
    return {
        "median_s": statistics.median(ts),
        "min_s": min(ts),
        "q25_s": float(q[0]),
        "q75_s": float(q[1]),
        "repeats": len(ts),
    }


def _compile_times(repeats: int) -> dict:
    """Cold (empty NUMBA_CACHE_DIR) and cached (same dir again) subprocess timings."""
    cold, cached, cache_bytes, cache_files = [], [], [], []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory(prefix="numba_cache_") as d:
            env = dict(os.environ, NUMBA_CACHE_DIR=d)
            for bucket in (cold, cached):
                out = subprocess.run(
                    [sys.executable, "-c", _COMPILE_SCRIPT],
                    capture_output=True,
                    text=True,
                    env=env,
                    cwd=ROOT,
                    check=True,
                )
                bucket.append(json.loads(out.stdout.strip().splitlines()[-1]))
            files = [p for p in Path(d).rglob("*") if p.is_file()]
            cache_files.append(len(files))
            cache_bytes.append(sum(p.stat().st_size for p in files))

    def summary(runs):
        first = [r["first_call_s"] for r in runs]
        warm = [r["warm_call_s"] for r in runs]
        sp_first = [r["spatial_first_call_s"] for r in runs]
        sp_warm = [r["spatial_warm_call_s"] for r in runs]
        return {
            "import_s": statistics.median(r["import_s"] for r in runs),
            "first_call_s": statistics.median(first),
            "warm_call_s": statistics.median(warm),
            "compile_or_load_s": statistics.median(f - w for f, w in zip(first, warm, strict=True)),
            "spatial_first_call_s": statistics.median(sp_first),
            "spatial_compile_or_load_s": statistics.median(
                f - w for f, w in zip(sp_first, sp_warm, strict=True)
            ),
            "runs": runs,
        }

    return {
        "method": "subprocess: import spine_gym; simulate(20 s) twice, then a 20-s spatial module run "
        "twice; NUMBA_CACHE_DIR = fresh empty temp dir",
        "cold": summary(cold),
        "cached": summary(cached),
        "cache_files": cache_files,
        "cache_bytes": cache_bytes,
    }


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _git_commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=ROOT, check=True
        )
        return out.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=21, help="timed runs per configuration (>= 15)")
    ap.add_argument("--compile-repeats", type=int, default=1, help="cold/cached subprocess pairs")
    ap.add_argument("--no-compile", action="store_true", help="skip the compile-time subprocesses")
    ap.add_argument("--out", type=Path, default=RESULTS, help="results folder (default: %(default)s)")
    args = ap.parse_args(argv)
    if args.repeats < 15:
        ap.error(f"--repeats must be >= 15, got {args.repeats}")
    if args.compile_repeats < 1:
        ap.error(f"--compile-repeats must be >= 1, got {args.compile_repeats}")

    load_before = os.getloadavg()[0]
    vr, vl = _inputs(DURATION)
    # warm-up: compile (or load from cache) every kernel and get reference trajectories
    runs = {name: simulate(DURATION, vr, vl, solver=s) for name, s in CONFIGS.items()}
    ref = runs["reference"]
    spatial_runs = _spatial_runs(vr)
    spatial_out = {
        name: simulate(DURATION, v, layout=lay, solver=s) for name, (lay, v, s) in spatial_runs.items()
    }
    print("spatial fine-step references (FINE_REFERENCE, once each) ...", flush=True)
    spatial_ref = {
        name: simulate(DURATION, v, layout=lay, solver=FINE_REFERENCE)
        for name, (lay, v, _s) in spatial_runs.items()
        if name in SPATIAL_TARGETS
    }

    print(f"timing the {DURATION:g}-s hysteresis run, {args.repeats} interleaved repeats ...", flush=True)
    times = _time_interleaved(CONFIGS, vr, vl, DURATION, args.repeats, spatial_runs)
    base = statistics.median(times["newton"])
    results = {}
    for name, r in runs.items():
        st = _stats(times[name])
        diff = np.abs(r.angle_deg - ref.angle_deg)
        results[name] = {
            "label": LABELS[name],
            "solver": {
                k: (v if not (isinstance(v, float) and math.isinf(v)) else "inf")
                for k, v in vars(CONFIGS[name]).items()
            },
            **st,
            "ratio_to_default": st["median_s"] / base,
            "substeps": r.substeps,
            "shape_passes": r.shape_passes,
            "ms_per_simulated_s": st["median_s"] * 1e3 / DURATION,
            "us_per_substep": st["median_s"] * 1e6 / r.substeps,
            "us_per_output_step": st["median_s"] * 1e6 / (len(r) - 1),
            "angle_at_20s_deg": float(r.angle_deg[-1]),
            "max_abs_angle_diff_to_reference_deg": float(diff.max()),
            "time_of_max_diff_s": float(r.time[int(diff.argmax())]),
            "ratio_paper_60s_to_this": PAPER_SECONDS / st["median_s"],
        }

    spatial = {}
    for name, r in spatial_out.items():
        st = _stats(times[name])
        sref = spatial_ref[name.split("_")[0]]
        spatial[name] = {
            "label": SPATIAL_LABELS[name],
            "scheme": spatial_runs[name][2].scheme,
            "wires": r.layout.n_wires,
            "modules": r.layout.n_modules,
            "segments": r.layout.n_seg,
            **st,
            "ratio_to_planar_default": st["median_s"] / base,
            "ratio_to_planar_default_by_min": st["min_s"] / results["newton"]["min_s"],
            "target_ratio": SPATIAL_TARGETS.get(name),
            "max_abs_bending_diff_to_spatial_reference_deg": float(
                np.abs(r.tip_bending_deg - sref.tip_bending_deg).max()
            ),
            "substep_ratio_to_planar_default": r.substeps / runs["newton"].substeps,
            "us_per_substep_ratio_to_planar_default": (st["median_s"] / r.substeps)
            / (base / runs["newton"].substeps),
            "substeps": r.substeps,
            "shape_passes": r.shape_passes,
            "ms_per_simulated_s": st["median_s"] * 1e3 / DURATION,
            "us_per_substep": st["median_s"] * 1e6 / r.substeps,
            "tip_theta_at_20s_deg": float(r.tip_theta_deg[-1]),
        }
    for name in ("spatial", "spatial_stepped", "spatial_frozen"):
        seed_diff = np.abs(spatial_out[name].tip_bending_deg[:, 0] - ref.angle_deg)
        spatial[name]["max_abs_angle_diff_to_planar_reference_deg"] = float(seed_diff.max())

    # the whole 50-s hysteresis run (heating + cooling) with the default solver
    vr50, vl50 = hysteresis_voltages()
    full_ref = simulate(50.0, vr50, vl50, solver=CONFIGS["reference"])
    peers50 = {k: CONFIGS[k] for k in ("newton", "stepped", "frozen")}
    t50 = _time_interleaved(peers50, vr50, vl50, 50.0, args.repeats)
    hyst50 = {}
    for k, solver in peers50.items():
        full = simulate(50.0, vr50, vl50, solver=solver)
        hyst50[k] = {
            **_stats(t50[k]),
            "substeps": full.substeps,
            "ms_per_simulated_s": statistics.median(t50[k]) * 1e3 / 50.0,
            "max_abs_angle_diff_to_reference_deg": float(np.abs(full.angle_deg - full_ref.angle_deg).max()),
        }

    print("MODEL.md §10.3 / §10.4 gates ...", flush=True)
    gates = {k: _gates(CONFIGS[k]) for k in CONFIGS if k not in ("illinois", "bisect", "reference")}
    compile_info = None if args.no_compile else _compile_times(args.compile_repeats)
    load_after = os.getloadavg()[0]
    d = results["newton"]
    summary = {
        "default_median_ms": d["median_s"] * 1e3,
        "target_ms": TARGET_SECONDS * 1e3,
        "meets_time_target": d["median_s"] <= TARGET_SECONDS,
        "default_min_ms": d["min_s"] * 1e3,
        "meets_time_target_by_min": d["min_s"] <= TARGET_SECONDS,
        "speedup_vs_stepped": results["stepped"]["median_s"] / d["median_s"],
        "speedup_vs_stepped_by_min": results["stepped"]["min_s"] / d["min_s"],
        "max_angle_diff_50s_deg": hyst50["newton"]["max_abs_angle_diff_to_reference_deg"],
        "default_passes_gates": gates["newton"]["pass"],
        "speedup_vs_frozen_before": results["frozen"]["median_s"] / d["median_s"],
        "speedup_vs_frozen_before_by_min": results["frozen"]["min_s"] / d["min_s"],
        "max_angle_diff_deg": d["max_abs_angle_diff_to_reference_deg"],
        "meets_accuracy_target": d["max_abs_angle_diff_to_reference_deg"] <= TARGET_ANGLE_DEG,
        "speedup_vs_bisect_seed_algorithm": results["bisect"]["median_s"] / d["median_s"],
        "speedup_vs_illinois": results["illinois"]["median_s"] / d["median_s"],
        "speedup_vs_fine_step_reference": results["reference"]["median_s"] / d["median_s"],
        "ratio_paper_60s_to_default": PAPER_SECONDS / d["median_s"],
        "ratio_paper_60s_to_bisect": PAPER_SECONDS / results["bisect"]["median_s"],
        "ms_per_simulated_s": d["ms_per_simulated_s"],
        "substeps": d["substeps"],
        "spatial_module_ratio_to_planar": spatial["spatial"]["ratio_to_planar_default"],
        "chain_ratio_to_planar": spatial["chain"]["ratio_to_planar_default"],
        "spatial_module_frozen_ratio_to_planar": spatial["spatial_frozen"]["ratio_to_planar_default"],
        "chain_frozen_ratio_to_planar": spatial["chain_frozen"]["ratio_to_planar_default"],
    }
    if compile_info:
        summary["cold_compile_s"] = compile_info["cold"]["compile_or_load_s"]
        summary["cached_load_s"] = compile_info["cached"]["compile_or_load_s"]
        summary["spatial_cold_compile_s"] = compile_info["cold"]["spatial_compile_or_load_s"]
        summary["spatial_cached_load_s"] = compile_info["cached"]["spatial_compile_or_load_s"]
        summary["spatial_cached_first_call_s"] = compile_info["cached"]["spatial_first_call_s"]
    report = {
        "benchmark": "20-s hysteresis run (right wire 3.2 V, MODEL.md §10.2), dt = 10 ms output step",
        "note": (
            "ratio_paper_60s_*: the seed only states '< 60 s' for 20 s (its Table 3 is lost) on 2014 "
            "hardware/software, so this is the ratio to that bound, not to a measured seed time"
        ),
        "summary": summary,
        "configs": results,
        "spatial": spatial,
        "hysteresis_50s": hyst50,
        "gates_10_3_10_4": gates,
        "compile": compile_info,
        "machine": {
            "cpu_count": os.cpu_count(),
            "cpus_usable": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
            "cpu_model": _cpu_model(),
            "platform": platform.platform(),
            "python": platform.python_version(),
            "numpy": np.__version__,
            "numba": numba.__version__,
            "numba_threading_layer_threads": numba.config.NUMBA_NUM_THREADS,
            "load_average_1min_before": load_before,
            "load_average_1min_after": load_after,
        },
        "git_commit": _git_commit(),
        "date": time.strftime("%Y-%m-%d %H:%M:%S"),
        "timer": "time.perf_counter, single thread (simulate runs one serial jitted loop)",
    }
    args.out.mkdir(parents=True, exist_ok=True)
    js = args.out / "physics_speed.json"
    js.write_text(json.dumps(report, indent=2, ensure_ascii=False))

    names = list(results)
    labels = [LABELS[n] for n in names]
    secs = [results[n]["median_s"] for n in names]
    ann = []
    for n in names:
        r = results[n]
        ann.append(f"×{r['ratio_to_default']:.1f}, max|ΔΘ| {r['max_abs_angle_diff_to_reference_deg']:.3f}°")
    for r in spatial.values():
        labels.append(r["label"])
        secs.append(r["median_s"])
        ann.append(
            f"×{r['ratio_to_planar_default']:.2f} of planar, "
            f"max|Δ| {r['max_abs_bending_diff_to_spatial_reference_deg']:.3f}°"
        )
    png = plot_timings(
        labels,
        secs,
        args.out / "physics_speed.png",
        target_s=TARGET_SECONDS,
        target_label="target",
        annotations=ann,
        title=f"20-s hysteresis run, median of {args.repeats} (×: ratio to default)",
        errors={
            LABELS[n]: (runs[n].time, runs[n].angle_deg - ref.angle_deg) for n in names if n != "reference"
        },
        errors_ylabel="Θ − Θ_reference [deg]",
    )

    print(
        f"{'config':<50} {'median ms':>9} {'min ms':>7} {'ratio':>6} {'substeps':>8} {'us/sub':>7} "
        f"{'us/out':>7} {'max|dΘ| deg':>11}  (spatial rows: ratio to the planar default; error vs the "
        "spatial reference)"
    )
    for n in names:
        r = results[n]
        print(
            f"{r['label']:<50} {r['median_s'] * 1e3:9.2f} {r['min_s'] * 1e3:7.2f} "
            f"{r['ratio_to_default']:6.2f} {r['substeps']:8d} {r['us_per_substep']:7.2f} "
            f"{r['us_per_output_step']:7.2f} {r['max_abs_angle_diff_to_reference_deg']:11.4f}"
        )
    for r in spatial.values():
        print(
            f"{r['label']:<50} {r['median_s'] * 1e3:9.2f} {r['min_s'] * 1e3:7.2f} "
            f"{r['ratio_to_planar_default']:6.2f} {r['substeps']:8d} {r['us_per_substep']:7.2f} "
            f"{r['max_abs_bending_diff_to_spatial_reference_deg']:11.4f}"
        )
    for k, h in hyst50.items():
        print(
            f"50-s hysteresis run ({LABELS[k]}): {h['median_s'] * 1e3:.2f} ms (min {h['min_s'] * 1e3:.2f}), "
            f"{h['substeps']} sub-steps, max|dΘ| {h['max_abs_angle_diff_to_reference_deg']:.4f} deg"
        )
    for k, g in gates.items():
        print(
            f"gates ({LABELS[k]}): §10.3 alternate worst |dev|/tol "
            f"{g['alternate_worst_deviation_over_tolerance']:.2f}, "
            f"§10.4 capacity worst |dev|/tol {g['capacity_worst_deviation_over_tolerance']:.2f} "
            f"-> {'pass' if g['pass'] else 'FAIL'}"
        )
    for name, r in spatial.items():
        if r["target_ratio"] is None:
            continue
        met = "met" if r["ratio_to_planar_default"] <= r["target_ratio"] else "NOT met"
        fz = spatial[name + "_frozen"]
        print(
            f"{r['label']}: {r['ratio_to_planar_default']:.2f}x the planar default (by min "
            f"{r['ratio_to_planar_default_by_min']:.2f}x; target <= {r['target_ratio']:g}x, {met})"
            f" = sub-steps {r['substep_ratio_to_planar_default']:.2f}x, "
            f"cost per sub-step {r['us_per_substep_ratio_to_planar_default']:.2f}x; frozen scheme "
            f"{fz['ratio_to_planar_default']:.2f}x; max|d bending| to the spatial fine reference "
            f"{r['max_abs_bending_diff_to_spatial_reference_deg']:.4f} deg (frozen "
            f"{fz['max_abs_bending_diff_to_spatial_reference_deg']:.4f} deg)"
        )
    print(
        f"default: {summary['ms_per_simulated_s']:.3f} ms per simulated s; "
        f"target ≤ {TARGET_SECONDS * 1e3:g} ms "
        f"{'met' if summary['meets_time_target'] else 'NOT met'}; accuracy ≤ {TARGET_ANGLE_DEG}° "
        f"{'met' if summary['meets_accuracy_target'] else 'NOT met'}; "
        f"min {summary['default_min_ms']:.2f} ms; stepped / default = "
        f"{summary['speedup_vs_stepped']:.2f}x (median), {summary['speedup_vs_stepped_by_min']:.2f}x (min); "
        f"frozen (before) / default = "
        f"{summary['speedup_vs_frozen_before']:.2f}x (median), "
        f"{summary['speedup_vs_frozen_before_by_min']:.2f}x (min); "
        f"60 s / default = {summary['ratio_paper_60s_to_default']:.0f}x; "
        f"bisect / default = {summary['speedup_vs_bisect_seed_algorithm']:.1f}x"
    )
    if compile_info:
        print(
            f"compile: cold {compile_info['cold']['compile_or_load_s']:.2f} s "
            f"(import {compile_info['cold']['import_s']:.2f} s), cached load "
            f"{compile_info['cached']['compile_or_load_s']:.3f} s "
            f"(import {compile_info['cached']['import_s']:.2f} s); spatial kernels: cold "
            f"{compile_info['cold']['spatial_compile_or_load_s']:.2f} s, cached load "
            f"{compile_info['cached']['spatial_compile_or_load_s']:.3f} s (cached first spatial call "
            f"{compile_info['cached']['spatial_first_call_s']:.3f} s)"
        )
    print(f"wrote {js} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
