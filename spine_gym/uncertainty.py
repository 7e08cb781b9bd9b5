"""Parameter uncertainty of a fitted preset, and draws from it (domain randomisation from a fit).

A fit (:mod:`spine_gym.calibrate`) estimates a few *fit parameters*. Each one moves the model along
a fixed direction in :class:`~spine_gym.params.ModelParams` space: a plain field (``alpha``: the
direction ``{"alpha": 1}``) or a composite such as ``T_shift`` (``{"T_low": 1, "T_high": 1}``:
both stress-line anchors together, i.e. the transformation temperatures). The fit's covariance of
those parameters, stored in the preset's provenance (``provenance["fit"]``), is what this module
reads and samples. It needs numpy only, so the environments can use it without scipy.

Draws: the identified parameters from a multivariate normal with the fit's covariance, each
clipped to its fit bounds; a parameter the data could not identify (flagged by the fit) uniformly
over its bounds, independently, because the data say nothing about it beyond those bounds.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .params import ModelParams, load_preset

__all__ = ["ParameterUncertainty", "apply_offsets"]

MAX_REDRAWS = 100  # draws that leave the model's valid range are redrawn at most this often


def apply_offsets(base: ModelParams, directions, offsets) -> ModelParams:
    """``base`` moved by ``offsets[j]`` along ``directions[j]`` ({field: coefficient}); validated."""
    changes: dict[str, float] = {}
    for direction, off in zip(directions, offsets, strict=True):
        for field, coef in direction.items():
            changes[field] = changes.get(field, getattr(base, field)) + coef * float(off)
    return base.replace(**changes)


@dataclass(frozen=True, eq=False)
class ParameterUncertainty:
    """What a fit does not know: parameter directions, estimates, covariance, bounds.

    Attributes:
        names: fit-parameter names.
        directions: per parameter, {ModelParams field: coefficient} (value change per unit).
        values: fitted values (the preset's parameters sit at these).
        covariance: (n, n) covariance of the estimates, in the parameters' units (finite for the
            identified parameters; rows of unidentified ones are ignored).
        lower, upper: the fit bounds (draws stay inside them).
        identified: per parameter, whether the data identified it.
        params: the fitted preset.
        source: the file it came from ('' if built in memory).
    """

    names: tuple[str, ...]
    directions: tuple[dict, ...]
    values: np.ndarray
    covariance: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    identified: np.ndarray
    params: ModelParams
    source: str = ""

    def __post_init__(self):
        n = len(self.names)
        shapes = {
            "values": (self.values, (n,)),
            "covariance": (self.covariance, (n, n)),
            "lower": (self.lower, (n,)),
            "upper": (self.upper, (n,)),
            "identified": (self.identified, (n,)),
        }
        for key, (arr, shape) in shapes.items():
            if np.shape(arr) != shape:
                raise ValueError(
                    f"{self.source or 'fit'}: {key} must have shape {shape}, got {np.shape(arr)}"
                )
        if n == 0 or len(self.directions) != n:
            raise ValueError(f"{self.source or 'fit'}: needs one direction per parameter (got {n} names)")
        ok = np.asarray(self.identified, dtype=bool)
        cov = np.asarray(self.covariance, dtype=float)[np.ix_(ok, ok)]
        if not np.all(np.isfinite(cov)) or (
            cov.size and np.min(np.linalg.eigvalsh(cov)) < -1e-9 * np.max(np.abs(cov))
        ):
            raise ValueError(
                f"{self.source or 'fit'}: the covariance of the identified parameters must be finite and "
                "positive semi-definite"
            )
        if np.any(self.lower > self.values) or np.any(self.upper < self.values):
            raise ValueError(f"{self.source or 'fit'}: every fitted value must lie within its bounds")

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_file(cls, path: str | Path) -> ParameterUncertainty:
        """Read the uncertainty of a preset written by a fit (``FitResult.to_file``)."""
        params, provenance = load_preset(path)
        fit = provenance.get("fit")
        if not isinstance(fit, dict) or "parameters" not in fit or "covariance" not in fit:
            raise ValueError(
                f"{path}: the preset carries no fit uncertainty (provenance['fit'] with 'parameters' and "
                "'covariance'); write it with spine_gym.calibrate (FitResult.to_file)"
            )
        if fit["covariance"] is None:
            raise ValueError(f"{path}: the fit was interrupted and has no covariance to draw from")
        items = fit["parameters"]
        try:
            cov = np.array(
                [[np.nan if c is None else float(c) for c in row] for row in fit["covariance"]], dtype=float
            )
            return cls(
                names=tuple(str(p["name"]) for p in items),
                directions=tuple({str(k): float(v) for k, v in p["directions"].items()} for p in items),
                values=np.array([float(p["value"]) for p in items]),
                covariance=cov,
                lower=np.array([float(p["lower"]) for p in items]),
                upper=np.array([float(p["upper"]) for p in items]),
                identified=np.array([bool(p["identified"]) for p in items]),
                params=params,
                source=str(path),
            )
        except (KeyError, TypeError, AttributeError) as e:
            raise ValueError(f"{path}: malformed provenance['fit'] ({type(e).__name__}: {e})") from None

    # ------------------------------------------------------------------ draws
    def draw_offsets(self, rng: np.random.Generator) -> np.ndarray:
        """One draw of the parameters minus their fitted values (n,), inside the bounds."""
        ok = np.asarray(self.identified, dtype=bool)
        out = np.empty(len(self.names))
        if ok.any():
            cov = np.asarray(self.covariance, dtype=float)[np.ix_(ok, ok)]
            w, q = np.linalg.eigh(cov)
            z = rng.standard_normal(int(ok.sum()))
            out[ok] = q @ (np.sqrt(np.clip(w, 0.0, None)) * z)
        if (~ok).any():
            out[~ok] = rng.uniform(self.lower[~ok], self.upper[~ok]) - self.values[~ok]
        return np.clip(out, self.lower - self.values, self.upper - self.values)

    def draw(self, rng: np.random.Generator, base: ModelParams | None = None) -> ModelParams:
        """A parameter set drawn about ``base`` (default: the fitted preset), redrawing invalid sets."""
        base = base or self.params
        err = None
        for _ in range(MAX_REDRAWS):
            try:
                return apply_offsets(base, self.directions, self.draw_offsets(rng))
            except ValueError as e:  # e.g. a draw violating eps_T > dsigma/E_M
                err = e
        raise ValueError(
            f"{self.source or 'fit'}: {MAX_REDRAWS} draws in a row left the model's range: {err}"
        )

    def extremes(self, base: ModelParams | None = None) -> list[ModelParams]:
        """``base`` with each parameter at its lower and at its upper draw limit (valid ones only)."""
        base = base or self.params
        out = []
        for j in range(len(self.names)):
            for bound in (self.lower[j], self.upper[j]):
                off = np.zeros(len(self.names))
                off[j] = bound - self.values[j]
                try:
                    out.append(apply_offsets(base, self.directions, off))
                except ValueError:
                    continue
        return out
