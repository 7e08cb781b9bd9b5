"""Documented measurement protocols of the spatial calibration (the tested identifiability case and
the worked example in docs/calibration.md use the same one).

:func:`module_protocol`: a four-wire module, every wire pulsed alone, then the two adjacent pairs
(0+1, 2+3: bends toward 45° and 225°); each experiment ``on`` s at ``volts`` then ``off`` s
unpowered, sampled every ``dt``. The single pulses separate each wire's heating (resistivity) and
transformation temperature; the pairs load two wires against the same shape.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MODULE_PULSES", "MODULE_CHANNELS", "EXAMPLE_WIRE_VALUES", "module_protocol"]

MODULE_PULSES = ((0,), (1,), (2,), (3,), (0, 1), (2, 3))  # powered wires per experiment
# what the protocol records: the tip bending vector and every wire's temperature and resistance
MODULE_CHANNELS = (
    ("bend_1", "bend_2")
    + tuple(f"temperature_{j}" for j in range(4))
    + tuple(f"resistance_{j}" for j in range(4))
)
# the module of the identifiability test and of the worked example: transformation temperatures
# −4/0/+3/+6 K, wire 1 with 10 % higher resistivity (SpineLayout.with_wire_values)
EXAMPLE_WIRE_VALUES = (
    {"T_shift": -4.0},
    {"T_shift": 0.0, "lam_scale": 1.1},
    {"T_shift": 3.0},
    {"T_shift": 6.0},
)


def module_protocol(
    volts: float = 3.2, on: float = 15.0, off: float = 15.0, dt: float = 0.1, n_wires: int = 4
) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """[(name, time (n,), voltages (n, W))] of the protocol (names ``pulse_0``, ``pair_01`` …)."""
    t = np.arange(int(round((on + off) / dt)) + 1) * dt
    out = []
    for wires in MODULE_PULSES:
        v = np.zeros((t.size, n_wires))
        v[np.ix_(t < on - 1e-9, list(wires))] = volts
        name = f"pulse_{wires[0]}" if len(wires) == 1 else "pair_" + "".join(map(str, wires))
        out.append((name, t, v))
    return out
