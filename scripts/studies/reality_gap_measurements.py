"""Write the bench-top "measurements" that calibrate the module of docs/studies/reality_gap/.

The worked example of docs/calibration.md section 8 reads every wire's temperature; a bench spine
rarely has a thermocouple on a 0.1-mm wire. This protocol keeps what a bench measures easily: the
tip bending vector (1° Gaussian noise, a camera) and every wire's resistance (0.05 Ω, the driver's
sense resistor), on the same module (transformation temperatures −4/0/+3/+6 K, wire 1 with 10 %
higher resistivity) under :func:`spine_gym.calibrate.protocols.module_protocol`, noise seed 0.
The fit then leaves wider uncertainties (the preset the study pretrains on)::

    PYTHONPATH=$PWD python scripts/studies/reality_gap_measurements.py results/reality_gap_csv
    spine-gym calibrate results/reality_gap_csv/*.csv --layout seed --params wires \\
        -o results/reality_gap_fit --seed 0 --n-starts 1
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from spine_gym import SpineLayout
from spine_gym.calibrate import synthetic_spatial_experiment
from spine_gym.calibrate.protocols import EXAMPLE_WIRE_VALUES, module_protocol

CHANNELS = ("bend_1", "bend_2") + tuple(f"resistance_{j}" for j in range(4))
NOISE = {"bend": 1.0, "resistance": 0.05}  # [deg], [Ohm]


def main(out: str) -> None:
    truth = SpineLayout.seed().with_wire_values(list(EXAMPLE_WIRE_VALUES))
    rng = np.random.default_rng(0)
    for i, (name, t, v) in enumerate(module_protocol()):
        e = synthetic_spatial_experiment(truth, t, v, channels=CHANNELS, noise=NOISE, rng=rng, name=name)
        print(e.to_csv(Path(out) / f"{i}_{name}.csv"))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/reality_gap_csv")
