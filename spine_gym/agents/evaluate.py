"""Evaluate baselines and saved policies on the fixed scenario suite of :mod:`spine_gym.agents.scenarios`.

Example (``spine-gym evaluate`` is the same command; the README's main command, ``bash scripts/run.sh``, runs it
per family and voltage ceiling: :mod:`spine_gym.agents.family_comparison`)::

    python -m spine_gym.agents.evaluate            # shipped policies + step, bang-bang, PID on SmaSpine-v1
    python -m spine_gym.agents.evaluate --env SmaSpine3D-v1      # the spatial spine's suite and policies

Without ``--env`` it runs on the env of the one model given with ``--models`` (its ``meta.json``),
else on ``SmaSpine-v1``; a model trained on another env (by its ``meta.json``, else by the spaces
stored in its file) is a usage error before any work, as is an ``--out`` that cannot be written.
Every controller (anything with SB3's ``predict``) runs every scenario of the suite in its own
env, reset with the scenario's seed, target profile and load schedule
(:mod:`spine_gym.agents.evaluation`, the library this command line runs).

The CLI prints first the equal-terms comparison (:mod:`spine_gym.agents.equal_terms`): per actuator
envelope (voltage ceiling ``v_max``) and scenario group, the controllers at most 0.5 s per episode
over the temperature limit ranked by RMSE, then the others apart with their violation, each with
its energy, both as multiples of the tuned PID's in the same envelope, and who cuts a hot wire
(``guard``: the plant's cut-off of the ``-v2`` ids, the controller's own guard, or none). A model that runs at another
ceiling than the env's (its own ``v_max``) gets the baselines re-run at its ceiling (named
``pid@6V``, ...) and is compared only with them. Then one table per scenario group (mean over the
group's scenarios) with tracking RMSE and max error [deg], settling time [s] (step scenarios),
electrical energy [J], peak wire temperature [K] and time over the temperature limit [s]. It
writes to ``--out``:

* ``metrics.csv`` — one row per (controller, scenario); ``summary.csv`` — one row per
  (controller, group); ``equal_terms.csv`` — the equal-terms comparison, one row per (envelope,
  group, controller);
* ``trajectories/<controller>/<scenario>.csv`` — the step-by-step record;
* ``plots/<controller>_<group>.png`` — angle and target, voltages and temperatures vs time for
  each scenario of the group;
* with ``--video``: ``videos/<controller>/<scenario>.mp4`` — the episode as the env renders it
  (:mod:`spine_gym.agents.video`).

These outputs of an earlier run in the same folder are removed first (other files are kept).
"""

from __future__ import annotations

import argparse
import sys
import time

from spine_gym import cli_conventions as cli
from spine_gym.controllers.registry import BASELINES, REGISTRY  # noqa: F401

# the library's names stay importable from here for one release (they moved to .evaluation)
from .evaluation import (  # noqa: F401
    ERROR_UNIT,
    evaluate,
    format_relative,
    format_tables,
    plot_controller,
    policy_env_id,
    relative_rows,
    shipped_policies,
    summarize,
    write_csv,
    write_trajectories,
)
from .evaluation_job import MPC_CONTROLLERS, OUTPUTS, add_arguments, plan, remove_outputs, run  # noqa: F401
from .evaluation_job import controllers_of as _controllers  # noqa: F401  (the old names, for one release)
from .evaluation_job import env_of as _env  # noqa: F401
from .evaluation_job import models_of as _models  # noqa: F401
from .evaluation_job import plan as _plan  # noqa: F401
from .runtime import (  # noqa: F401  (make_env, run_episode, ... re-exported for one release)
    build_controller,
    env_temperature_limit,
    evaluation_env_kwargs,
    load_policy,
    make_env,
    run_episode,
)


# --------------------------------------------------------------------------- CLI
#: this command's name as ``python -m <module>`` (``spine-gym <command>`` passes its own ``prog``)
PROG = cli.module_prog(__spec__.name)

EXAMPLES = """
spine-gym evaluate --suite quick                     # shipped policies + step, bang-bang, PID
spine-gym evaluate --env SmaSpine3D-v1 --suite quick --no-plots -o results/eval_3d
spine-gym evaluate --suite quick --baselines pid --models mine=logs/ppo/SmaSpine-v2_1
spine-gym evaluate --suite quick --baselines pid --models --env-kwargs sensor_delay=1 --no-progress
"""


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    return add_arguments(cli.Parser(prog=prog, description=__doc__.split("\n")[0], examples=EXAMPLES))


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """Run the CLI; exit status 0 (the summary rows are ``summary.csv``). Usage errors exit with
    status 2 before any work."""
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    t_start = time.perf_counter()
    try:
        planned = plan(args)
    except (ValueError, RuntimeError) as e:
        parser.error(str(e))
    return run(args, planned, t_start)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
