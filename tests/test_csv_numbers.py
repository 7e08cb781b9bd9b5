"""CSV numbers: floats to 12 significant digits, so that a sum of steps reads 3.2."""

import numpy as np

from spine_gym.agents.evaluation import write_csv
from spine_gym.csv_numbers import csv_number


def test_csv_numbers_are_rounded_to_12_significant_digits(tmp_path):
    drift = sum([0.1] * 32)  # 3.2000000000000015
    assert drift != 3.2 and csv_number(drift) == "3.2" and csv_number(3.1999999999999993) == "3.2"
    assert csv_number(np.float32(0.1)) == "0.1" and csv_number(1.234567890123456e-9) == "1.23456789012e-09"
    assert csv_number(float("nan")) == "nan" and csv_number(7) == 7 and csv_number("pid") == "pid"
    write_csv(tmp_path / "t.csv", [{"name": "pid", "t": drift, "e": np.float64(1 / 3)}])
    assert (tmp_path / "t.csv").read_text().splitlines() == ["name,t,e", "pid,3.2,0.333333333333"]
