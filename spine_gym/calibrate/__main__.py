"""Command line: fit ModelParams to measured CSV experiments and write preset, report and plots.

Example (``spine-gym calibrate`` is the same command)::

    python -m spine_gym.calibrate run1.csv run2.csv --params alpha,E_t,T_shift,lam_A \\
        --start alternative --noise angle=0.5,temperature=1 --out results/calibration --seed 0

writes ``fit.json`` (the preset, loadable with ``ModelParams.from_file`` and usable as
``domain_randomization="fit.json"``), ``report.md``, ``report.json`` and PNG plots to ``--out``.

CSVs with ``voltage_0`` … columns are spatial experiments (:mod:`.spatial_data`), fitted on the
layout ``--layout`` (``seed``: the four-wire module; ``chain:<n>``: n modules), e.g.
``--params wires`` for every wire's resistivity scale, transformation-temperature shift and
pre-strain plus E_t and α.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..cli_conventions import (
    Parser,
    add_out,
    add_progress,
    add_workers,
    check_file,
    check_out_dir,
    first_line,
    module_prog,
    positive_int,
)
from ..layout import SpineLayout
from ..params import PRESETS, ModelParams
from .data import Experiment
from .fit import fit
from .parameters import PARAMETER_SETS, FitParameter, resolve_parameters
from .spatial_data import SpatialExperiment


def _pairs(text: str, what: str) -> dict[str, str]:
    out = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        key, sep, val = item.partition("=")
        if not sep:
            raise ValueError(f"{what}: expected name=value, got {item!r}")
        out[key.strip()] = val.strip()
    return out


def _noise(text: str | None) -> dict[str, float]:
    if not text:
        return {}
    out = {}
    for k, v in _pairs(text, "--noise").items():
        try:
            out[k] = float(v)
        except ValueError:
            raise ValueError(f"--noise: {k} must be a number, got {v!r}") from None
    return out


def _start(text: str) -> tuple[ModelParams, str]:
    if text in PRESETS:
        return PRESETS[text](), text
    return ModelParams.from_file(text), text


def _layout(text: str, params: ModelParams) -> SpineLayout:
    if text == "seed":
        return SpineLayout.seed(params)
    kind, sep, n = text.partition(":")
    if kind == "chain" and sep and n.isdigit():
        return SpineLayout.chain(int(n), params)
    raise ValueError(f"--layout must be 'seed' or 'chain:<n>', got {text!r}")


def _is_spatial(path: str) -> bool:
    with open(path, newline="") as fh:
        return "voltage_0" in [h.strip() for h in fh.readline().split(",")]


def _experiments(paths, noise, layout_text, params):
    """(experiments, start) : planar CSVs with the params, spatial ones with the layout."""
    spatial = [_is_spatial(p) for p in paths]
    if any(spatial) and not all(spatial):
        raise ValueError(
            "give either planar CSVs (voltage_right/left) or spatial ones (voltage_0 …), not both"
        )
    if all(spatial):
        return [SpatialExperiment.from_csv(p, noise=noise) for p in paths], _layout(layout_text, params)
    return [Experiment.from_csv(p, noise=noise) for p in paths], params


def _parameters(names: str, bounds: str | None, start) -> tuple[FitParameter, ...]:
    """Names (or a set) with default bounds, overridden by ``--bounds name=lo:hi,...``."""
    params = list(resolve_parameters(names, start))
    for key, val in _pairs(bounds or "", "--bounds").items():
        lo, sep, hi = val.partition(":")
        idx = [p.name for p in params].index(key) if key in [p.name for p in params] else None
        if idx is None or not sep:
            raise ValueError(f"--bounds: expected name=lower:upper for a fitted parameter, got {key}={val}")
        try:
            params[idx] = FitParameter(key, float(lo), float(hi))
        except ValueError as e:
            raise ValueError(f"--bounds: {e}") from None
    return resolve_parameters(params, start)


#: this command's name as ``python -m <module>`` (``spine-gym <command>`` passes its own ``prog``)
PROG = module_prog(__spec__.name)

EXAMPLES = """
spine-gym calibrate run1.csv run2.csv --params alpha,E_t,T_shift,lam_A -o results/calibration
spine-gym calibrate run1.csv --start alternative --noise angle=0.5,temperature=1 --workers 2
spine-gym calibrate results/spatial_example/*.csv --layout seed --params wires --no-progress
"""


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    ap = Parser(
        prog=prog,
        examples=EXAMPLES,
        description="Fit spine_gym ModelParams to measured experiments (CSV: time, voltage_right, "
        "voltage_left, angle [+ temperature_*, resistance_*, tip_force_x/y]; or spatial: time, "
        "voltage_0.., bend_1, bend_2 and/or tip_x/y/z [+ temperature_<j>, resistance_<j>, tip_force_x/y/z]).",
    )
    ap.add_argument("csv", nargs="+", help="measured experiments (CSV files)")
    ap.add_argument(
        "--params",
        default="thermal",
        help=f"parameters to fit: one of {sorted(PARAMETER_SETS)} or comma-separated names "
        "(e.g. alpha,E_t,T_shift,lam_A); default thermal",
    )
    ap.add_argument("--bounds", default=None, help="override bounds: name=lower:upper,... (parameter units)")
    ap.add_argument(
        "--start",
        default="baseline",
        help=f"start preset: one of {sorted(PRESETS)} or a preset file (.json/.yaml)",
    )
    ap.add_argument(
        "--noise",
        default=None,
        help="noise levels: channel-or-kind=std,... (angle deg, temperature K, resistance Ohm)",
    )
    ap.add_argument(
        "--layout", default="seed", help="spatial CSVs: the layout, 'seed' (four-wire module) or 'chain:<n>'"
    )
    add_out(ap, default="results/calibration")
    ap.add_argument("--seed", type=int, default=0, help="random seed of the CMA-ES stage and of the random starts")
    ap.add_argument(
        "--n-starts", type=positive_int, default=2,
        help="least-squares starts: the CMA-ES optimum, the start preset, then random points",
    )  # fmt: skip
    ap.add_argument(
        "--cma-evals", type=positive_int, default=None,
        help="CMA-ES budget in candidates (default: 30 generations of its default population)",
    )  # fmt: skip
    ap.add_argument("--no-global", action="store_true", help="skip the CMA-ES global stage")
    ap.add_argument("--max-nfev", type=int, default=30, help="evaluations per least-squares start")
    ap.add_argument("--loss", default="linear", help="least_squares loss (linear, soft_l1, huber, ...)")
    add_workers(ap, default=None, help="threads simulating candidates (default: all cores)")
    ap.add_argument("--format", choices=("json", "yaml"), default="json", help="format of the preset file")
    add_progress(ap)
    return ap


def main(argv: list[str] | None = None, prog: str = PROG) -> int:
    """Run the CLI; exit status 0 (130 if interrupted), or 2 (one line on stderr) on a bad argument,
    before the fit starts."""
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    try:
        for path in args.csv:
            check_file(path, "csv")
        check_out_dir(args.out)
        start, start_name = _start(args.start)
        noise = _noise(args.noise)
        experiments, start = _experiments(args.csv, noise, args.layout, start)
        params = _parameters(args.params, args.bounds, start)
        res = fit(
            experiments,
            params,
            start,
            seed=args.seed,
            n_starts=args.n_starts,
            global_stage=not args.no_global,
            cma_evals=args.cma_evals,
            max_nfev=args.max_nfev,
            loss=args.loss,
            n_workers=args.workers,
            progress=args.progress,
            start_name=start_name,
        )
    except (ValueError, FileNotFoundError) as e:
        print(f"{parser.prog}: error: {first_line(e)}", file=sys.stderr)
        return 2
    out = Path(args.out)
    preset = res.to_file(out / f"fit.{args.format}")
    (out / "report.md").write_text(res.report())
    res.to_json(out / "report.json")
    plots = res.plot(out)
    print(res.report())
    print(
        f"wrote {preset}, {out / 'report.md'}, {out / 'report.json'} and {len(plots)} PNG plot(s) to {out}/"
    )
    return 130 if res.interrupted else 0


if __name__ == "__main__":
    sys.exit(main())
