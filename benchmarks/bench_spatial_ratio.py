"""Benchmark: process-CPU-time cost of the spatial 20-s runs as ratios to the planar default.

The three 20-s runs of ``bench_physics.py`` (planar default; the seed four-wire module with wire 0
at the MODEL.md §10.2 drive; the two-module chain with wire 0 of the lower and wire 1 of the upper
module at the drive scaled to their wire length), timed round-robin in one process with
``time.process_time`` (CPU time of this process: less sensitive than wall time to the other jobs of a
shared machine), median of ``repeats``. Prints one JSON line: per run the median [ms], sub-steps,
µs per sub-step and the ratio to the planar run. No accuracy gate here: ``bench_physics.py`` has it.

A/B against another commit (what docs/SPATIAL.md §8.7 reports): export it and alternate processes,

    git archive main spine_gym | tar -x -C /tmp/spine_main
    for i in 1 2 3 4; do
      SPINE_GYM_TREE=/tmp/spine_main .venv/bin/python benchmarks/bench_spatial_ratio.py 9
      .venv/bin/python benchmarks/bench_spatial_ratio.py 9
    done

``PYTHONPATH`` alone does not do it: the editable install's import finder (``sys.meta_path``) is
asked before ``sys.path``, so ``spine_gym`` would still come from the checkout. With
``SPINE_GYM_TREE`` set, this script drops that finder and imports ``spine_gym`` from the given tree
(it prints which one on stderr).
"""

from __future__ import annotations

import json
import os
import statistics
import sys
import time

import numpy as np

if os.environ.get("SPINE_GYM_TREE"):  # A/B against an exported tree (module docstring)
    sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in repr(f).lower()]
    sys.path.insert(0, os.environ["SPINE_GYM_TREE"])

import spine_gym  # noqa: E402 - after the optional tree switch
from spine_gym import SpineLayout, simulate  # noqa: E402
from spine_gym.experiments import hysteresis_voltages  # noqa: E402

DURATION = 20.0  # [s] the timed run of bench_physics.py
DT = 0.01  # [s] output step


def runs() -> dict:
    """name → a call of one 20-s run (as bench_physics.py's planar default, spatial and chain runs)."""
    n = int(round(DURATION / DT))
    vr, vl = (v[:n].copy() for v in hysteresis_voltages())
    seed = SpineLayout.seed()
    v_seed = np.zeros((n, seed.n_wires))
    v_seed[:, 0] = vr
    chain = SpineLayout.chain(2)
    v_chain = np.zeros((n, chain.n_wires))
    v_chain[:, 0] = vr * chain.voltage_scale[0]
    v_chain[:, 5] = vr * chain.voltage_scale[5]
    return {
        "planar": lambda: simulate(DURATION, vr, vl),
        "module": lambda: simulate(DURATION, v_seed, layout=seed),
        "chain": lambda: simulate(DURATION, v_chain, layout=chain),
    }


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    repeats = int(args[0]) if args else 9
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    print(f"spine_gym from {spine_gym.__file__}", file=sys.stderr)
    calls = runs()
    first = {k: c() for k, c in calls.items()}  # compile / load, and the sub-step counts
    times: dict[str, list[float]] = {k: [] for k in calls}
    for _ in range(repeats):
        for k, c in calls.items():
            t0 = time.process_time()
            c()
            times[k].append(time.process_time() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    out = {
        k: {
            "median_ms": 1e3 * med[k],
            "substeps": int(first[k].substeps),
            "us_per_substep": 1e6 * med[k] / first[k].substeps,
            "ratio_to_planar": med[k] / med["planar"],
        }
        for k in calls
    }
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
