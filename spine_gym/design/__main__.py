"""Command line of the design studies: ``python -m spine_gym.design {params,sweep,optimize,best}``.

Examples (user guide: ``docs/design.md``)::

    python -m spine_gym.design params
    python -m spine_gym.design sweep --param a=6e-3:14e-3:9 --param n_w=1,2,3 --n-workers 2
    python -m spine_gym.design sweep --param n_modules=1,2,3 --param a=6e-3:12e-3:4   # chained layouts
    python -m spine_gym.design optimize --space a=6e-3:14e-3 --space n_w=1,2,3 \\
        --maximize stable_angle --constraint "ability>=0.15" --constraint "responding_time<=36" \\
        --n-trials 60 --n-workers 2 --storage runs/design/study.journal --study-name spine
    python -m spine_gym.design best --storage runs/design/study.journal --study-name spine
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import shlex
import sys
import time
from pathlib import Path

from ..capacity import CapacityProtocol
from ..cli_conventions import Parser, add_out, add_progress, add_workers, check_file, check_out_dir, module_prog, usage_errors
from ..layout import SpineLayout
from ..params import PRESETS, ModelParams, SolverOptions
from .space import (
    LAYOUT_PARAMS,
    METRICS,
    PROTOCOL_PARAMS,
    design_parameter_names,
    parameter_range,
    parse_assignment,
)


def _assignments(items: list[str] | None) -> list[str]:
    """Flatten repeatable ``--opt k=v,k2=v2`` arguments."""
    out: list[str] = []
    for it in items or []:
        out += [s.strip() for s in it.split(",") if s.strip()]
    return out


def _protocol(items: list[str] | None) -> CapacityProtocol:
    kw = {}
    names = [f.name for f in dataclasses.fields(CapacityProtocol)]
    for s in _assignments(items):
        k, _, v = s.partition("=")
        k = k.strip()
        if k not in names or not v:
            raise ValueError(f"--protocol takes KEY=VALUE with KEY in {names}, got {s!r}")
        try:
            kw[k] = float(v)
        except ValueError:
            raise ValueError(f"--protocol {k}: {v!r} is not a number") from None
    return CapacityProtocol(**kw)


def _solver(items: list[str] | None) -> SolverOptions | None:
    items = _assignments(items)
    if not items:
        return None
    kw: dict = {}
    fields = {f.name: f for f in dataclasses.fields(SolverOptions)}
    for s in items:
        k, _, v = s.partition("=")
        k = k.strip()
        if k not in fields or not v:
            raise ValueError(f"--solver takes KEY=VALUE with KEY in {list(fields)}, got {s!r}")
        if k == "method":
            kw[k] = v
        else:
            try:
                kw[k] = int(v) if k.startswith("max_") else float(v)
            except ValueError:
                raise ValueError(f"--solver {k}: {v!r} is not a number") from None
    return SolverOptions(**kw)


def _fixed(items: list[str] | None) -> dict:
    out = {}
    for s in _assignments(items):
        k, v = parse_assignment(s)
        out[k] = v
    return out


def _add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--preset",
        choices=sorted(PRESETS),
        default="baseline",
        help="base parameter set (MODEL.md §7), default baseline",
    )
    p.add_argument(
        "--set",
        action="append",
        metavar="NAME=VALUE",
        help="fixed override of the base design (repeatable or comma-separated), e.g. E_t=30e6",
    )
    p.add_argument(
        "--protocol",
        action="append",
        metavar="KEY=VALUE",
        help="capacity protocol (default 60+60+30 s at 3.2 V), e.g. "
        "t_stable=20,t_respond=20,t_load=10 for a quick study",
    )
    p.add_argument(
        "--solver", action="append", metavar="KEY=VALUE", help="SolverOptions overrides, e.g. method=bisect"
    )
    add_workers(p, "--n-workers", dest="n_workers", all_cores=True, help="parallel worker processes (-1 = all cores)")
    p.add_argument(
        "--mp-context", choices=("spawn", "forkserver"), default="spawn",
        help="how worker processes start (multiprocessing start method)",
    )  # fmt: skip
    add_out(p, type=Path, help="output folder (default: runs/design/<sweep-time> or runs/design/opt-<study>)")
    add_progress(p)


def _fmt(v) -> str:
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float) and math.isinf(v):
        return "inf"
    if isinstance(v, float) and math.isnan(v):
        return "-"
    return f"{v:.4g}"


def _cmd_params(args) -> int:
    base = PRESETS[args.preset]()
    print(f"{'name':<14} {'value (' + args.preset + ')':>22} {'allowed range':>26}")
    for name in design_parameter_names():
        lo, hi = parameter_range(name)
        if name in LAYOUT_PARAMS:
            val = "planar"  # unset: the planar spine; set: SpineLayout.chain(n_modules, params)
        elif name in PROTOCOL_PARAMS:
            val = CapacityProtocol().voltage
        else:
            val = getattr(base, name)
        print(f"{name:<14} {val!r:>22} {f'[{lo:g}, {hi:g}]':>26}")
    print("metrics:", ", ".join(METRICS))
    return 0


def _cmd_sweep(args, parser) -> int:
    from .sweeps import sweep

    out = args.out or Path("runs/design") / time.strftime("sweep-%Y%m%d-%H%M%S")
    with usage_errors(parser):
        check_out_dir(out)
        base = PRESETS[args.preset]()
        fixed = _fixed(args.set)
        protocol = _protocol(args.protocol)
        solver = _solver(args.solver)
        metrics = [m for m in (args.metrics or "").split(",") if m] or None
        if metrics:
            from .space import resolve_metric

            metrics = [resolve_metric(m) for m in metrics]
        # sweep() validates every grid point before any worker starts
        res = sweep(
            args.param,
            base=base,
            protocol=protocol,
            solver=solver,
            fixed=fixed,
            n_workers=args.n_workers,
            backend=args.backend,
            mp_context=args.mp_context,
            progress=args.progress,
        )
    csv_path = res.to_csv(out / "sweep.csv")
    res.write_metadata(
        out / "sweep.json", command=shlex.join([sys.executable, "-m", "spine_gym.design", *sys.argv[1:]])
    )
    written = []
    if not args.no_plots:
        from .plots import DEFAULT_METRICS, plot_sweep

        written = plot_sweep(res, out, metrics or DEFAULT_METRICS)
    names = res.param_names
    shown = metrics or [
        "stable_angle_deg",
        "responding_time_s",
        "responding_time_swing_s",
        "actuating_ability",
    ]
    header = [*names, *shown, "status"]
    if len(res) <= 200:
        print("  ".join(f"{h:>14}" for h in header))
        for r in res.rows:
            print("  ".join(f"{_fmt(r[h]) if h != 'status' else r[h]:>14}" for h in header))
    n_fail = sum(r["status"] != "ok" for r in res.rows)
    print(
        f"{len(res)} designs in {res.elapsed_s:.2f} s ({len(res) / res.elapsed_s:.2f} designs/s, "
        f"{res.n_workers} worker(s), {res.backend}); {n_fail} failed"
    )
    print(f"wrote {csv_path}, {out / 'sweep.json'}" + (f" and {len(written)} PNG" if written else ""))
    return 0


def _cmd_optimize(args, parser) -> int:
    from .optimizer import DesignProblem, display_storage, optimize
    from .plots import plot_history

    if (args.maximize is None) == (args.minimize is None):
        parser.error("give exactly one of --maximize METRIC or --minimize METRIC")
    out = args.out or Path("runs/design") / f"opt-{args.study_name}"
    storage = args.storage or str(out / "study.journal")
    with usage_errors(parser):
        check_out_dir(out)
        problem = DesignProblem(
            space=tuple(args.space),
            metric=args.maximize or args.minimize,
            maximize=args.maximize is not None,
            constraints=tuple(args.constraint or ()),
            base=PRESETS[args.preset](),
            protocol=_protocol(args.protocol),
            solver=_solver(args.solver),
            fixed=_fixed(args.set),
        )
        res = optimize(
            problem,
            n_trials=args.n_trials,
            storage=storage,
            study_name=args.study_name,
            n_workers=args.n_workers,
            seed=args.seed,
            sampler=args.sampler,
            n_startup_trials=args.n_startup_trials,
            max_total_trials=args.max_total_trials,
            timeout=args.timeout,
            mp_context=args.mp_context,
            progress=args.progress,
        )
    print(res.summary())
    best_json = res.write_json(out / "best.json")
    trials_csv = res.write_trials_csv(out / "trials.csv")
    plot_history(res.trials, problem.metric, problem.maximize, out / "history.png")
    (out / "command.txt").write_text(
        shlex.join([sys.executable, "-m", "spine_gym.design", *map(display_storage, sys.argv[1:])]) + "\n"
    )
    print(
        f"{len(res.trials)} trials in the study; this run took {res.elapsed_s:.1f} s "
        f"with {args.n_workers} worker(s)"
    )
    print(
        f"study saved in {display_storage(storage)} (name {args.study_name!r}); "
        f"wrote {best_json}, {trials_csv}, {out / 'history.png'}"
    )
    return 0


def _cmd_best(args, parser) -> int:
    from .optimizer import load_result

    with usage_errors(parser):
        if "://" not in args.storage:  # a journal file, which reading would create
            check_file(args.storage, "--storage")
        res = load_result(args.storage, args.study_name)
    print(res.summary())
    if args.json:
        print(json.dumps(res.to_dict(), indent=2))
    if res.best is not None:
        p: ModelParams = res.best_params()
        changed = {
            f.name: getattr(p, f.name)
            for f in dataclasses.fields(p)
            if getattr(p, f.name) != getattr(ModelParams(), f.name)
        }
        print("ModelParams differing from the baseline:", changed)
        model = res.best_design()
        if isinstance(model, SpineLayout):
            print(f"layout: SpineLayout.chain({model.n_modules}, params)")
    return 0


#: this command's name as ``python -m <module>`` (``spine-gym <command>`` passes its own ``prog``)
PROG = module_prog(__spec__.name)

EXAMPLES = {
    "params": ("spine-gym design params --preset alternative",),
    "sweep": (
        "spine-gym design sweep --param a=6e-3:14e-3:3 --param n_w=1,2 --workers 2 -o runs/design/grid",
        "spine-gym design sweep --param n_modules=1,2 --param a=6e-3:12e-3:2 -o runs/design/chain   # chained layouts",
    ),
    "optimize": (
        'spine-gym design optimize --space a=6e-3:14e-3 --space n_w=1,2,3 --maximize stable_angle '
        '--constraint "ability>=0.15" --n-trials 60 --workers 2 -o runs/design/opt',
    ),
    "best": ("spine-gym design best --storage runs/design/opt/study.journal --study-name spine-design",),
}


def _add_axes(p: argparse.ArgumentParser, flag: str, help: str) -> None:
    """``flag NAME=SPEC``, required and repeatable: one axis of a sweep or dimension of a search."""
    p.add_argument(flag, action="append", required=True, metavar="NAME=SPEC", help=help)


def _add_params_parser(sub) -> None:
    """The ``params`` subcommand."""
    p = sub.add_parser(
        "params", help="list the design parameters, their base values and ranges",
        description="The design parameters, their base values and allowed ranges.", examples=EXAMPLES["params"],
    )  # fmt: skip
    p.add_argument("--preset", choices=sorted(PRESETS), default="baseline", help="base parameter set")


def _add_sweep_parser(sub) -> None:
    """The ``sweep`` subcommand."""
    p = sub.add_parser(
        "sweep",
        help="capacity metrics over a grid (CSV + PNG)",
        description="Grid sweep. --param NAME=lo:hi:n | lo:hi:n:log | v1,v2,... "
        "(repeat for more axes; the last axis varies fastest).",
        examples=EXAMPLES["sweep"],
    )
    _add_axes(
        p,
        "--param",
        "sweep axis, e.g. a=6e-3:14e-3:9, n_w=1,2,3, E_t=10e6:100e6:5:log, voltage=2.8,3.2, "
        "n_modules=1,2,3 (chained four-wire layouts)",
    )
    _add_common(p)
    p.add_argument(
        "--backend",
        choices=("process", "thread"),
        default="process",
        help="process pool (default) or thread pool (the kernels release the GIL)",
    )
    p.add_argument(
        "--metrics",
        default=None,
        help="comma-separated metrics to plot/print (default stable angle, responding time, ability)",
    )
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")


def _add_optimize_parser(sub) -> None:
    """The ``optimize`` (``optimise``) subcommand."""
    p = sub.add_parser(
        "optimize",
        aliases=["optimise"],
        help="constrained optimisation with Optuna",
        description="Search NAME=lo:hi | lo:hi:log | v1,v2,... (categorical).",
        examples=EXAMPLES["optimize"],
    )
    _add_axes(p, "--space", "search dimension, e.g. a=6e-3:14e-3, n_w=1,2,3, E_t=10e6:100e6:log")
    metrics = ", ".join(METRICS)
    p.add_argument("--maximize", "--maximise", metavar="METRIC", help=f"the objective to maximise, one of: {metrics}")
    p.add_argument("--minimize", "--minimise", metavar="METRIC", help="the objective to minimise (give one of the two)")
    p.add_argument(
        "--constraint",
        action="append",
        metavar="METRIC>=X|METRIC<=Y",
        help='e.g. "ability>=0.15", "responding_time<=36" (repeatable)',
    )
    p.add_argument("--n-trials", type=int, default=50, help="trials run by this command (all workers)")
    p.add_argument(
        "--max-total-trials",
        type=int,
        default=None,
        help="global budget of the stored study (stops every worker on every machine)",
    )
    p.add_argument(
        "--storage",
        default=None,
        help="journal file path or RDB URL (sqlite:///..., postgresql+psycopg2://..., "
        "mysql+pymysql://...); default OUT/study.journal",
    )
    p.add_argument("--study-name", default="spine-design", help="the study's name in --storage")
    p.add_argument("--sampler", choices=("tpe", "nsga2", "random"), default="tpe", help="Optuna sampler")
    p.add_argument("--n-startup-trials", type=int, default=10, help="random trials before TPE (per worker)")
    p.add_argument("--seed", type=int, default=0, help="sampler seed (worker i uses seed+i)")
    p.add_argument("--timeout", type=float, default=None, help="per-worker time limit [s]")
    _add_common(p)


def _add_best_parser(sub) -> None:
    """The ``best`` subcommand."""
    p = sub.add_parser(
        "best", help="print the best design of a stored study",
        description="The best design of a stored study.", examples=EXAMPLES["best"],
    )  # fmt: skip
    p.add_argument("--storage", required=True, help="journal file path or RDB URL of the study")
    p.add_argument("--study-name", default="spine-design", help="the study's name in --storage")
    p.add_argument("--json", action="store_true", help="also print the full summary as JSON")


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = Parser(
        prog=prog,
        description="Design studies of the SMA spine: capacity sweeps, constrained optimisation "
        "(Optuna), scale-out on a shared study. Guide: docs/design.md",
        examples=[e for group in EXAMPLES.values() for e in group],
    )
    sub = parser.add_subparsers(dest="cmd", required=True, metavar="{params,sweep,optimize,best}")

    _add_params_parser(sub)
    _add_sweep_parser(sub)
    _add_optimize_parser(sub)
    _add_best_parser(sub)
    return parser


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """Run the CLI; exit status 0, or 2 (one line on stderr) on a bad argument, before any work."""
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    sub = parser._subparsers._group_actions[0].choices[args.cmd]  # for errors in the right usage
    if args.cmd == "params":
        return _cmd_params(args)
    if args.cmd == "sweep":
        return _cmd_sweep(args, sub)
    if args.cmd in ("optimize", "optimise"):
        return _cmd_optimize(args, sub)
    return _cmd_best(args, sub)


if __name__ == "__main__":
    sys.exit(main())
