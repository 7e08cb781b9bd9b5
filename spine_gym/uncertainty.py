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

A spatial fit also has per-wire directions ``{"wire<j>.<value>": 1}`` (a wire's ``lam_scale``,
``T_shift`` or ``eps0``, :class:`~spine_gym.WireGroup`); the fitted per-wire values are kept in
``wire_values`` (provenance ``["layout"]["wire_values"]``), and :meth:`ParameterUncertainty.draw_plant`
draws both the params and the per-wire values.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .layout import SpineLayout, wire_key
from .params import ModelParams, load_preset

__all__ = ["ParameterUncertainty", "apply_offsets"]

MAX_REDRAWS = 100  # draws that leave the model's valid range are redrawn at most this often


def apply_offsets(base: ModelParams | SpineLayout, directions, offsets):
    """``base`` moved by ``offsets[j]`` along ``directions[j]`` ({field: coefficient}); validated.

    ``base`` is a ModelParams, or a SpineLayout whose params take the ModelParams fields and whose
    wire groups take the per-wire keys ``wire<j>.<value>``."""
    params = base.params if isinstance(base, SpineLayout) else base
    changes: dict[str, float] = {}
    wires: dict[tuple[int, str], float] = {}
    for direction, off in zip(directions, offsets, strict=True):
        for field, coef in direction.items():
            key = wire_key(field)
            if key is None:
                changes[field] = changes.get(field, getattr(params, field)) + coef * float(off)
                continue
            if not isinstance(base, SpineLayout) or key[0] >= base.n_wires:
                raise ValueError(f"direction {field!r} needs a SpineLayout with more than {key[0]} wires")
            wires[key] = wires.get(key, base.wire_values[key[0]][key[1]]) + coef * float(off)
    if not isinstance(base, SpineLayout):
        return params.replace(**changes)
    values = [{} for _ in range(base.n_wires)]
    for (j, name), v in wires.items():
        values[j][name] = v
    out = base.replace(params=params.replace(**changes)) if changes else base
    return out.with_wire_values(values) if wires else out


def with_wire_values(layout: SpineLayout, wire_values) -> SpineLayout:
    """``layout`` with the per-wire values ``wire_values`` (one mapping per wire, or None)."""
    if wire_values is None:
        return layout
    if len(wire_values) != layout.n_wires:
        raise ValueError(
            f"wire_values must have one entry per wire of the layout ({layout.n_wires}), got {len(wire_values)}"
        )
    return layout.with_wire_values([dict(v) for v in wire_values])


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
        wire_values: a spatial fit's per-wire values (one {lam_scale, T_shift, eps0} per wire, in
            voltage order), or None.
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
    wire_values: tuple | None = None

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
                wire_values=_wire_values(provenance, path),
            )
        except (KeyError, TypeError, AttributeError) as e:
            raise ValueError(f"{path}: malformed provenance['fit'] ({type(e).__name__}: {e})") from None

    @property
    def per_wire(self) -> bool:
        """Whether any direction moves a per-wire value (the draws need a layout)."""
        return any(wire_key(f) is not None for d in self.directions for f in d)

    def shared_only(self) -> ParameterUncertainty:
        """The same uncertainty without the per-wire parameters (their marginal is unchanged)."""
        keep = [j for j, d in enumerate(self.directions) if all(wire_key(f) is None for f in d)]
        if not keep:
            raise ValueError(f"{self.source or 'fit'}: the fit has no shared (non per-wire) parameters")
        k = np.array(keep)
        return ParameterUncertainty(
            names=tuple(self.names[j] for j in keep),
            directions=tuple(self.directions[j] for j in keep),
            values=self.values[k],
            covariance=np.asarray(self.covariance)[np.ix_(k, k)],
            lower=self.lower[k],
            upper=self.upper[k],
            identified=self.identified[k],
            params=self.params,
            source=self.source,
            wire_values=self.wire_values,
        )

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

    def draw_plant(self, rng: np.random.Generator, base: SpineLayout) -> SpineLayout:
        """A layout drawn about ``base`` (its params and per-wire values), redrawing invalid sets."""
        err = None
        for _ in range(MAX_REDRAWS):
            try:
                return apply_offsets(base, self.directions, self.draw_offsets(rng))
            except ValueError as e:
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


def _wire_values(provenance: dict, path) -> tuple | None:
    """The per-wire values a spatial fit stored (provenance["layout"]["wire_values"]), or None."""
    lay = provenance.get("layout")
    if lay is None:
        return None
    values = lay.get("wire_values") if isinstance(lay, dict) else None
    if not isinstance(values, list) or not all(isinstance(v, dict) for v in values):
        raise ValueError(f"{path}: provenance['layout']['wire_values'] must be a list of mappings")
    return tuple({str(k): float(x) for k, x in v.items()} for v in values)
