"""``spine-gym``: every subcommand's help, its one-line usage errors before any side effect, the
``python -m`` aliases, the shared ``key=value`` / ``key:value`` syntax and the wheel's top-level names."""

from __future__ import annotations

import argparse
import contextlib
import csv
import importlib
import io
import os
import re
import shutil
import subprocess
import sys
import time
import warnings
import zipfile
from pathlib import Path

import pytest
from repo import ROOT

from spine_gym import cli
from spine_gym.cli_conventions import ENV_IDS, KeyValues, did_you_mean

V0_POLICY = ROOT / "spine_gym" / "agents" / "policies" / "ppo"  # trained on SmaSpine-v0
ECO_POLICY = ROOT / "spine_gym" / "agents" / "policies" / "ppo_3d_v1_eco"  # SmaSpine3D-v1 at a 6-V ceiling
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
TAKES_ENV = ("train", "evaluate", "tune", "benchmark", "datasets")


def run(argv: list[str]) -> int:
    """Exit status of ``spine-gym argv`` run in this process (SystemExit or the returned status)."""
    try:
        return cli.main(argv)
    except SystemExit as e:
        return int(e.code or 0)


def _subprocess(args: list[str], cwd: Path = ROOT) -> subprocess.CompletedProcess:
    return subprocess.run(args, cwd=cwd, env=ENV, capture_output=True, text=True, timeout=240)


# --------------------------------------------------------------------------- help
@pytest.mark.parametrize("name", list(cli.COMMANDS))
def test_every_subcommand_help_exits_0_with_examples_and_shared_options(name, capsys):
    assert run([name, "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: spine-gym {name}")
    assert "examples:" in out and f"spine-gym {name}" in out.split("examples:")[1]
    assert "--out" in out or name == "design"  # design: on its sweep and optimize
    if name in TAKES_ENV:
        assert "--env" in out and all(i in out for i in ENV_IDS)
        assert "--env-kwargs" in out and "--progress, --no-progress" in out


@pytest.mark.parametrize("sub", ["sweep", "optimize"])
def test_design_studies_share_the_options(sub, capsys):
    assert run(["design", sub, "--help"]) == 0
    out = capsys.readouterr().out
    assert "-o DIR, --out DIR" in out and "--workers N, --n-workers N" in out and "--no-progress" in out
    assert "examples:" in out


def test_top_level_help_lists_every_command_with_its_module(capsys):
    assert run(["--help"]) == 0
    out = capsys.readouterr().out
    for name, command in cli.COMMANDS.items():
        assert name in out and cli.alias(command.module) in out
    assert "examples:" in out


def test_train_help_shows_defaults_and_keeps_rl_zoo_aliases(capsys):
    assert run(["train", "--help"]) == 0
    out = capsys.readouterr().out
    assert "-o DIR, --out DIR, -f DIR, --log-folder DIR" in out and "(default: logs)" in out
    assert "-P, --progress, --no-progress" in out and "-params KEY=VALUE" in out


# --------------------------------------------------------------------------- usage errors
BAD = {
    "train unknown env": (["train", "--algo", "ppo", "--env", "SmaSpine-v9"], "did you mean 'SmaSpine-v2'?"),
    "train env case": (["train", "--algo", "ppo", "--env", "smaspine3d-v1"], "did you mean 'SmaSpine3D-v1'?"),
    "train env kwarg name": (
        ["train", "--algo", "ppo", "--env-kwargs", "episode_duraton=3"], "did you mean 'episode_duration'?"
    ),
    "train env kwarg value": (["train", "--algo", "ppo", "--env-kwargs", "episode_duration:-3"], "episode_duration"),
    "train env kwarg syntax": (["train", "--algo", "ppo", "--env-kwargs", "episode_duration"], "key=value"),
    "train hyperparameter": (["train", "--algo", "ppo", "-params", "n_step=64"], "did you mean 'n_steps'?"),
    "train hyperparameter value": (["train", "--algo", "ppo", "-params", "policy_kwargs:dict(net_arch=["], "never closed"),
    "train missing model": (["train", "--algo", "sac", "-i", "missing.zip"], "missing.zip does not exist"),
    "train missing conf": (["train", "--algo", "ppo", "-conf", "missing.yml"], "missing.yml does not exist"),
    "train steps": (["train", "--algo", "ppo", "-n", "0"], "-n must be a positive integer"),
    "train no algo": (["train"], "--algo is required"),
    "train workers 0": (["train", "--algo", "ppo", "--workers", "0"], "must be an integer >= 1"),
    "train model of another env": (
        ["train", "--algo", "ppo", "--env", "SmaSpine-v1", "-i", str(V0_POLICY / "model.zip")],
        "was trained on SmaSpine-v0, not on SmaSpine-v1",
    ),
    "evaluate unknown env": (["evaluate", "--env", "SmaSpin-v1"], "did you mean 'SmaSpine-v1'?"),
    "evaluate controller": (["evaluate", "--baselines", "pdi"], "did you mean 'pid'?"),
    "evaluate missing model": (["evaluate", "--baselines", "--models", "mine=missing"], "missing does not exist"),
    "evaluate env kwarg": (["evaluate", "--env-kwargs", "sensor_dely=1"], "did you mean 'sensor_delay'?"),
    "evaluate model without path": (["evaluate", "--models", "mine"], "--models takes NAME=PATH"),
    "evaluate model of another env": (
        ["evaluate", "--env", "SmaSpine-v1", "--models", f"mine={V0_POLICY}"], "was trained on SmaSpine-v0"
    ),
    "evaluate model at another ceiling": (
        ["evaluate", "--env", "SmaSpine3D-v1", "--models", f"eco={ECO_POLICY}", "--env-kwargs", "v_max=5"],
        "differs from model eco's own v_max=6.0",
    ),
    "benchmark workers 0": (["benchmark", "--quick", "--workers", "0"], "must be an integer >= 1"),
    "calibrate starts 0": (["calibrate", "missing.csv", "--n-starts", "0"], "must be an integer >= 1"),
    "design workers 0": (["design", "sweep", "--param", "a=6e-3,7e-3", "--workers", "0"], "-1 (all cores) or"),
    "tune controller": (["tune", "--controllers", "pdi"], "did you mean 'pid'?"),
    "tune env kwarg": (["tune", "--env-kwargs", "episode_duraton:3"], "did you mean 'episode_duration'?"),
    "benchmark unknown env": (["benchmark", "--env", "SmaSpineHrd-v2"], "did you mean 'SmaSpineHard-v2'?"),
    "benchmark env kwarg": (["benchmark", "--quick", "--env-kwargs", "episode_duraton=3"], "did you mean"),
    "datasets unknown env": (["datasets", "--env", "SmaSpine-v9", "--controller", "pid", "--episodes", "1"], "did you mean"),
    "datasets env kwarg": (
        ["datasets", "--env", "SmaSpine-v1", "--controller", "pid", "--episodes", "1", "--env-kwargs", "bogus=1"],
        "takes no argument 'bogus'",
    ),
    "export missing policy": (["export", "missing_policy"], "missing_policy does not exist"),
    "calibrate missing csv": (["calibrate", "missing.csv"], "missing.csv does not exist"),
    "finetune missing preset": (
        ["finetune", "--preset", "missing.json"], "--preset: missing.json does not exist"
    ),
    "design parameter": (["design", "sweep", "--param", "wire=1,2", "--no-progress"], "unknown design parameter"),
    "unknown command": (["trian"], "did you mean 'train'?"),
}
OUT_OPTION = {"train": ["-o", "out"], "export": ["-o", "out"], "datasets": ["-o", "out"], "design": ["-o", "out"]}


@pytest.mark.parametrize("argv, message", list(BAD.values()), ids=list(BAD))
def test_bad_input_is_one_line_exit_2_and_creates_nothing(argv, message, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # default output folders are relative: any would appear here
    extra = OUT_OPTION.get(argv[0], ["-o", "out"]) if argv[0] in cli.COMMANDS else []
    assert run([*argv, *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and err.startswith("spine-gym"), err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("argv", [["train", "--n-timestep", "10"], ["train", "--algo", "ppo", "--n-timestep", "10"]])
def test_an_abbreviated_option_is_refused_not_taken_for_the_full_one(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert run([*argv, "-o", "out"]) == 2
    err = capsys.readouterr().err
    assert err == "spine-gym train: error: unrecognized arguments: --n-timestep 10\n"
    assert not list(tmp_path.iterdir())


def _parsers(parser: argparse.ArgumentParser):
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from _parsers(sub)


@pytest.mark.parametrize(
    "module", [c.module for c in cli.COMMANDS.values()] + ["spine_gym.agents.behaviour_cloning", "spine_gym.cli"]
)
def test_no_parser_takes_abbreviated_options(module):
    parsers = list(_parsers(importlib.import_module(module).build_parser()))
    assert parsers and all(p.allow_abbrev is False for p in parsers), [p.prog for p in parsers if p.allow_abbrev]


def test_version_prints_the_package_version(capsys):
    import spine_gym

    assert run(["--version"]) == 0
    assert capsys.readouterr().out == f"spine-gym {spine_gym.__version__}\n"


def test_the_program_name_is_set_once():
    assert cli.build_parser().prog == cli.PROG == "spine-gym"
    assert cli.prog_of("train") == "spine-gym train"


def test_tune_refuses_an_existing_file_without_overwrite(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    target = tmp_path / "tuned.yml"
    target.write_text("pid: {}\n")
    assert run(["tune", "-o", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exists; pass --overwrite" in err
    assert [p.name for p in tmp_path.iterdir()] == ["tuned.yml"] and target.read_text() == "pid: {}\n"


def test_tune_writes_a_new_file_by_default_not_the_shipped_one():
    args = importlib.import_module("spine_gym.agents.tune").build_parser().parse_args([])
    assert args.out is None and not args.overwrite  # resolved to results/tune/<shipped name>


def test_reproduce_refuses_an_out_that_is_a_file(tmp_path, capsys):
    f = tmp_path / "file.txt"
    f.write_text("x")
    assert run(["reproduce", "-o", str(f), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is a file, not a folder" in err
    assert [p.name for p in tmp_path.iterdir()] == ["file.txt"]


def test_train_module_bad_kwarg_in_a_subprocess_leaves_no_run_folder(tmp_path):
    proc = _subprocess(
        [sys.executable, "-m", "spine_gym.agents.train", "--algo", "ppo", "--env-kwargs", "bogus:1"], cwd=tmp_path
    )
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "takes no argument 'bogus'" in proc.stderr and not list(tmp_path.iterdir())


# --------------------------------------------------------------------------- the python -m aliases
@pytest.mark.parametrize("name", list(cli.COMMANDS))
def test_modules_keep_their_python_m_names(name):
    module = importlib.import_module(cli.COMMANDS[name].module)
    assert module.build_parser().prog == cli.alias(cli.COMMANDS[name].module)


@pytest.mark.parametrize(
    "module", ["spine_gym.agents.train", "spine_gym.agents.evaluate", "spine_gym.calibrate", "spine_gym.design"]
)
def test_python_m_help_still_works(module):
    proc = _subprocess([sys.executable, "-m", module, "--help"])
    assert proc.returncode == 0 and proc.stdout.startswith(f"usage: python -m {module}"), proc.stderr
    assert "examples:" in proc.stdout


def test_console_script_and_python_m_spine_gym():
    script = Path(sys.executable).with_name("spine-gym")
    commands = [[sys.executable, "-m", "spine_gym", "reproduce", "--help"]]
    if script.exists():  # installed with this checkout's pyproject.toml
        commands.append([str(script), "reproduce", "--help"])
    for command in commands:
        proc = _subprocess(command)
        assert proc.returncode == 0 and proc.stdout.startswith("usage: spine-gym reproduce"), proc.stderr


# --------------------------------------------------------------------------- shared conventions
def test_key_values_take_both_separators_and_literals():
    p = argparse.ArgumentParser()
    p.add_argument("--kw", nargs="+", action=KeyValues)
    got = p.parse_args(["--kw", "a=1", "b:(1, 2)", "c=abc", "d:dict(x=1)", "e=x:y"]).kw
    assert got == {"a": 1, "b": (1, 2), "c": "abc", "d": "dict(x=1)", "e": "x:y"}


def test_did_you_mean():
    assert did_you_mean("SmaSpine-v9", ENV_IDS) == " (did you mean 'SmaSpine-v2'?)"
    assert did_you_mean("zzz", ENV_IDS) == ""


# --------------------------------------------------------------------------- the wheel
def test_wheel_has_only_spine_gym_at_top_level_and_the_console_script(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, src / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc")
    shutil.copytree(ROOT / "spine_gym", src / "spine_gym", ignore=ignore)
    dist = tmp_path / "dist"
    proc = _subprocess(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(dist), str(src)]
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    (wheel,) = dist.glob("spine_gym-*.whl")
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        info = next(n.split("/")[0] for n in names if n.split("/")[0].endswith(".dist-info"))
        entry_points = z.read(f"{info}/entry_points.txt").decode()
        top_level = z.read(f"{info}/top_level.txt").decode().split() if f"{info}/top_level.txt" in names else []
    tops = {n.split("/")[0] for n in names} - {info}
    assert tops == {"spine_gym"} and set(top_level) <= {"spine_gym"}
    assert "spine-gym = spine_gym.cli:main" in entry_points


# --------------------------------------------------------------------------- output folders, models, help text
OUT_CASES = {
    "train": ["train", "--algo", "ppo"],
    "evaluate": ["evaluate", "--suite", "quick"],
    "tune": ["tune"],
    "benchmark": ["benchmark", "--quick"],
    "export": ["export", str(V0_POLICY)],
    "datasets": ["datasets", "--env", "SmaSpine-v1", "--controller", "pid", "--episodes", "1"],
    "reproduce": ["reproduce", "--no-progress"],
    "design": ["design", "sweep", "--param", "a=6e-3,7e-3", "--no-progress"],
}


@pytest.mark.parametrize("argv", list(OUT_CASES.values()), ids=list(OUT_CASES))
def test_an_output_below_a_file_is_one_line_exit_2_before_any_work(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file.txt").write_text("x")
    assert run([*argv, "-o", "file.txt/out" + ("/tuned.yml" if argv[0] == "tune" else "")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "file.txt is a file" in err and "--out" in err, err
    assert [p.name for p in tmp_path.iterdir()] == ["file.txt"]


def test_design_best_of_a_missing_journal_creates_none(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert run(["design", "best", "--storage", "missing.journal"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "missing.journal does not exist" in err and not list(tmp_path.iterdir())


def test_an_unwritable_output_is_refused(tmp_path, capsys):
    from spine_gym.cli_conventions import check_out_dir, check_out_file

    with pytest.raises(ValueError, match="is not writable"):
        check_out_dir("/proc/1/spine-gym-out")  # not writable even by root
    with pytest.raises(ValueError, match="is not writable"):
        check_out_dir("/proc/spine-gym-out")  # /proc's permission bits say yes to root; a real write fails
    with pytest.raises(ValueError, match="is a folder, not a file"):
        check_out_file(tmp_path)
    check_out_dir(tmp_path / "new" / "deeper")  # creatable
    assert not (tmp_path / "new").exists()
    assert list(tmp_path.iterdir()) == []  # the write probe leaves nothing behind


def test_evaluate_defaults_to_the_one_models_env():
    evaluate = importlib.import_module("spine_gym.agents.evaluate")
    args = evaluate.build_parser().parse_args(["--models", f"mine={V0_POLICY}"])
    assert evaluate._env(args) == "SmaSpine-v0"
    args = evaluate.build_parser().parse_args([])
    assert evaluate._env(args) == "SmaSpine-v2"


def test_evaluate_replaces_an_earlier_runs_outputs_and_prints_no_gymnasium_warning(tmp_path, capsys):
    out = tmp_path / "eval"
    for stale in ("plots/old_x.png", "trajectories/old/x.csv", "relative.csv"):
        (out / stale).parent.mkdir(parents=True, exist_ok=True)
        (out / stale).write_text("stale")
    (out / "notes.txt").write_text("mine")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        argv = ["evaluate", "--suite", "quick", "--baselines", "step", "--no-plots", "--no-progress", "-o", str(out)]
        assert run(argv) == 0
    assert not [w for w in caught if "out of date" in str(w.message)]
    assert not (out / "plots").exists() and not (out / "relative.csv").exists()
    assert not (out / "trajectories" / "old").exists() and (out / "notes.txt").read_text() == "mine"
    assert (out / "summary.csv").exists() and (out / "trajectories" / "step").is_dir()
    with open(next((out / "trajectories" / "step").glob("*.csv"))) as f:
        times = [row["time_s"] for row in csv.DictReader(f)]
    digits = [len(re.sub(r"e.*|[-.]", "", t).strip("0")) for t in times]
    assert len(times) > 20 and max(digits) <= 12, times


@pytest.mark.parametrize("name", [*cli.COMMANDS, None])
def test_help_has_no_rest_markup(name, capsys):
    assert run([name, "--help"] if name else ["--help"]) == 0
    out = capsys.readouterr().out
    assert "``" not in out and not re.search(r":[a-z]+:`", out), out


@pytest.mark.slow
def test_train_prints_a_progress_line_and_the_next_step(tmp_path):
    proc = _subprocess(
        [sys.executable, "-m", "spine_gym", "train", "--algo", "ppo", "-n", "256", "--n-envs", "2", "-o", "logs",
         "--eval-freq", "0", "--save-freq", "0", "--no-tensorboard"],
        cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.strip().splitlines()
    assert len(lines) <= 6 and lines[0].startswith("training: "), proc.stdout
    run_folder = tmp_path / "logs" / "ppo" / "SmaSpine-v2_1"
    assert lines[-1].startswith("saved logs/ppo/SmaSpine-v2_1/model.zip after ")
    assert lines[-1].endswith("— next: spine-gym evaluate --models ppo=logs/ppo/SmaSpine-v2_1 --suite quick")
    assert (run_folder / "model.zip").exists()


# --------------------------------------------------------------------------- every --help example, as printed
# The examples are shell lines: each runs with ``bash -c`` in a temporary folder, with this checkout's
# ``spine-gym`` and ``python`` first on ``PATH`` and Minari's data folder inside the temporary folder.
# The examples of one command run in the order printed; the commands whose examples use what another
# command's wrote run after it in one folder (CHAINS): ``evaluate``, ``export`` and ``datasets`` find
# the run folder the ``train`` examples wrote, ``finetune`` the fit the ``calibrate`` examples wrote
# (their "measured" CSVs written first: synthetic, by the model); those of ``spine-gym --help``, a
# train-then-evaluate pair, in a folder of their own. A chain is one test, so that the chains can run
# side by side. An example whose full budget takes minutes gets options appended that shrink it
# (SHRINK; argparse keeps the last value), and two examples stand for a value the user must supply
# (PLACEHOLDERS).
BIN = Path(sys.executable).parent

#: examples that name a value of the user's (a Ray head's address, a command)
PLACEHOLDERS = ("spine-gym benchmark --address HOST:6379", "spine-gym <command> --help")
#: options appended to an example whose full budget takes minutes, or that would use two cores (the
#: tests get one each): (pattern, options), every matching one in turn
SHRINK = (
    # a training budget of 10 k steps or more: one PPO rollout of 8 envs x 256 steps; CrossQ's first updates
    (r"^spine-gym train\b.* -n [0-9]{5,}\b", "-n 2048"),
    (r"^spine-gym tune\b", "--trials 2 --episodes 1"),
    (r"^spine-gym benchmark\b", "--quick --algos ppo --envs SmaSpine-v1 --n-seeds 1 -n 512"),
    (r"^spine-gym reproduce\b(?!.*--quick)", "--quick --no-plots"),
    (r"^spine-gym calibrate\b", "--no-global --n-starts 1 --max-nfev 2 --no-progress"),
    (r"^spine-gym design optimize\b", "--n-trials 3"),
    (r"^spine-gym finetune\b", "--quick"),
    (r"--workers 2\b", "--workers 1"),
)
#: the commands in the order their examples run (train first: the others use its run folder)
ORDER = (
    "train", "evaluate", "export", "datasets", "tune", "benchmark", "reproduce", "calibrate", "finetune", "design"
)  # fmt: skip
#: the commands whose examples run in one folder, in ORDER ("spine-gym": the top-level help's)
CHAINS = {
    "spine-gym": ("spine-gym",),
    "train": ("train", "evaluate", "export", "datasets"),
    "tune": ("tune",),
    "benchmark": ("benchmark",),
    "reproduce": ("reproduce",),
    "calibrate": ("calibrate", "finetune"),
    "design": ("design",),
}


def help_examples(argv: list[str]) -> list[str]:
    """The lines of the ``examples:`` section of ``spine-gym argv --help``."""
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        assert run([*argv, "--help"]) == 0
    lines = text.getvalue().split("examples:\n", 1)[1].splitlines()
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
    import numpy as np

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


def test_every_command_is_in_one_chain():
    chained = [c for chain in CHAINS.values() for c in chain]
    assert sorted(chained) == sorted({c for c, _ in all_examples()}) and len(chained) == len(set(chained))


@pytest.mark.slow
@pytest.mark.parametrize("chain", list(CHAINS))
def test_every_help_example_runs_as_printed(chain, tmp_path):
    if "calibrate" in CHAINS[chain]:
        write_calibration_inputs(tmp_path)
    failures = []
    for command, example in all_examples():
        if command not in CHAINS[chain] or example.startswith(PLACEHOLDERS):
            continue
        line = shrunk(example)
        t0 = time.perf_counter()
        proc = subprocess.run(
            ["bash", "-c", line], cwd=tmp_path, env=_env(tmp_path), capture_output=True, text=True,
            timeout=600,
        )  # fmt: skip
        print(f"{time.perf_counter() - t0:6.1f} s  {line}")  # pytest -s: where the minutes go
        if proc.returncode != 0:
            failures.append(f"{line}\n  exit {proc.returncode}: {proc.stderr.strip()[-800:]}")
    assert not failures, "\n".join(failures)
