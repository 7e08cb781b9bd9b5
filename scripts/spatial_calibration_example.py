"""Write the "measured" CSVs of the spatial worked example in docs/calibration.md.

A four-wire module whose wires differ (transformation temperatures −4/0/+3/+6 K, wire 1 with 10 %
higher resistivity) under :func:`spine_gym.calibrate.protocols.module_protocol`, with the tip
bending vector (0.5° Gaussian noise), every wire's temperature (1 K) and resistance (0.01 Ω),
noise seed 0::

    PYTHONPATH=$PWD .venv/bin/python scripts/spatial_calibration_example.py results/spatial_example
    .venv/bin/python -m spine_gym.calibrate results/spatial_example/*.csv --layout seed --params wires \\
        --out results/spatial_example/fit --seed 0 --n-starts 1
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from spine_gym import SpineLayout
from spine_gym.calibrate import synthetic_spatial_experiment
from spine_gym.calibrate.protocols import EXAMPLE_WIRE_VALUES, MODULE_CHANNELS, module_protocol


def main(out: str) -> None:
    truth = SpineLayout.seed().with_wire_values(list(EXAMPLE_WIRE_VALUES))
    rng = np.random.default_rng(0)
    for i, (name, t, v) in enumerate(module_protocol()):
        e = synthetic_spatial_experiment(truth, t, v, channels=MODULE_CHANNELS, rng=rng, name=name)
        print(e.to_csv(Path(out) / f"{i}_{name}.csv"))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/spatial_example")
