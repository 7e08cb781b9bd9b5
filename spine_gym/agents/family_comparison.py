"""Every family's shipped policies against the baselines, each compared at equal terms (the README's
main command, ``bash scripts/run.sh``).

Example::

    python -m spine_gym.agents.family_comparison        # SmaSpineHard-v2, SmaSpine3D-v2, SmaSpineChain-v2
    python -m spine_gym.agents.family_comparison --suite quick -o /tmp/eval --no-plots

For each env id it runs :mod:`spine_gym.agents.evaluate` once per actuator envelope of the id's
shipped policies (:data:`~spine_gym.agents.evaluation_job.ENVELOPE_KWARGS`: the voltage ceiling
``v_max``). Policies trained at the env's own ceiling are ranked with the baselines in
``<out>/<env id>/``; a policy trained at another ceiling gets its own table, in
``<out>/<env id>_v_max_<V>/``, in which the baselines run at that ceiling too
(``--env-kwargs v_max=<V>``). So no policy is ranked against baselines that were given
less voltage. Every table carries the ratios to the tuned PID of the same run (``--relative-to pid``).
Arguments other than ``--envs`` and ``-o/--out`` go to every evaluation (e.g. ``--suite quick``,
``--no-plots``, ``--plain``, ``--mpc``); all of them are checked before the first episode runs.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from spine_gym import cli_conventions as cli
from spine_gym.cli_conventions import module_prog

from . import evaluation_job as job
from .evaluation import shipped_policies
from .runtime import evaluation_env_kwargs, make_env
from .zoo_config import ENV_IDS

#: each family's -v2 id of its shipped -v2 policy (the plant's cut-off protects every controller alike),
#: in the order they are compared
FAMILY_IDS = ("SmaSpineHard-v2", "SmaSpine3D-v2", "SmaSpineChain-v2")
#: evaluate's options each comparison sets itself
OWN_OPTIONS = ("--env", "--models", "--env-kwargs")
#: what a run writes, in the order the closing summary names it
OUTPUTS = ("summary.csv", "relative.csv", "metrics.csv", "plots", "trajectories")


@dataclass(frozen=True)
class Comparison:
    """One evaluation: the baselines and ``models`` on ``env_id`` with the envelope ``envelope``
    (what differs from the env's ``defaults``; empty: the env's own), written to ``out``."""

    env_id: str
    envelope: dict
    models: dict
    out: Path
    defaults: dict

    def argv(self, extra: list[str]) -> list[str]:
        """The ``spine_gym.agents.evaluate`` arguments of this comparison; ``extra`` goes last."""
        argv = ["--env", self.env_id, "--models", *(f"{n}={p}" for n, p in self.models.items())]
        if self.envelope:
            argv += ["--env-kwargs", *(f"{k}={v:g}" for k, v in self.envelope.items())]
        return [*argv, "--relative-to", "pid", "-o", str(self.out), *extra]

    def label(self) -> str:
        values = ", ".join(f"{k}={v:g}" for k, v in {**self.defaults, **self.envelope}.items())
        whose = "the policies' own, given to the baselines too" if self.envelope else "the env default"
        return f"{self.env_id}, {values} ({whose})"


def policy_envelope(folder: Path, defaults: dict) -> dict:
    """The :data:`~spine_gym.agents.evaluation_job.ENVELOPE_KWARGS` a shipped policy runs with on the
    suite that differ from the env's ``defaults`` (empty: it runs at the env's own envelope)."""
    kw = evaluation_env_kwargs(json.loads((folder / "meta.json").read_text()).get("env_kwargs", {}))
    return {k: float(kw[k]) for k in job.ENVELOPE_KWARGS if k in kw and float(kw[k]) != float(defaults[k])}


def env_envelope(env_id: str) -> dict:
    """The env's default values of :data:`~spine_gym.agents.evaluation_job.ENVELOPE_KWARGS`."""
    env = make_env({}, env_id=env_id)
    try:
        return {k: float(getattr(env.unwrapped, k)) for k in job.ENVELOPE_KWARGS}
    finally:
        env.close()


def comparisons(env_ids: list[str], out: Path) -> list[Comparison]:
    """One :class:`Comparison` per env id and envelope of its shipped policies; the env's own
    envelope always (the baselines alone if no policy runs at it)."""
    runs = []
    for env_id in env_ids:
        defaults = env_envelope(env_id)
        groups: dict[tuple, dict] = {(): {}}
        for name, folder in shipped_policies(env_id).items():
            key = tuple(sorted(policy_envelope(folder, defaults).items()))
            groups.setdefault(key, {})[name] = folder
        for key, models in groups.items():
            suffix = "".join(f"_{k}_{v:g}" for k, v in key)
            runs.append(Comparison(env_id, dict(key), models, out / f"{env_id}{suffix}", defaults))
    return runs


def check(runs: list[Comparison], extra: list[str]) -> None:
    """Parse and check every evaluation's arguments (ValueError or SystemExit, one line) before any runs."""
    parser = evaluate_parser()
    for run in runs:
        job.plan(parser.parse_args(run.argv(extra)))


def evaluate_parser() -> argparse.ArgumentParser:
    """The evaluate command's parser (its usage errors name that command)."""
    return job.add_arguments(cli.Parser(prog=job.PROG))


def summary_lines(runs: list[Comparison], seconds: float) -> list[str]:
    """The closing summary: where each comparison's tables and plots went."""
    lines = [f"compared {len(runs)} sets of controllers in {seconds:.0f} s; tables and plots:"]
    for run in runs:
        wrote = [f + ("/" if (run.out / f).is_dir() else "") for f in OUTPUTS if (run.out / f).exists()]
        names = ", ".join(run.models) or "no shipped policy"
        lines.append(f"  {run.label()}: baselines + {names} -> {run.out}/ ({', '.join(wrote)})")
    lines.append("  summary.csv: one row per controller and scenario group; relative.csv: ratios to the PID")
    return lines


#: this command's name as ``python -m <module>``
PROG = module_prog(__spec__.name)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description=__doc__.split("\n\n")[0].replace("\n", " ").replace("``", ""),
        epilog="Any other argument goes to every python -m spine_gym.agents.evaluate run "
        "(e.g. --suite quick, --no-plots, --plain, --mpc).",
        allow_abbrev=False,
    )
    p.add_argument(
        "--envs", nargs="+", default=list(FAMILY_IDS), choices=ENV_IDS, metavar="ID",
        help=f"env ids to compare (default: {' '.join(FAMILY_IDS)})",
    )  # fmt: skip
    p.add_argument("-o", "--out", default="results/eval", help="output folder (default: %(default)s)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the comparisons; exit status 0. Bad arguments exit with status 2 before any episode runs."""
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    t0 = time.perf_counter()
    own = [a for a in extra if a.split("=")[0] in OWN_OPTIONS]
    if own:
        name = own[0].split("=")[0]
        parser.error(f"{name} is set per comparison (the id, its policies, their envelope); use --envs")
    runs = comparisons(args.envs, Path(args.out))
    try:
        check(runs, extra)
    except ValueError as e:
        parser.error(str(e))
    for run in runs:
        names = ", ".join(run.models) or "no shipped policy"
        print(f"\n=== {run.label()}: the baselines and {names}", flush=True)
        t_start = time.perf_counter()
        args = evaluate_parser().parse_args(run.argv(extra))
        job.run(args, job.plan(args), t_start)
    print("\n" + "\n".join(summary_lines(runs, time.perf_counter() - t0)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
