"""Reproducible tuning of the bang-bang and PID baselines on training scenarios only.

Example (``spine-gym tune`` is the same command)::

    python -m spine_gym.agents.tune --trials 60 --episodes 8 --seed 0      # writes results/tune/baselines.yml
    python -m spine_gym.agents.tune --env SmaSpine3D-v0 --controllers pid  # results/tune/baselines_SmaSpine3D-v0.yml
    python -m spine_gym.agents.tune --env SmaSpine-v0 -o spine_gym/controllers/tuned/baselines.yml --overwrite  # the shipped gains

An existing output file is refused unless ``--overwrite`` (which replaces the tuned controllers'
entries and keeps the others).

The objective (``--objective``, :data:`OBJECTIVES`) is a mean over ``--episodes`` episodes of the env
(``--env``, default ``SmaSpine-v1``) drawn by the env's own samplers (random targets and loads)
with reset seeds ``TRAIN_SEED_BASE + i`` — the same distribution the RL agents train on, and
disjoint from the evaluation suite's seeds (:data:`spine_gym.agents.scenarios.EVAL_SEED_BASE`):

* ``rmse`` — the tracking RMSE [deg; mm for the chain's tip position];
* ``rmse_energy`` — the RMSE plus the energy term of the env's own reward in the same unit:
  ``error_scale × energy_weight × mean(E_step / E_ref)`` (the exchange rate of tracking error
  against energy the RL agents are trained with: 5° per unit of normalised step energy on the
  ``-v1``/``-v2`` ids, 10 mm on the chain), so a gain set cannot win by burning energy.

Optuna's TPE sampler is seeded, every trial sees the same episodes and the rollouts are
deterministic, so the same command gives the same gains. The hand-set start point and the gains
in use (:func:`load_tuned`) are tried first. On ids without a thermal cut-off in the plant the
controllers cut a wire whose temperature reaches the env's limit minus :data:`GUARD_MARGIN_K` (as
in the evaluation); on the ``-v2`` ids the plant's cut-off is the only protection.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import yaml

from spine_gym import cli_conventions as cli
from spine_gym.controllers.registry import GUARD_MARGIN_K, load_tuned, tunable_for, tuned_file

from .tuning import OBJECTIVES, TRAIN_SEED_BASE, energy_exchange_rate, episode_score, objective_value, tune
from .zoo_config import DEFAULT_ENV_ID

__all__ = [
    "tune",
    "objective_value",
    "episode_score",
    "energy_exchange_rate",
    "OBJECTIVES",
    "load_tuned",
    "TRAIN_SEED_BASE",
    "GUARD_MARGIN_K",
]

#: this command's name as ``python -m <module>`` (``spine-gym <command>`` passes its own ``prog``)
PROG = cli.module_prog(__spec__.name)

EXAMPLES = """
spine-gym tune --trials 60 --episodes 8 --seed 0      # writes results/tune/baselines.yml
spine-gym tune --env SmaSpine3D-v0 --controllers pid -o results/tune/pid_3d.yml
spine-gym tune --env SmaSpine-v0 -o spine_gym/controllers/tuned/baselines.yml --overwrite   # the shipped gains
"""
DEFAULT_OUT = Path("results/tune")  # the default output folder (the file is named after the shipped one)


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    p = cli.Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES)
    cli.add_env(p, default=DEFAULT_ENV_ID)
    p.add_argument(
        "--controllers", nargs="+", default=None, help="tuned registry entries (default: all of --env)"
    )
    p.add_argument("--trials", type=int, default=60, help="Optuna trials per controller")
    p.add_argument("--episodes", type=int, default=8, help="training episodes per trial")
    p.add_argument("--seed", type=int, default=0, help="TPE sampler seed")
    p.add_argument(
        "--objective", choices=OBJECTIVES, default="rmse",
        help="rmse, or rmse_energy: the RMSE plus the env reward's energy term in the same unit",
    )  # fmt: skip
    cli.add_env_kwargs(p)
    cli.add_out(
        p, metavar="FILE",
        help=f"output YAML (default: {DEFAULT_OUT}/<name of the env's shipped file>, e.g. {DEFAULT_OUT}/baselines.yml)",
    )  # fmt: skip
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="update an existing --out (the tuned controllers' entries are replaced, the others kept)",
    )
    cli.add_progress(p)
    return p


def _check(args) -> Path:
    """The output file, every argument checked (ValueError, one line) before any tuning."""
    tunable = list(tunable_for(args.env))
    args.controllers = tunable if args.controllers is None else args.controllers
    cli.check_keys(args.controllers, tunable, "--controllers", what=f"tuned controller of {args.env}")
    if args.trials < 1:
        raise ValueError(f"--trials must be >= 1, got {args.trials}")
    if not 1 <= args.episodes <= 10_000:
        raise ValueError(f"--episodes must be in [1, 10000], got {args.episodes}")
    out = Path(args.out) if args.out else DEFAULT_OUT / tuned_file(args.env).name
    if out.is_dir():
        raise ValueError(f"--out {out} is a folder; give a file name (.yml)")
    cli.check_out_file(out)
    if out.exists() and not args.overwrite:
        raise ValueError(f"--out {out} exists; pass --overwrite to update it or give another --out")
    cli.check_env_kwargs(args.env, args.env_kwargs)
    return out


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """Run the CLI; exit status 0 (the record is the YAML file written). Usage errors exit with
    status 2 before any tuning."""
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    with cli.usage_errors(parser):
        out = _check(args)
    command = f"{PROG} " + " ".join(sys.argv[1:] if argv is None else argv)
    record = yaml.safe_load(out.read_text()) if out.exists() else {}
    for kind in args.controllers:
        rec = tune(
            kind, n_trials=args.trials, n_episodes=args.episodes, seed=args.seed, env_id=args.env,
            env_kwargs=args.env_kwargs, verbose=args.progress, objective=args.objective,
        )  # fmt: skip
        rec["command"] = command
        record[kind] = rec
        best = rec.get("train_rmse_deg", rec.get("train_score"))
        print(f"{kind}: {rec['params']} (train {args.objective} {best})")
    header = (
        "# Tuned baseline settings, written by spine_gym/agents/tune.py (see its docstring); do not edit by hand.\n"
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(header + yaml.safe_dump(record, sort_keys=False))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
