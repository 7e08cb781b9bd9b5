"""Demonstration datasets in Minari's format: a controller's episodes on a spine_gym env.

Example (``spine-gym datasets`` is the same command)::

    python -m spine_gym.agents.datasets --env SmaSpine-v1 SmaSpine3D-v1 --controller pid --episodes 20
    python -m spine_gym.agents.datasets --env SmaSpine-v1 --controller mpc_oracle --episodes 10 \\
        --env-kwargs episode_duration:30.0 --data-path runs/minari

One dataset per env id, named ``spine_gym/<env id>/<controller>-v<version>``; what is recorded, the
seeds, the metadata and where the datasets go: :mod:`spine_gym.agents.minari_datasets`, the
library this command line runs. An existing dataset id is refused unless ``--overwrite``.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from spine_gym import cli_conventions as cli

# the library's names stay importable from here for one release (they moved to .minari_datasets)
from .minari_datasets import (  # noqa: F401
    DATASET_SEED_BASE,
    MAX_DATASET_EPISODES,
    NAMESPACE,
    DatasetPlan,
    data_dir,
    dataset_dir,
    dataset_id,
    datasets_path,
    load_metadata,
    plan,
    record,
    transitions,
)
from .policy_files import check_policy_env

__all__ = ["build_parser", "main"]


#: this command's name as ``python -m <module>`` (``spine-gym <command>`` passes its own ``prog``)
PROG = cli.module_prog(__spec__.name)

EXAMPLES = """
spine-gym datasets --env SmaSpine-v1 SmaSpine3D-v1 --controller pid --episodes 2
spine-gym datasets --env SmaSpine-v1 --controller mpc_oracle --episodes 1 --env-kwargs episode_duration=2.0
spine-gym datasets --env SmaSpine-v2 --controller logs/ppo/SmaSpine-v2_1 --episodes 2 -o runs/minari
"""


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    p = cli.Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES)
    cli.add_env(
        p, nargs="+", required=True, help="env id(s), one dataset each; any of: " + ", ".join(cli.ENV_IDS)
    )
    p.add_argument(
        "--controller", required=True, help="registry name (pid, mpc_oracle, ...) or policy folder"
    )
    p.add_argument(
        "--episodes", type=int, required=True, help=f"episodes per dataset (1..{MAX_DATASET_EPISODES})"
    )
    cli.add_env_kwargs(p, nargs="*")
    p.add_argument(
        "--seed-base", type=int, default=DATASET_SEED_BASE, help="first reset seed (default: %(default)s)"
    )
    p.add_argument("--version", type=int, default=0, help="the dataset id's version (default: %(default)s)")
    cli.add_out(
        p, "--data-path", dest="data_path",
        help="Minari data directory (default: MINARI_DATASETS_PATH, else ~/.minari/datasets)",
    )  # fmt: skip
    p.add_argument("--overwrite", action="store_true", help="replace an existing dataset of the same id")
    p.add_argument("--no-infos", action="store_true", help="do not record the env's info dicts")
    cli.add_progress(p)
    return p


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """Run the CLI; exit status 0, or 2 (one line on stderr) on a bad argument, before anything is
    recorded or written."""
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(prog)
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # argparse's exit (2 on a bad argument, 0 after --help)
        return int(e.code or 0)
    command = f"{PROG} " + " ".join(shlex.quote(a) for a in argv)
    try:
        cli.check_out_dir(args.data_path or data_dir(), "--out/--data-path")
    except ValueError as e:
        print(f"{parser.prog}: error: {e}", file=sys.stderr)
        return 2
    if len(set(args.env)) != len(args.env):
        print(f"{parser.prog}: error: --env names an id twice: {args.env}", file=sys.stderr)
        return 2
    with datasets_path(args.data_path):
        try:
            for e in args.env:
                cli.check_env_kwargs(e, args.env_kwargs)
                if Path(args.controller).exists():
                    check_policy_env(args.controller, e, "--controller")
            plans = [
                plan(e, args.controller, args.episodes, env_kwargs=args.env_kwargs,
                     seed_base=args.seed_base, version=args.version, overwrite=args.overwrite)
                for e in args.env
            ]  # fmt: skip
        except ValueError as e:
            print(f"{parser.prog}: error: {cli.first_line(e)}", file=sys.stderr)
            return 2
        for p in plans:
            ds = record(p, record_infos=not args.no_infos, progress=args.progress, command=command)
            meta = load_metadata(ds)
            print(
                f"{p.dataset_id}: {ds.total_episodes} episodes, {ds.total_steps} steps, "
                f"mean RMSE {meta['mean_rmse']:.3f}, mean energy {meta['mean_energy_J']:.2f} J -> "
                f"{dataset_dir(p.dataset_id)}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
