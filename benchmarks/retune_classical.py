"""Study: the PID and the sliding-mode controller re-tuned per env id, with the same budget for both.

For every id of ``--envs`` (default: the six ``-v2`` benchmark tiers, then the three ``-v2``
defaults) and every controller of ``--controllers`` (default ``pid smc``) this runs
:func:`spine_gym.agents.retune.retune_one`: seeded TPE on training episodes with the energy-aware
objective ``rmse_energy`` (:mod:`spine_gym.agents.tune`), then the family's gains and the re-tuned
ones on the same validation episodes (reset seeds 500 000+; never the evaluation suite's).
A re-tune is adopted (written to ``spine_gym/controllers/tuned/<id>.yml``) only if its validation
score is lower. Both controllers of an id get the same budget: ``--trials`` × ``--episodes`` on the
planar and four-wire ids, ``--chain-trials`` × ``--chain-episodes`` on the chain (about ten times
slower per episode).

    PYTHONPATH=$PWD python benchmarks/retune_classical.py               # the full study, resumable
    PYTHONPATH=$PWD python benchmarks/retune_classical.py --summary-only

Each finished (id, controller) is a record ``records/<id>__<controller>.yml`` in ``--out`` (default
``benchmarks/results/classical_tuning``), written as it finishes and skipped on a re-run; the code tree
keeps them as one ``records.tar.xz`` (unpacked at the start, re-packed after each record);
``summary.csv`` and ``summary.md`` are rebuilt from the records after each one.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tarfile
from pathlib import Path

import yaml

from spine_gym.agents.retune import ROW_FIELDS, Budget, record_row, retune_one, write_id_gains
from spine_gym.envs import ENV_SPECS, family_of

V2_IDS = tuple(
    [s.id for s in ENV_SPECS.values() if s.version == 2 and s.tier != "default"]
    + [s.id for s in ENV_SPECS.values() if s.version == 2 and s.tier == "default"]
)
OUT = Path(__file__).parent / "results" / "classical_tuning"


def parse(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--envs", nargs="+", default=list(V2_IDS))
    p.add_argument("--controllers", nargs="+", default=["pid", "smc"])
    p.add_argument("--trials", type=int, default=40)
    p.add_argument("--episodes", type=int, default=6)
    p.add_argument("--chain-trials", type=int, default=20)
    p.add_argument("--chain-episodes", type=int, default=4)
    p.add_argument("--validation-episodes", type=int, default=20)
    p.add_argument("--chain-validation-episodes", type=int, default=10)
    p.add_argument("--seed", type=int, default=0, help="TPE sampler seed")
    p.add_argument("--out", type=Path, default=OUT)
    p.add_argument("--no-write-gains", action="store_true", help="records only; tuned/<id>.yml untouched")
    p.add_argument("--summary-only", action="store_true")
    return p.parse_args(argv)


def budget_for(env_id: str, args) -> Budget:
    chain = family_of(env_id) == "SmaSpineChain"
    return Budget(
        trials=args.chain_trials if chain else args.trials,
        episodes=args.chain_episodes if chain else args.episodes,
        sampler_seed=args.seed,
        validation_episodes=args.chain_validation_episodes if chain else args.validation_episodes,
    )


def write_summary(out: Path, command: str) -> None:
    recs = [yaml.safe_load(f.read_text()) for f in sorted((out / "records").glob("*.yml"))]
    rows = [record_row(r) for r in recs]
    with open(out / "summary.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=ROW_FIELDS)
        w.writeheader()
        w.writerows(rows)
    head = "| id | controller | budget (trials × episodes) | validation score before → after | RMSE before → after | energy [J] before → after | T>limit [s] before → after | adopted |"
    lines = [
        "# PID and sliding mode re-tuned per id (validation episodes)",
        "",
        "Score: the tuning objective `rmse_energy` (RMSE + the env reward's energy term, same unit: deg; "
        "mm for the chain). Before: the family's gains; after: the per-id re-tune. Means over the "
        "validation episodes (reset seeds 500 000+; never the evaluation suite's).",
        "",
        f"Reproduce: `{command}`",
        "",
        "Budgets: " + "; ".join(sorted({f"{r['env_id']}: {r['budget']['text']}" for r in recs})),
        "",
        head,
        "|" + "---|" * 8,
    ]
    for r in rows:
        lines.append(
            f"| {r['env_id']} | {r['controller']} | {r['budget']} | {r['score_before']:.3f} → {r['score_after']:.3f} "
            f"| {r['rmse_before']:.3f} → {r['rmse_after']:.3f} | {r['energy_J_before']:.1f} → {r['energy_J_after']:.1f} "
            f"| {r['over_limit_s_before']:.2f} → {r['over_limit_s_after']:.2f} | {r['adopted']} |"
        )
    (out / "summary.md").write_text("\n".join(lines) + "\n")


def unpack_records(out: Path) -> None:
    """The records are kept in the code tree as one ``records.tar.xz``: unpack what is missing."""
    archive = out / "records.tar.xz"
    if archive.exists():
        with tarfile.open(archive) as tar:
            tar.extractall(out, members=[m for m in tar if m.isfile() and m.name.startswith("records/")
                                         and not (out / m.name).exists()], filter="data")


def pack_records(out: Path) -> None:
    """Write ``records/*.yml`` into ``records.tar.xz`` (replacing it)."""
    with tarfile.open(out / "records.tar.xz", "w:xz") as tar:
        for f in sorted((out / "records").glob("*.yml")):
            tar.add(f, arcname=f"records/{f.name}")


def main(argv=None) -> int:
    args = parse(argv)
    (args.out / "records").mkdir(parents=True, exist_ok=True)
    unpack_records(args.out)
    command = (
        f"PYTHONPATH=$PWD python benchmarks/retune_classical.py --envs {' '.join(args.envs)} "
        f"--controllers {' '.join(args.controllers)} --trials {args.trials} --episodes {args.episodes} "
        f"--chain-trials {args.chain_trials} --chain-episodes {args.chain_episodes} "
        f"--validation-episodes {args.validation_episodes} "
        f"--chain-validation-episodes {args.chain_validation_episodes} --seed {args.seed}"
    )
    if not args.summary_only:
        for env_id in args.envs:
            for name in args.controllers:
                path = args.out / "records" / f"{env_id}__{name}.yml"
                if path.exists():
                    print(f"{env_id} {name}: done, skipped", flush=True)
                    continue
                rec = retune_one(env_id, name, budget_for(env_id, args), verbose=True)
                path.write_text(yaml.safe_dump(rec, sort_keys=False, allow_unicode=True))
                if not args.no_write_gains:
                    write_id_gains(rec)
                b, a = rec["validation"]["before"], rec["validation"]["after"]
                print(
                    f"{env_id} {name}: validation score {b['score']:.3f} -> {a['score']:.3f} "
                    f"(RMSE {b['rmse']:.3f} -> {a['rmse']:.3f}, energy {b['energy_J']:.0f} -> {a['energy_J']:.0f} J) "
                    f"adopted={rec['adopted']}",
                    flush=True,
                )
                write_summary(args.out, command)
                pack_records(args.out)
    write_summary(args.out, command)
    return 0


if __name__ == "__main__":
    sys.exit(main())
