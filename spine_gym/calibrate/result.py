"""The outcome of a fit: fitted preset, uncertainties, report, PNG plots, loadable file.

``FitResult.to_file("fit.json")`` writes a ModelParams preset (``ModelParams.from_file`` reads
it) whose provenance holds the fit: parameters with bounds, standard errors, identifiability,
covariance and correlation, RMSE per experiment and channel, the experiments, the settings and
the seed. The same file is what ``gym.make("SmaSpine-v0", domain_randomization="fit.json")``
draws from (:class:`spine_gym.uncertainty.ParameterUncertainty`).
"""

from __future__ import annotations

import dataclasses
import datetime
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..layout import SpineLayout
from ..params import ModelParams
from ..uncertainty import ParameterUncertainty
from .data import Experiment
from .model import channel, simulate_experiment
from .parameters import FitParameter
from .plots import plot_correlation, plot_experiment_fit

__all__ = ["FitResult", "parameter_rows"]


def parameter_rows(params, values) -> dict[str, float]:
    return {p.name: float(v) for p, v in zip(params, values, strict=True)}


def _finite_or_none(a):
    return (
        None
        if a is None
        else [[None if not np.isfinite(x) else float(x) for x in row] for row in np.atleast_2d(a)]
    )


@dataclass
class FitResult:
    """What :func:`spine_gym.calibrate.fit` returns (arrays are per fit parameter, in its unit).

    ``std_errors`` is ``inf`` for a parameter the data do not see at all; ``std_errors``,
    ``covariance``, ``correlation`` and ``signal_to_roughness`` are None for an interrupted fit.
    ``signal_to_roughness``: per parameter, the residuals' change over the Jacobian step divided by
    their change over a negligible step (below 3 the parameter is flagged not identified).
    ``params`` (and ``start``) are a ModelParams, or for a spatial fit a SpineLayout (its
    ``params`` and per-wire values). ``residuals`` are the
    weighted residuals (model − measurement)/noise at the optimum; ``cost`` = ½ Σ residuals².
    """

    parameters: tuple[FitParameter, ...]
    start: ModelParams | SpineLayout
    start_name: str
    params: ModelParams | SpineLayout
    values: np.ndarray
    start_values: np.ndarray
    std_errors: np.ndarray | None
    covariance: np.ndarray | None
    correlation: np.ndarray | None
    signal_to_roughness: np.ndarray | None
    identified: np.ndarray
    warnings: list[str]
    experiments: tuple[Experiment, ...]
    residuals: np.ndarray
    cost: float
    n_simulations: int
    wall_time: float
    seed: int
    interrupted: bool
    stages: list[dict] = field(default_factory=list)
    settings: dict = field(default_factory=dict)

    # ------------------------------------------------------------------ numbers
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def value(self, name: str) -> float:
        """Fitted value of parameter ``name``."""
        return float(self.values[self.names.index(name)])

    def std_error(self, name: str) -> float:
        if self.std_errors is None:
            raise ValueError("the fit was interrupted: no standard errors")
        return float(self.std_errors[self.names.index(name)])

    def is_identified(self, name: str) -> bool:
        return bool(self.identified[self.names.index(name)])

    def rmse(self) -> dict[str, dict[str, float]]:
        """{experiment: {channel: RMSE in the channel's unit}} at the fitted parameters."""
        out, i = {}, 0
        for e in self.experiments:
            out[e.name] = {}
            for c in e.measured:
                r = self.residuals[i : i + e.n_samples] * e.noise[c] / np.sqrt(e.weight)
                out[e.name][c] = float(np.sqrt(np.mean(r**2)))
                i += e.n_samples
        return out

    # ------------------------------------------------------------------ uncertainty and file
    def uncertainty(self) -> ParameterUncertainty:
        """The fit's uncertainty as a sampler (domain randomisation)."""
        if self.covariance is None:
            raise ValueError("the fit was interrupted: it has no uncertainty to draw from")
        cov = np.where(np.isfinite(self.covariance), self.covariance, 0.0)
        return ParameterUncertainty(
            names=self.names,
            directions=tuple(p.direction for p in self.parameters),
            values=self.values.copy(),
            covariance=cov,
            lower=np.array([p.lower for p in self.parameters]),
            upper=np.array([p.upper for p in self.parameters]),
            identified=self.identified.copy(),
            params=self.model_params,
            wire_values=self.wire_values,
        )

    @property
    def model_params(self) -> ModelParams:
        """The fitted ModelParams (a spatial fit's layout params)."""
        return self.params.params if isinstance(self.params, SpineLayout) else self.params

    @property
    def wire_values(self) -> tuple | None:
        """A spatial fit's per-wire values (one {lam_scale, T_shift, eps0} per wire), else None."""
        return tuple(self.params.wire_values) if isinstance(self.params, SpineLayout) else None

    def provenance(self) -> dict:
        se = [None] * len(self.names) if self.std_errors is None else self.std_errors
        snr = [None] * len(self.names) if self.signal_to_roughness is None else self.signal_to_roughness
        items = [
            {
                "name": p.name,
                "unit": p.unit,
                "directions": p.direction,
                "value": float(v),
                "start": float(s0),
                "lower": p.lower,
                "upper": p.upper,
                "std_error": None if e is None or not np.isfinite(e) else float(e),
                "identified": bool(ok),
                "signal_to_roughness": None if q is None or not np.isfinite(q) else float(q),
            }
            for p, v, s0, e, ok, q in zip(
                self.parameters, self.values, self.start_values, se, self.identified, snr, strict=True
            )
        ]
        layout = (
            {}
            if self.wire_values is None
            else {
                "layout": {
                    "n_modules": self.params.n_modules,
                    "n_wires": self.params.n_wires,
                    "wire_labels": self.params.wire_labels,
                    "wire_values": list(self.wire_values),
                }
            }
        )
        return {
            "source": "spine_gym.calibrate",
            **layout,
            "spine_gym_version": __version__,
            "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "start_preset": self.start_name,
            "seed": self.seed,
            "settings": self.settings,
            "experiments": [
                {
                    "name": e.name,
                    "n_samples": e.n_samples,
                    "dt": e.dt,
                    "duration": e.duration,
                    "channels": list(e.measured),
                    "noise": dict(e.noise),
                    "weight": e.weight,
                }
                for e in self.experiments
            ],
            "fit": {
                "parameters": items,
                "covariance": _finite_or_none(self.covariance) if self.covariance is not None else None,
                "correlation": _finite_or_none(self.correlation) if self.correlation is not None else None,
                "cost": self.cost,
                "reduced_chi2": self.reduced_chi2,
                "rmse": self.rmse(),
                "warnings": list(self.warnings),
                "interrupted": self.interrupted,
                "n_simulations": self.n_simulations,
                "wall_time_s": self.wall_time,
                "stages": self.stages,
            },
        }

    @property
    def reduced_chi2(self) -> float:
        """Σ residuals² / (m − n): ≈ 1 when the model fits to within the stated noise levels."""
        m, n = self.residuals.shape[0], len(self.names)
        return float(self.residuals @ self.residuals) / max(m - n, 1)

    def to_file(self, path: str | Path) -> Path:
        """Write the fitted preset with the fit's provenance (JSON or YAML by suffix); a spatial
        fit's per-wire values go to ``provenance["layout"]["wire_values"]``."""
        return self.model_params.to_file(path, provenance=self.provenance())

    # ------------------------------------------------------------------ report
    def report(self) -> str:
        """Markdown report: parameters with standard errors, correlations, RMSE, warnings."""
        lines = [
            f"# Calibration report ({len(self.experiments)} experiment(s), {len(self.names)} parameter(s))",
            "",
            f"Start preset: {self.start_name}; seed {self.seed}; {self.n_simulations} simulations in "
            f"{self.wall_time:.1f} s; cost {self.cost:.6g}; reduced chi² {self.reduced_chi2:.3f}"
            + (" (INTERRUPTED)" if self.interrupted else ""),
            "",
            "| parameter | unit | start | fitted | std. error | rel. error | bounds | signal/roughness "
            "| identified |",
            "|---|---|--:|--:|--:|--:|---|--:|---|",
        ]
        se = self.std_errors if self.std_errors is not None else [None] * len(self.names)
        snr = self.signal_to_roughness if self.signal_to_roughness is not None else [None] * len(self.names)
        for p, s0, v, e, ok, q in zip(
            self.parameters, self.start_values, self.values, se, self.identified, snr, strict=True
        ):
            e_txt = "—" if e is None else ("inf" if not np.isfinite(e) else f"{e:.4g}")
            rel = "—" if e is None or not np.isfinite(e) or v == 0 else f"{abs(e / v):.2%}"
            lines.append(
                f"| {p.name} | {p.unit} | {s0:.5g} | {v:.5g} | {e_txt} | {rel} | "
                f"[{p.lower:.4g}, {p.upper:.4g}] | "
                f"{'—' if q is None else f'{q:.3g}'} | {'yes' if ok else '**no**'} |"
            )
        if self.correlation is not None:
            lines += [
                "",
                "Correlation matrix:",
                "",
                "| | " + " | ".join(self.names) + " |",
                "|---|" + "--:|" * len(self.names),
            ]
            for name, row in zip(self.names, self.correlation, strict=True):
                lines.append(f"| {name} | " + " | ".join(f"{x:+.3f}" for x in row) + " |")
        lines += [
            "",
            "RMSE at the fitted parameters:",
            "",
            "| experiment | channel | RMSE | noise level |",
            "|---|---|--:|--:|",
        ]
        for e in self.experiments:
            for c, val in self.rmse()[e.name].items():
                lines.append(f"| {e.name} | {c} | {val:.4g} {e.unit(c)} | {e.noise[c]:.4g} {e.unit(c)} |")
        lines += ["", "Warnings:", ""] + ([f"- {w}" for w in self.warnings] or ["- none"])
        return "\n".join(lines) + "\n"

    def to_json(self, path: str | Path) -> Path:
        """Write :meth:`provenance` plus the fitted parameters as a JSON report."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        doc = {"params": dataclasses.asdict(self.model_params), **self.provenance()}
        path.write_text(json.dumps(doc, indent=2, default=float) + "\n")
        return path

    # ------------------------------------------------------------------ traces and plots
    def traces(self) -> list[dict[str, dict[str, np.ndarray]]]:
        """Per experiment {channel: {"measured", "start", "fitted"}} traces."""
        out = []
        for e in self.experiments:
            sims = {k: simulate_experiment(p, e) for k, p in (("start", self.start), ("fitted", self.params))}
            out.append(
                {
                    c: {"measured": e.measured[c], **{k: channel(r, c) for k, r in sims.items()}}
                    for c in e.measured
                }
            )
        return out

    def plot(self, out_dir: str | Path, dpi: int = 120) -> list[Path]:
        """PNG plots: measured vs start and fitted traces with residuals (one file per experiment),
        and the correlation matrix. Returns the paths."""
        out_dir = Path(out_dir)
        paths = [
            plot_experiment_fit(e, tr, out_dir / f"fit_{i}_{_slug(e.name)}.png", dpi)
            for i, (e, tr) in enumerate(zip(self.experiments, self.traces(), strict=True))
        ]
        if self.correlation is not None and len(self.names) > 1:
            paths.append(
                plot_correlation(
                    self.names, self.correlation, self.identified, out_dir / "correlation.png", dpi
                )
            )
        return paths


def _slug(name: str) -> str:
    stem = Path(name).stem
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in stem)[:40] or "experiment"
