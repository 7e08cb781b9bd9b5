"""Benchmark: an ``sbx_mbpo`` run's ensemble error per model round and where its training CPU goes.

Trains ``sbx_mbpo`` (its ``spine_gym/agents/hyperparams/sbx_mbpo.yml`` entry, ``-params`` overrides) on one
env id and seed for ``-n`` env steps, without validation, and prints one JSON line per model round (env
steps, the ensemble's last NLL, its error on the real transitions collected since the round before: the
squared error of the members' mean per output in units of that output's standard deviation, averaged),
then the training CPU split into the model rounds (fitting and rollouts) and SAC's updates.

    python benchmarks/bench_mbpo_model_error.py SmaSpineEasy-v2 --seed 101 -n 30000
"""

from __future__ import annotations

import argparse
import json
import time

from spine_gym.agents import model_based
from spine_gym.agents.training import build_envs, build_model, resolve_config
from spine_gym.cli_conventions import KeyValues


def timed(cpu: dict, name: str, method):
    """``method`` adding its CPU time to ``cpu[name]``."""

    def wrapper(*args, **kwargs):
        start = time.process_time()
        try:
            return method(*args, **kwargs)
        finally:
            cpu[name] += time.process_time() - start

    return wrapper


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("env_id")
    p.add_argument("--seed", type=int, default=100)
    p.add_argument("-n", "--n-timesteps", type=int, default=30_000)
    p.add_argument("-params", "--hyperparams", nargs="+", action=KeyValues, default={}, metavar="KEY=VALUE")
    args = p.parse_args(argv)
    cfg = resolve_config("sbx_mbpo", args.env_id, hyperparams=dict(args.hyperparams))
    model = build_model(cfg, build_envs(cfg, args.seed).env, args.seed)
    cpu = {"model_rounds_s": 0.0, "sac_updates_s": 0.0}
    model_based.MBPO._model_round = timed(cpu, "model_rounds_s", model_based.MBPO._model_round)
    model_based.SAC.train = timed(cpu, "sac_updates_s", model_based.SAC.train)
    start = time.process_time()
    model.learn(args.n_timesteps)
    for row in model.model_history:
        print(json.dumps({k: round(v, 4) for k, v in row.items()}))
    print(json.dumps({"training_cpu_s": round(time.process_time() - start, 1), **{k: round(v, 1) for k, v in cpu.items()}}))


if __name__ == "__main__":
    main()
