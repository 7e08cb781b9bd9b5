"""``spine-gym``: every subcommand's help, its one-line usage errors before any side effect, the
``python -m`` aliases, the shared ``key=value`` / ``key:value`` syntax and the wheel's top-level names."""

from __future__ import annotations

import argparse
import importlib
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from repo import ROOT

from spine_gym import cli
from spine_gym.cli_conventions import ENV_IDS, KeyValues, did_you_mean

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
    "train unknown env": (["train", "--algo", "ppo", "--env", "SmaSpine-v9"], "did you mean 'SmaSpine-v1'?"),
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
    "evaluate unknown env": (["evaluate", "--env", "SmaSpin-v1"], "did you mean 'SmaSpine-v1'?"),
    "evaluate controller": (["evaluate", "--baselines", "pdi"], "did you mean 'pid'?"),
    "evaluate missing model": (["evaluate", "--baselines", "--models", "mine=missing"], "missing does not exist"),
    "evaluate env kwarg": (["evaluate", "--env-kwargs", "sensor_dely=1"], "did you mean 'sensor_delay'?"),
    "tune controller": (["tune", "--controllers", "pdi"], "did you mean 'pid'?"),
    "tune env kwarg": (["tune", "--env-kwargs", "episode_duraton:3"], "did you mean 'episode_duration'?"),
    "benchmark unknown env": (["benchmark", "--env", "SmaSpineHard-v2"], "did you mean 'SmaSpineHard-v1'?"),
    "benchmark env kwarg": (["benchmark", "--quick", "--env-kwargs", "episode_duraton=3"], "did you mean"),
    "datasets unknown env": (["datasets", "--env", "SmaSpine-v9", "--controller", "pid", "--episodes", "1"], "did you mean"),
    "datasets env kwarg": (
        ["datasets", "--env", "SmaSpine-v1", "--controller", "pid", "--episodes", "1", "--env-kwargs", "bogus=1"],
        "takes no argument 'bogus'",
    ),
    "export missing policy": (["export", "missing_policy"], "missing_policy does not exist"),
    "calibrate missing csv": (["calibrate", "missing.csv"], "missing.csv does not exist"),
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
    assert err.count("\n") == 1 and "out_dir must be a directory" in err
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
    assert did_you_mean("SmaSpine-v9", ENV_IDS) == " (did you mean 'SmaSpine-v1'?)"
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
