"""``spine-gym finetune``: pretrain with domain randomisation from a calibration preset, shift the
plant by what the calibration leaves uncertain (several plants), fine-tune on each and score before/after.

The library is :mod:`spine_gym.agents.reality_gap`; this is its command line. Writes into ``-o``:
``scores.csv`` (the evaluation set's means per plant, row and group), ``finetune_seeds.csv`` (each
fine-tuning run's rows), ``scenarios.csv`` (every controller's metrics per plant and scenario),
``plant.csv`` and ``real_plant_shift<seed>.json`` (the shifted plants, with ``--model-error`` the
parameters the fit holds fixed that they set to other values), ``selection.csv`` (the
learners on the tuning shifts), ``reality_gap.png``, ``summary.json`` (the recovered fraction pooled
and per plant, the control arm, their bootstrap intervals, the target's verdict), ``command.txt``
and the run folders ``pretrained/``, ``finetuned_shift<seed>_<training seed>/`` and
``control_<training seed>/`` (the same fine-tuning on the fitted plant).
"""

from __future__ import annotations

import argparse
import shlex
import sys

from spine_gym.cli_conventions import (
    Parser,
    add_env,
    add_out,
    add_progress,
    check_file,
    check_out_dir,
    first_line,
    module_prog,
)

from .reality_gap import (
    DEFAULT_ENV_ID,
    DEFAULT_LEARNER,
    EVAL_EPISODES,
    LEARNERS,
    SHIFT_SEEDS,
    StudyConfig,
    run_study,
)

PROG = module_prog(__spec__.name)

EXAMPLES = """
spine-gym finetune --preset results/calibration/fit.json --quick -o rg_quick   # tiny budgets
spine-gym finetune --preset results/calibration/fit.json -o rg
spine-gym finetune --preset results/calibration/fit.json --pretrained rg/pretrained --pretrain-steps 0 -o rg2
spine-gym finetune --preset results/calibration/fit.json --model-error T_E=303 a=0.0135 -o rg_warm
"""

#: the budgets of ``--quick`` (a pipeline check in about a minute)
QUICK = {
    "pretrain_steps": 2048,
    "finetune_steps": 256,
    "finetune_seeds": 2,
    "selection_episodes": 1,
    "suite": "quick",
    "eval_episodes": 2,
}


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    p = Parser(
        prog=prog,
        description=(
            "Pretrain PPO with domain randomisation from a spatial calibration preset, shift the plant by "
            "k standard errors per fit parameter, fine-tune on it within a step budget and score the "
            "pretrained, fine-tuned and PID rows on the evaluation suite."
        ),
        examples=EXAMPLES,
    )
    add = p.add_argument
    add("--preset", required=True, help="spatial fit preset (spine-gym calibrate ... --params wires)")
    add_env(p, default=DEFAULT_ENV_ID, help="a SmaSpine3D* env id (one four-wire module)")
    add("--pretrain-steps", type=int, default=300_000, help="PPO pretraining steps (0: --pretrained)")
    add("--pretrained", default="", help="an existing pretrained run folder (with --pretrain-steps 0)")
    add("--finetune-steps", type=int, default=6_000, help="fine-tuning budget [env steps] on one spine")
    add("--finetune-seeds", type=int, default=4,
        help="fine-tuning runs (seeds) per arm and plant; a row: their median")  # fmt: skip
    add("--k", type=float, default=3.0, help="shift of every fit parameter [standard errors]")
    add("--shift-seeds", type=int, nargs="+", default=list(SHIFT_SEEDS),
        help="seeds of the shifts' signs, a 'real' plant each (not 101, 102: the tuning plants)")  # fmt: skip
    add("--model-error", nargs="+", default=[], metavar="FIELD=VALUE",
        help="parameters the fit holds fixed, set to VALUE on every shifted plant (a model error a "
             "calibration cannot see, e.g. T_E=303 a=0.0135: a warmer room, a pore radius off by "
             "0.5 mm); default: none")  # fmt: skip
    learners = ", ".join(LEARNERS)
    add("--learners", nargs="+", default=[DEFAULT_LEARNER],
        help=f"fine-tuning settings among {learners} (several: chosen on tuning plants)")  # fmt: skip
    add("--selection-episodes", type=int, default=10, help="validation episodes per tuning plant")
    add("--suite", default="full", help="evaluation suite: full or quick")
    add("--eval-episodes", type=int, default=EVAL_EPISODES,
        help="held-out episodes of the env's own samplers scored next to the suite")  # fmt: skip
    add("--seed", type=int, default=0, help="training seed (the first of the fine-tuning seeds)")
    add("--quick", action="store_true", help="tiny budgets and the quick suite (a pipeline check)")
    add_out(p, default="results/reality_gap")
    add_progress(p)
    return p


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """Run the CLI; exit status 0, or 2 with one line on stderr for a bad argument (before any work)."""
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    argv = sys.argv[1:] if argv is None else list(argv)
    settings = {
        "pretrain_steps": args.pretrain_steps,
        "finetune_steps": args.finetune_steps,
        "finetune_seeds": args.finetune_seeds,
        "selection_episodes": args.selection_episodes,
        "suite": args.suite,
        "eval_episodes": args.eval_episodes,
    }
    if args.quick:
        pretrain_steps = QUICK["pretrain_steps"] if args.pretrain_steps else 0
        settings = {**settings, **QUICK, "pretrain_steps": pretrain_steps}
    try:
        check_file(args.preset, "--preset")
        check_out_dir(args.out)
        cfg = StudyConfig(
            preset=args.preset,
            out=args.out,
            env_id=args.env,
            pretrained=args.pretrained,
            k=args.k,
            shift_seeds=tuple(args.shift_seeds),
            model_error=parse_model_error(args.model_error),
            learners=tuple(args.learners),
            seed=args.seed,
            command=shlex.join(["spine-gym", "finetune", *argv]),
            **settings,
        )
    except (ValueError, FileNotFoundError) as e:
        parser.error(first_line(e))
    summary = run_study(cfg, progress=args.progress)
    print(
        f"fine-tuned on each shifted plant in {cfg.finetune_steps} steps "
        f"({summary['hardware_minutes']:.1f} min of hardware): {outcome_line(summary)}; wrote {args.out}/"
    )
    return 0


def parse_model_error(items: list[str]) -> tuple[tuple[str, float], ...]:
    """``FIELD=VALUE`` strings as (field, value) pairs (the fields and values are checked by the
    study's config)."""
    pairs = []
    for item in items:
        name, sep, value = item.partition("=")
        try:
            pairs.append((name.strip(), float(value)))
        except ValueError:
            sep = ""
        if not sep:
            raise ValueError(f"model_error: expected FIELD=VALUE (e.g. T_E=303), got {item!r}")
    return tuple(pairs)


def outcome_line(summary: dict) -> str:
    """The shift's cost, the recovered fraction and the control arm pooled over the plants, each with
    its 95 % interval (evaluation episodes and runs resampled), and the target's verdict."""
    lo, hi = summary["shift_cost_deg_ci95"]
    n = len(summary["plants"])
    cost = (
        f"over {n} shifted plant{'s' * (n > 1)} the shift cost {summary['shift_cost_deg']:.2f} deg of RMSE "
        f"(95 % CI {lo:.2f} to {hi:.2f})"
    )
    c_lo, c_hi = summary["control_gain_deg_ci95"]
    control = (
        f"the same fine-tuning on the unshifted plant moved it by {-summary['control_gain_deg']:+.2f} deg "
        f"(95 % CI {-c_hi:+.2f} to {-c_lo:+.2f})"
    )
    if summary["shift_cost_deg"] <= 0:
        return f"{cost}: nothing to recover; {control}"
    f_lo, f_hi = summary["recovered_fraction_ci95"]
    won = (
        f"the fine-tuning won back {summary['recovered_fraction']:.0%} of it "
        f"(95 % CI {f_lo:.0%} to {f_hi:.0%}; target {summary['target_fraction']:.0%}: {summary['verdict']})"
    )
    return f"{cost}; {won}; {control}"


if __name__ == "__main__":
    sys.exit(main())
