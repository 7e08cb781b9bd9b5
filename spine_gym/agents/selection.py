"""Choose among trained models on validation episodes, never on the evaluation suite.

Example::

    python -m spine_gym.agents.selection logs/ppo/SmaSpine-v0_* --episodes 20
    python -m spine_gym.agents.selection logs/ppo/SmaSpine3D-v1_* --env SmaSpine3D-v1

Each model (run folder: its final ``model.zip``; with ``--best`` also its ``best_model.zip``)
runs ``--episodes`` episodes drawn by the env's own samplers (the training distribution: random
targets, tip forces and payloads) with reset seeds ``VALIDATION_SEED_BASE + i`` — disjoint from
the training seeds, the tuning seeds and the evaluation suite's seeds. The tuned PID runs the same
episodes as the reference, in each model's actuator envelope: a model that runs at another
voltage ceiling (its own ``v_max``) is compared with the PID run at that ceiling, never with one
held to another. Printed and written (``--out``, CSV): mean tracking RMSE [deg], mean energy [J]
and mean time with a wire above the env's temperature limit [s] per episode, per model, its
ceiling ``v_max_V``, and the ratio of RMSE and energy to the PID's at that ceiling.

``--env-kwargs key:value ...`` scores every model and the PID on that distribution instead of each
model's own training one (e.g. the hard group's plants and loads); the PID runs it with the env's
default observation, each model with what it was trained with beyond the task distribution, as in
the evaluation suite (:func:`model_env_kwargs`: e.g. its ``target_preview`` or ``v_max``; a model's
own value wins over a given one).

Selecting the shipped policies this way keeps the evaluation suite a test set: the suite's numbers
are not what the models were picked by.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from spine_gym.cli_conventions import module_prog
from spine_gym.envs import config_of

from .evaluation import write_csv
from .runtime import (
    OBSERVATION_KWARGS,
    VALIDATION_SEED_BASE,
    build_controller,
    evaluation_env_kwargs,
    load_policy,
    make_env,
    policy_env_kwargs,
    validation_metrics,
    validation_scores,
)
from .zoo_config import ENV_ID, ENV_IDS, StoreDict

__all__ = ["VALIDATION_SEED_BASE", "validation_scores", "model_env_kwargs", "score_row", "main"]


def model_env_kwargs(own: dict, given: dict | None) -> dict:
    """The env kwargs a model trained with ``own`` is scored with: ``own`` (without its episode
    length) if no distribution is ``given``, else ``given`` with what the evaluation suite keeps of
    ``own`` (:func:`spine_gym.agents.runtime.evaluation_env_kwargs`: its observation, voltage ceiling,
    ...) on top."""
    if given is None:
        return {k: v for k, v in own.items() if k != "episode_duration"}
    return policy_env_kwargs(own, given)


def score_row(name: str, controller, n_episodes: int, env_kwargs: dict, env_id: str) -> dict:
    """{model, rmse_deg, energy_J, time_over_limit_s}: the means of ``controller`` over the
    ``n_episodes`` validation episodes (RMSE in the env's unit: deg, mm for the chain)."""
    rows = validation_metrics(controller, n_episodes, env_kwargs, env_id)
    mean = {k: sum(r[k] for r in rows) / len(rows) for k in ("rmse_deg", "energy_J", "time_over_limit_s")}
    return {"model": name, **mean}


def reference(
    refs: dict[float, dict], pid_kwargs: dict, v_max: float | None, n_episodes: int, env_id: str
) -> dict:
    """The tuned PID's :func:`score_row` at voltage ceiling ``v_max`` (None: that of ``pid_kwargs``),
    from ``refs`` (keyed by the ceiling) or run and stored there."""
    kw = dict(pid_kwargs) if v_max is None else {**pid_kwargs, "v_max": v_max}
    v = float(config_of(env_id, **kw).v_max)
    if v not in refs:
        probe = make_env(kw, env_id=env_id)
        pid = build_controller("pid", probe)
        probe.close()
        name = "pid" if not refs else f"pid@{v:g}V"
        refs[v] = {**score_row(name, pid, n_episodes, kw, env_id), "v_max_V": v}
    return refs[v]


#: this command's name as ``python -m <module>``
PROG = module_prog(__spec__.name)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; exit status 0 (the scores are printed and, with ``--out``, written as CSV)."""
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n")[0], allow_abbrev=False)
    p.add_argument("runs", nargs="+", help="run folders of spine_gym.agents.train")
    p.add_argument(
        "--env", default=ENV_ID, choices=ENV_IDS, help="env id the runs were trained on (default: %(default)s)"
    )
    p.add_argument("--episodes", type=int, default=20, help="validation episodes (default: %(default)s)")
    p.add_argument("--best", action="store_true", help="also score each run's best_model.zip")
    p.add_argument("--out", default=None, help="CSV file for the scores")
    p.add_argument(
        "--env-kwargs",
        nargs="+",
        action=StoreDict,
        default=None,
        help="score every model and the PID on this distribution (key:value; default: each model's own)",
    )
    args = p.parse_args(argv)
    import torch

    torch.set_num_threads(1)
    # the PID reference sees the env's default observation (preview), as in the evaluation suite
    pid_kwargs = {k: v for k, v in (args.env_kwargs or {}).items() if k not in OBSERVATION_KWARGS}
    refs: dict[float, dict] = {}  # the PID's row per voltage ceiling, run when a model needs it
    reference(refs, pid_kwargs, None, args.episodes, args.env)
    rows = []
    for run in map(Path, args.runs):
        targets = [run] + ([run / "best_model.zip"] if args.best and (run / "best_model.zip").exists() else [])
        for t in targets:
            pol = load_policy(t)
            kw = model_env_kwargs(getattr(pol, "env_kwargs", {}), args.env_kwargs)
            v_max = float(config_of(args.env, **kw).v_max)
            ref = reference(refs, pid_kwargs, v_max, args.episodes, args.env)
            row = {**score_row(str(t), pol, args.episodes, kw, args.env), "v_max_V": v_max}
            rmse_ratio, energy_ratio = row["rmse_deg"] / ref["rmse_deg"], row["energy_J"] / ref["energy_J"]
            rows.append({**row, "rmse_ratio": rmse_ratio, "energy_ratio": energy_ratio})
            print(
                f"{str(t):<55s} RMSE {row['rmse_deg']:6.2f} ({rmse_ratio:5.2f} x PID)  "
                f"energy {row['energy_J']:6.1f} J ({energy_ratio:5.2f} x PID)  "
                f"T>limit {row['time_over_limit_s']:5.2f} s  at {v_max:g} V",
                flush=True,
            )
    for v_max, ref in refs.items():
        print(
            f"{'pid':<55s} RMSE {ref['rmse_deg']:6.2f}  energy {ref['energy_J']:6.1f} J  "
            f"T>limit {ref['time_over_limit_s']:5.2f} s  at {v_max:g} V"
        )
    rows = [{**ref, "rmse_ratio": 1.0, "energy_ratio": 1.0} for ref in refs.values()] + rows
    if args.out:
        write_csv(Path(args.out), rows)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
