"""``spine-gym``: one command line for every job of the package, with one convention.

Each subcommand is the command line of a module (its own ``build_parser``/``main``), which still
runs as ``python -m <module>``::

    spine-gym train      -> python -m spine_gym.agents.train
    spine-gym evaluate   -> python -m spine_gym.agents.evaluate
    spine-gym tune       -> python -m spine_gym.agents.tune
    spine-gym benchmark  -> python -m spine_gym.agents.benchmark
    spine-gym design     -> python -m spine_gym.design
    spine-gym calibrate  -> python -m spine_gym.calibrate
    spine-gym reproduce  -> python -m spine_gym.experiments
    spine-gym export     -> python -m spine_gym.agents.export
    spine-gym datasets   -> python -m spine_gym.agents.datasets
    spine-gym finetune   -> python -m spine_gym.agents.finetune

The shared options (:mod:`spine_gym.cli_conventions`): ``-o/--out`` the output folder, ``--env`` a
registered spine env id, ``--env-kwargs k=v`` (``k:v`` too), ``--progress/--no-progress``,
``--workers``; defaults in ``--help`` with an ``examples:`` section. Arguments are checked before any
folder is made or work starts; a bad one is one line on stderr and exit status 2. The subcommand's
module is imported only when it runs, so ``spine-gym --help`` does not load torch. Docs: docs/cli.md.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from dataclasses import dataclass

import spine_gym
from spine_gym.cli_conventions import PROG, Parser, did_you_mean, module_prog

__all__ = ["PROG", "COMMANDS", "Command", "build_parser", "main", "prog_of"]


@dataclass(frozen=True)
class Command:
    """A subcommand: the module whose ``main(argv, prog)`` runs it, what it does, where it writes."""

    module: str
    summary: str
    writes: str


COMMANDS: dict[str, Command] = {
    "train": Command(
        "spine_gym.agents.train", "train PPO, SAC, TD3 or TQC on a spine env", "logs/<algo>/<env id>_<k>/"
    ),
    "evaluate": Command(
        "spine_gym.agents.evaluate", "run baselines and saved policies on the scenario suite", "results/eval/"
    ),
    "tune": Command(
        "spine_gym.agents.tune", "tune the PID and bang-bang baselines (Optuna)", "results/tune/<file>.yml"
    ),
    "benchmark": Command(
        "spine_gym.agents.benchmark", "RL algorithms x env ids at fixed budgets, with CIs", "results/benchmark/"
    ),
    "design": Command(
        "spine_gym.design.__main__", "design sweeps and constrained optimisation", "runs/design/..."
    ),
    "calibrate": Command(
        "spine_gym.calibrate.__main__", "fit model parameters to measured CSV experiments", "results/calibration/"
    ),
    "reproduce": Command(
        "spine_gym.experiments", "reproduce the paper's experiments (MODEL.md §10)", "runs/experiments/"
    ),
    "export": Command("spine_gym.agents.export", "export a policy as ONNX, NumPy and C", "-o (required)"),
    "datasets": Command(
        "spine_gym.agents.datasets", "record Minari datasets of a controller", "~/.minari/datasets/"
    ),
    "finetune": Command(
        "spine_gym.agents.finetune",
        "pretrain on a calibration's uncertainty, fine-tune on a shifted plant",
        "results/reality_gap/",
    ),
}

EXAMPLES = f"""
{PROG} train --algo ppo --env SmaSpine-v2 -n 20000 -o logs     # a first run (the YAML's budget without -n)
{PROG} evaluate --suite quick --models mine=logs/ppo/SmaSpine-v2_1
{PROG} reproduce --quick -o runs/repro
{PROG} <command> --help             # the options of one command
"""


def alias(module: str) -> str:
    """``python -m`` form of a command's module."""
    return module_prog(module)


def prog_of(name: str) -> str:
    """The program name of command ``name`` in its usage and errors: ``spine-gym <name>``."""
    return f"{PROG} {name}"


def _table() -> str:
    rows = [f"  {name:<10} {c.summary} ({alias(c.module)})" for name, c in COMMANDS.items()]
    return "commands:\n" + "\n".join(rows)


def command(text: str) -> str:
    """argparse ``type`` of the command name."""
    if text in COMMANDS:
        return text
    raise argparse.ArgumentTypeError(
        f"unknown command {text!r}{did_you_mean(text, COMMANDS)}; choose from {', '.join(COMMANDS)}"
    )


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=PROG,
        description="One command line for every job of spine_gym, with one convention.\n\n" + _table(),
        examples=EXAMPLES,
    )
    p.add_argument("command", type=command, metavar="COMMAND", help="one of: " + ", ".join(COMMANDS))
    p.add_argument("args", nargs=argparse.REMAINDER, help=f"its arguments ({PROG} COMMAND --help)")
    p.add_argument("--version", action="version", version=f"%(prog)s {spine_gym.__version__}")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``spine-gym`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv:
        parser.error(f"give a command, one of: {', '.join(COMMANDS)} ({PROG} --help)")
    args = parser.parse_args(argv)
    module = importlib.import_module(COMMANDS[args.command].module)
    return module.main(args.args, prog=prog_of(args.command))


if __name__ == "__main__":
    sys.exit(main())
