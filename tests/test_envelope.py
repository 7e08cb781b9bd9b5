"""The envelope's numbers (:mod:`spine_gym.envelope`) against MODEL.md §8 and the cut-off's spec.

MODEL.md §8 gives the wire at 3.2 V: R 1.874 / 2.343 Ohm (martensite / austenite), I 1.71 / 1.37 A,
P 5.46 / 4.37 W, adiabatic heating 11.2 / 9.0 K/s, thermal time constant 16.9 s, steady rise
without latent heat 189 / 151 K. On the ``-v2`` plant a wire driven at full voltage overshoots the
cut-off by at most one control period's adiabatic heating.
"""

from __future__ import annotations

import numpy as np
import pytest

from spine_gym.envelope import cutoff_drive, electrics, first_time_at, step_drive
from spine_gym.envs.ids import CUTOFF_MARGIN_K, TEMPERATURE_LIMIT_K

CUTOFF = TEMPERATURE_LIMIT_K - CUTOFF_MARGIN_K


def test_electrics_at_the_seeds_voltage_are_model_md_section_8():
    e = electrics(3.2)
    assert (round(e.r_m, 3), round(e.r_a, 3)) == (1.874, 2.343)
    assert (round(e.i_m, 2), round(e.i_a, 2)) == (1.71, 1.37)
    assert (round(e.p_m, 2), round(e.p_a, 2)) == (5.46, 4.37)
    assert (round(e.heating_m, 1), round(e.heating_a, 1)) == (11.2, 9.0)
    assert round(e.tau_th, 1) == 16.9
    assert (round(e.t_steady_m - 293.0), round(e.t_steady_a - 293.0)) == (189, 151)


def test_electrics_scale_with_the_square_of_the_voltage():
    a, b = electrics(2.5), electrics(5.0)
    assert b.i_a == pytest.approx(2 * a.i_a) and b.p_m == pytest.approx(4 * a.p_m)
    assert b.heating_a == pytest.approx(4 * a.heating_a) and b.tau_th == a.tau_th


def test_first_time_at_interpolates_and_says_never():
    t, v = np.array([0.0, 1.0, 2.0]), np.array([0.0, 10.0, 20.0])
    assert first_time_at(t, v, 15.0) == pytest.approx(1.5)
    assert first_time_at(t, v, 0.0) == 0.0
    assert np.isnan(first_time_at(t, v, 21.0))


def test_the_step_drive_transforms_before_it_reaches_the_cutoff_and_settles_near_the_estimate():
    s = step_drive(5.0, duration=120.0, dt=0.05)
    assert 0.0 < s.time_to_transformation() < s.time_to(CUTOFF) < 120.0
    e = electrics(5.0)
    # settled (~7 time constants) between the austenite estimate and the martensite one
    assert e.t_steady_a - 5.0 < s.t_steady < e.t_steady_m


@pytest.mark.parametrize("volts", [5.0, 8.0])
def test_the_cutoff_overshoot_is_at_most_one_period_of_heating(volts):
    t, temp = cutoff_drive(volts, CUTOFF, duration=20.0)
    heating = electrics(volts).heating_m  # the larger of the two phases' rates
    assert CUTOFF <= temp.max() <= CUTOFF + heating * 0.1
    assert temp.max() < TEMPERATURE_LIMIT_K
    _, free = cutoff_drive(volts, None, duration=20.0)
    assert free.max() > TEMPERATURE_LIMIT_K
    assert t[1] - t[0] == pytest.approx(0.1)
