"""The whole reproduction run: every experiment, its comparison tables, the files and the command line.

:func:`reproduce` runs the hysteresis run, the alternate drive and the capacity cases
(:mod:`.references`), compares them (:mod:`.tables`) and writes ``reproduction.md``/``.json``, the
trajectory CSVs and the PNG plots; :func:`main` is ``python -m spine_gym.experiments``.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from .. import plotting
from ..capacity import CapacityMetrics, CapacityProtocol, capacity_metrics
from ..cli_conventions import Parser, add_out, add_progress, check_out_dir, module_prog, usage_errors
from ..params import ModelParams, SolverOptions
from ..simulate import SimulationResult
from .references import (
    ALTERNATE_REFERENCE,
    CAPACITY_REFERENCE,
    HYSTERESIS_REFERENCE,
    REFERENCE_NOTE,
    SEED_MAX_ERROR_DEG,
    alternate_events,
    hysteresis_events,
    run_alternate,
    run_hysteresis,
)
from .tables import Section, capacity_cases, compare_experiments, format_section

__all__ = ["Reproduction", "build_parser", "main", "reproduce"]


@dataclass
class Reproduction:
    """Everything :func:`reproduce` computed (sections, trajectories, capacity metrics, files)."""

    sections: list[Section]
    hysteresis: SimulationResult
    alternate: SimulationResult
    capacity: dict[str, CapacityMetrics]
    files: list[Path] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def n_outside(self) -> int:
        return sum(s.n_outside for s in self.sections)

    def markdown(self) -> str:
        """All tables as one markdown document."""
        parts = [
            "## Reproduction of the seed paper's experiments (spine_gym)",
            "",
            f"Model values next to the reference values. {REFERENCE_NOTE}",
            "",
        ]
        for s in self.sections:
            parts += [format_section(s), ""]
        parts.append(
            f"Total rows outside tolerance: {self.n_outside} of {sum(len(s.rows) for s in self.sections)}."
        )
        return "\n".join(parts) + "\n"

    def as_dict(self) -> dict:
        return {
            "note": REFERENCE_NOTE,
            "seed_max_error_deg": SEED_MAX_ERROR_DEG,
            "sections": {
                s.key: {"title": s.title, "notes": s.notes, "rows": [r.as_dict() for r in s.rows]}
                for s in self.sections
            },
            "capacity_metrics": {k: m.as_dict() for k, m in self.capacity.items()},
            "events": {
                "hysteresis": hysteresis_events(self.hysteresis),
                "alternate": alternate_events(self.alternate),
            },
            "rows_outside_tolerance": self.n_outside,
            "seconds": self.seconds,
        }


def _write_csv(result: SimulationResult, path: Path) -> Path:
    cols = [
        ("time_s", result.time),
        ("angle_deg", result.angle_deg),
        ("voltage_right_V", result.voltage_right),
        ("voltage_left_V", result.voltage_left),
        ("temperature_right_K", result.temperature_right),
        ("temperature_left_K", result.temperature_left),
        ("stress_right_MPa", result.stress_right / 1e6),
        ("stress_left_MPa", result.stress_left / 1e6),
        ("x_austenite_right", result.x_austenite_right),
        ("x_austenite_left", result.x_austenite_left),
    ]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow([c for c, _ in cols])
        for row in zip(*(v for _, v in cols), strict=True):
            w.writerow([f"{x:.6g}" for x in row])
    return path


def _json_default(o):
    if isinstance(o, float | np.floating):
        return float(o)
    return str(o)


def _finite_json(obj):
    """Replace inf/nan by strings so the file is strict JSON."""
    if isinstance(obj, dict):
        return {k: _finite_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite_json(v) for v in obj]
    if isinstance(obj, float | np.floating) and not math.isfinite(obj):
        return "nan" if math.isnan(obj) else ("inf" if obj > 0 else "-inf")
    return obj


def reproduce(
    out_dir: str | Path | None = "runs/experiments",
    *,
    quick: bool = False,
    solver: SolverOptions | None = None,
    progress: bool = True,
    plots: bool = True,
) -> Reproduction:
    """Run every experiment, compare with MODEL.md §10 and (optionally) write tables and plots.

    Args:
        out_dir: folder for ``reproduction.md/.json``, the trajectory CSVs and the PNGs
            (``None``: write nothing).
        quick: run four of the seven §10.4 capacity cases (a = 6, 10, 14 mm; 3 wires per side) and
            write lower-resolution PNGs; the hysteresis and alternate runs are always complete.
        solver: numerical options (default :class:`SolverOptions`).
        progress: show a tqdm progress bar on stderr.
        plots: write the PNG plots (needs ``out_dir``).

    Returns:
        A :class:`Reproduction`.
    """
    t_start = time.perf_counter()
    cases = capacity_cases(quick)
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:
        if out.exists() and not out.is_dir():
            raise ValueError(f"out_dir must be a directory, got an existing file {str(out)!r}")
        out.mkdir(parents=True, exist_ok=True)
    n_plot_steps = 5 if (plots and out is not None) else 0
    protocol = CapacityProtocol()
    capacity: dict[str, CapacityMetrics] = {}
    with tqdm(
        total=2 + len(cases) + n_plot_steps, desc="experiments", unit="step", disable=not progress
    ) as bar:
        bar.set_postfix_str("hysteresis (§10.2)")
        hyst = run_hysteresis(solver=solver)
        bar.update()
        bar.set_postfix_str("alternate drive (§10.3)")
        alt = run_alternate(solver=solver)
        bar.update()
        for case in cases:
            bar.set_postfix_str(f"capacity {case} (§10.4)")
            params = ModelParams().replace(**CAPACITY_REFERENCE[case][0])
            capacity[case] = capacity_metrics(params, protocol, solver)
            bar.update()
        sections = compare_experiments(hyst, alt, capacity)
        rep = Reproduction(sections, hyst, alt, capacity)
        if out is not None and plots:
            rep.files += _write_plots(rep, out, dpi=70 if quick else 120, bar=bar)
    rep.seconds = time.perf_counter() - t_start
    if out is not None:
        (out / "reproduction.md").write_text(rep.markdown(), encoding="utf-8")
        (out / "reproduction.json").write_text(
            json.dumps(_finite_json(rep.as_dict()), indent=2, default=_json_default, ensure_ascii=False),
            encoding="utf-8",
        )
        rep.files += [
            out / "reproduction.md",
            out / "reproduction.json",
            _write_csv(hyst, out / "hysteresis.csv"),
            _write_csv(alt, out / "alternate.csv"),
        ]
    return rep


def _write_plots(rep: Reproduction, out: Path, dpi: int, bar) -> list[Path]:
    files = []

    def step(name):
        bar.set_postfix_str(f"plot {name}")

    for name, result, reference, section, title in (
        ("hysteresis", rep.hysteresis, HYSTERESIS_REFERENCE, "§10.2",
         "Hysteresis run: right wire 3.2 V for 20 s, then off"),
        ("alternate", rep.alternate, ALTERNATE_REFERENCE, "§10.3",
         "Alternate drive: right wire 3.2 V 0–20 s, left wire 3.2 V 20–40 s"),
    ):  # fmt: skip
        step(f"{name} angle")
        times, angles = zip(*reference.items(), strict=True)
        files.append(
            plotting.plot_angle(
                result,
                out / f"{name}_angle.png",
                reference=(times, angles),
                reference_label=f"reference solution (MODEL.md {section})",
                title=title,
                dpi=dpi,
            )
        )
        bar.update()
    step("hysteresis wire states")
    files.append(
        plotting.plot_wire_states(
            rep.hysteresis, out / "hysteresis_states.png", title="Hysteresis run: wire states", dpi=dpi
        )
    )
    bar.update()
    for fname, prefix, xlabel, scale, integer in (
        ("capacity_vs_a.png", "a = ", "wire offset a [mm]", 1e3, False),
        ("capacity_vs_wires.png", "n_w = ", "wires per side n_w", 1.0, True),
    ):
        step(fname)
        # the baseline (a = 14 mm, n_w = 1) belongs to both studies
        keys = [k for k in rep.capacity if k.startswith(prefix) or k == "a = 14 mm"]
        param = "a" if prefix == "a = " else "n_w"
        xs = [CAPACITY_REFERENCE[k][0].get(param, getattr(ModelParams(), param)) * scale for k in keys]
        refs = [_reference_metrics(k) for k in keys]
        files.append(
            plotting.plot_capacity(
                xs,
                [rep.capacity[k] for k in keys],
                out / fname,
                xlabel=xlabel,
                reference=refs,
                reference_label="reference solution (MODEL.md §10.4)",
                title=f"Capacity metrics vs {xlabel} (seed Fig. {15 if param == 'a' else 16}-like)",
                integer_x=integer,
                dpi=dpi,
            )
        )
        bar.update()
    return files


def _reference_metrics(case: str) -> dict[str, float]:
    r = CAPACITY_REFERENCE[case][1]
    return {
        "stable_angle_deg": r["stable"],
        "responding_time_s": r["resp"],
        "responding_time_swing_s": r["swing"],
        "load_deflection_deg": r["defl"],
        "actuating_ability": r["ability"],
    }


# ------------------------------------------------------------------------------------- CLI
#: this command's name as ``python -m spine_gym.experiments`` (``spine-gym reproduce`` passes its own ``prog``)
PROG = module_prog(__package__)

EXAMPLES = """
spine-gym reproduce                           # every experiment, tables and plots in runs/experiments
spine-gym reproduce --quick -o runs/repro --no-progress
spine-gym reproduce --method bisect --strict  # the seed's solver; exit status 1 if a row is off
"""


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line of :func:`main` (``spine-gym reproduce``)."""
    ap = Parser(
        prog=prog,
        description="Reproduce the seed paper's experiments (MODEL.md §10.2-§10.4) and compare with "
        "the reference solution values of MODEL.md §10.",
        examples=EXAMPLES,
    )
    add_out(ap, default="runs/experiments")
    ap.add_argument(
        "--quick",
        action="store_true",
        help="four of the seven capacity cases (a = 6, 10, 14 mm; n_w = 3) and low-resolution PNGs",
    )
    ap.add_argument(
        "--method",
        choices=["newton", "illinois", "bisect"],
        default="newton",
        help="composite solver (default: %(default)s; 'bisect' is the seed's algorithm)",
    )
    ap.add_argument("--no-plots", action="store_true", help="write tables and CSVs only")
    add_progress(ap)
    ap.add_argument("--strict", action="store_true", help="exit with 1 if any row is outside tolerance")
    return ap


def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    """``python -m spine_gym.experiments`` (``spine-gym reproduce``): run, print the tables, write
    files; exit code 0.

    With ``--strict`` the exit code is 1 when any row is outside its tolerance; a usage error exits
    with 2 (one line on stderr) before any work.
    """
    ap = build_parser(prog)
    args = ap.parse_args(argv)
    with usage_errors(ap):
        check_out_dir(args.out)
        rep = reproduce(
            args.out,
            quick=args.quick,
            solver=SolverOptions(method=args.method),
            progress=args.progress,
            plots=not args.no_plots,
        )
    print(rep.markdown())
    print(f"Wrote {len(rep.files)} files to {args.out} in {rep.seconds:.1f} s:")
    for p in rep.files:
        print(f"  {p}")
    sys.stdout.flush()
    return 1 if (args.strict and rep.n_outside) else 0
