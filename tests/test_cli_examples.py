"""Every example of every ``--help`` (``spine-gym --help`` and each subcommand's) runs as printed.

The examples are shell lines: each runs with ``bash -c`` in a temporary folder, with this checkout's
``spine-gym`` and ``python`` first on ``PATH`` and Minari's data folder inside the temporary folder.
The examples of one command run in the order printed, those of all commands in one folder, so that
``evaluate``, ``export`` and ``datasets`` find the run folder the ``train`` examples wrote; the
calibration's "measured" CSVs are written first (synthetic, by the model). An example whose full
budget takes minutes gets options appended that shrink it (:data:`SHRINK`, argparse keeps the last
value), and two examples stand for a value the user must supply (:data:`PLACEHOLDERS`).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spine_gym import cli

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent

#: examples that name a value of the user's (a Ray head's address, a command)
PLACEHOLDERS = ("spine-gym benchmark --address HOST:6379", "spine-gym <command> --help")
#: options appended to an example whose full budget takes minutes, or that would use two cores (the
#: tests get one each): (pattern, options), every matching one in turn
SHRINK = (
    (r"^spine-gym tune\b", "--trials 2 --episodes 1"),
    (r"^spine-gym benchmark\b", "--quick --algos ppo --envs SmaSpine-v1 --n-seeds 1 -n 512"),
    (r"^spine-gym reproduce\b(?!.*--quick)", "--quick --no-plots"),
    (r"^spine-gym calibrate\b", "--no-global --n-starts 1 --max-nfev 2 --no-progress"),
    (r"^spine-gym design optimize\b", "--n-trials 3"),
    (r"--workers 2\b", "--workers 1"),
)
#: the commands in the order their examples run (train first: the others use its run folder)
ORDER = ("train", "evaluate", "export", "datasets", "tune", "benchmark", "reproduce", "calibrate", "design")


def help_examples(argv: list[str]) -> list[str]:
    """The lines of the ``examples:`` section of ``spine-gym argv --help``."""
    proc = subprocess.run(
        [sys.executable, "-m", "spine_gym", *argv, "--help"], capture_output=True, text=True, env=_env(ROOT)
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.split("examples:\n", 1)[1].splitlines()
    return [s.strip() for s in lines if s.startswith("  ") and s.strip()]


def all_examples() -> list[tuple[str, str]]:
    """(command, example) of every ``--help``; a design subcommand's examples are in ``design``'s."""
    out = [("spine-gym", e) for e in help_examples([])]
    for name in ORDER:
        out += [(name, e) for e in help_examples([name])]
    assert set(ORDER) == set(cli.COMMANDS)
    return list(dict.fromkeys(out))


def shrunk(example: str) -> str:
    """``example`` with the :data:`SHRINK` options that match it appended (before its comment)."""
    code = example.partition("  #")[0].rstrip()
    extra = [options for pattern, options in SHRINK if re.search(pattern, code)]
    return " ".join([code, *extra]) if extra else example


def _env(cwd: Path) -> dict:
    return {
        **os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ['PATH']}", "PYTHONPATH": str(ROOT),
        "OMP_NUM_THREADS": "1", "MINARI_DATASETS_PATH": str(cwd / "minari"), "MPLBACKEND": "Agg",
    }  # fmt: skip


def write_calibration_inputs(folder: Path) -> None:
    """The "measured" CSVs the calibrate examples read: two planar runs (the model with its baseline
    parameters, noise seeded) and the spatial worked example's files."""
    from spine_gym.calibrate import synthetic_experiment
    from spine_gym.params import PRESETS

    t = np.arange(0.0, 20.0 + 1e-9, 0.1)
    for i, volts in enumerate((3.2, 2.8), start=1):
        drive = np.where(t < 10.0, volts, 0.0)
        e = synthetic_experiment(
            PRESETS["baseline"](), t, drive, 0.0, channels=("angle", "temperature_right"),
            rng=np.random.default_rng(i), name=f"run{i}",
        )  # fmt: skip
        e.to_csv(folder / f"run{i}.csv")
    script = ROOT / "scripts" / "spatial_calibration_example.py"
    proc = subprocess.run(
        [sys.executable, str(script), "results/spatial_example"], cwd=folder, env=_env(folder),
        capture_output=True, text=True,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr


def test_the_examples_name_only_runnable_commands():
    examples = [e for _, e in all_examples()]
    assert len(examples) >= 25
    for e in examples:
        assert e.startswith(("spine-gym ", "python -m spine_gym")), e
    assert all(any(e.startswith(p) for e in examples) for p in PLACEHOLDERS)


@pytest.mark.slow
def test_every_help_example_runs_as_printed(tmp_path):
    top = tmp_path / "top"  # spine-gym --help's examples: a pair of their own (train, then evaluate it)
    shared = tmp_path / "commands"
    top.mkdir()
    shared.mkdir()
    write_calibration_inputs(shared)
    failures = []
    for command, example in all_examples():
        if example.startswith(PLACEHOLDERS):
            continue
        folder = top if command == "spine-gym" else shared
        line = shrunk(example)
        proc = subprocess.run(
            ["bash", "-c", line], cwd=folder, env=_env(folder), capture_output=True, text=True, timeout=600
        )
        if proc.returncode != 0:
            failures.append(f"{line}\n  exit {proc.returncode}: {proc.stderr.strip()[-800:]}")
    assert not failures, "\n".join(failures)
