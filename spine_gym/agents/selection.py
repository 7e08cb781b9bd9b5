"""Choose among trained models on validation episodes, never on the evaluation suite.

Example::

    python -m spine_gym.agents.selection logs/ppo/SmaSpine-v0_* --episodes 20
    python -m spine_gym.agents.selection logs/ppo/SmaSpine3D-v1_* --env SmaSpine3D-v1

Each model (run folder: its final ``model.zip``; with ``--best`` also its ``best_model.zip``)
runs ``--episodes`` episodes drawn by the env's own samplers (the training distribution: random
targets, tip forces and payloads) with reset seeds ``VALIDATION_SEED_BASE + i`` — disjoint from
the training seeds, the tuning seeds and the evaluation suite's seeds. The tuned PID runs the same
episodes as the reference. Printed and written (``--out``, CSV): mean tracking RMSE [deg] and mean
energy [J] per model, and the ratio of both to the PID's.

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

from .evaluate import write_csv
from .runtime import (
    OBSERVATION_KWARGS,
    VALIDATION_SEED_BASE,
    controller_for,
    load_policy,
    policy_env_kwargs,
    validation_scores,
)
from .zoo_config import ENV_ID, ENV_IDS, StoreDict

__all__ = ["VALIDATION_SEED_BASE", "validation_scores", "model_env_kwargs", "main"]


def model_env_kwargs(own: dict, given: dict | None) -> dict:
    """The env kwargs a model trained with ``own`` is scored with: ``own`` (without its episode
    length) if no distribution is ``given``, else the one rule of
    :func:`spine_gym.agents.runtime.policy_env_kwargs` (``given`` with what the evaluation suite keeps
    of ``own`` on top: its observation, voltage ceiling, ...)."""
    if given is None:
        return {k: v for k, v in own.items() if k != "episode_duration"}
    return policy_env_kwargs(own, given)


def main(argv: list[str] | None = None) -> list[dict]:
    p = argparse.ArgumentParser(prog="python -m spine_gym.agents.selection", description=__doc__.split("\n")[0])
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
    pid = controller_for("pid", args.env, pid_kwargs)
    ref_rmse, ref_energy = validation_scores(pid, args.episodes, pid_kwargs, args.env)
    rows = [{"model": "pid", "rmse_deg": ref_rmse, "energy_J": ref_energy, "rmse_ratio": 1.0, "energy_ratio": 1.0}]
    for run in map(Path, args.runs):
        targets = [run] + ([run / "best_model.zip"] if args.best and (run / "best_model.zip").exists() else [])
        for t in targets:
            pol = load_policy(t)
            kw = model_env_kwargs(getattr(pol, "env_kwargs", {}), args.env_kwargs)
            r, e = validation_scores(pol, args.episodes, kw, args.env)
            rows.append(
                {
                    "model": str(t),
                    "rmse_deg": r,
                    "energy_J": e,
                    "rmse_ratio": r / ref_rmse,
                    "energy_ratio": e / ref_energy,
                }
            )
            print(f"{str(t):<55s} RMSE {r:6.2f} deg ({r / ref_rmse:5.2f} x PID)  energy {e:6.1f} J ({e / ref_energy:5.2f} x PID)", flush=True)
    print(f"{'pid':<55s} RMSE {ref_rmse:6.2f} deg  energy {ref_energy:6.1f} J")
    if args.out:
        write_csv(Path(args.out), rows)
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
