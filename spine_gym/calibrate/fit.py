"""Fit ModelParams to measured experiments: a CMA-ES global stage, then bounded least squares.

Stages (all in the unit box of the chosen parameters, so that every coordinate is O(1)):

1. **Global stage** (optional): CMA-ES (``cma``) from the start point, each generation's
   candidates simulated in parallel; its best point becomes one more start.
2. **Local stage**: ``scipy.optimize.least_squares`` (bounded trust region, ``method="trf"``) of
   the weighted residuals from every start (the CMA-ES optimum, the start preset, and
   ``n_starts − 2`` points drawn uniformly with the seed); the forward-difference Jacobian's
   columns are simulated in parallel. The lowest cost wins.
3. **Uncertainty** at the optimum: central-difference Jacobian J; covariance s² (JᵀJ)⁻¹ with
   s² = Σr²/(m − n) (the noise levels' scale is estimated from the residuals, as ``curve_fit``
   does by default), standard errors and the correlation matrix. A parameter is flagged *not
   identified* when J has (numerically) no component along it, when its effect does not stand
   ``MIN_SIGNAL``× out of the model's numerical roughness (below), when its standard error
   exceeds ``identify_fraction`` of its bound width, or when it ends on a bound.

The model's outputs are not smooth in its parameters at the ~0.05° rms level (the antagonist's
detwinning and the fast swings move in jerks, MODEL.md §10.3): a 1e-4 relative change of E_t moves
single samples of a swing by up to 1°. Hence CMA-ES, which needs no gradients, does most of the
work; the least-squares Jacobian uses a finite-difference step of 2 % of each bound width (a
secant across that roughness); and the result is the best point evaluated anywhere.

Everything is reproducible for a seed (CMA-ES seed and the random starts; simulations are
deterministic). Ctrl-C stops the fit; the best point seen so far is returned with
``interrupted=True`` and no uncertainties.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import cma
import numpy as np
from scipy.optimize import least_squares
from tqdm import tqdm

from ..layout import SpineLayout
from ..params import ModelParams, SolverOptions
from .data import Experiment
from .model import Evaluator
from .parameters import FitParameter, resolve_parameters
from .result import FitResult, parameter_rows
from .spatial_data import SpatialExperiment

__all__ = ["fit"]

ROUGH_EPS = 1e-4  # [unit box] probe step at which a parameter's true effect is negligible
MIN_SIGNAL = 3.0  # a parameter's effect over the Jacobian step must exceed this × the model's roughness
MAX_STEP = 0.25  # largest difference step (fraction of the bound width) tried to reach MIN_SIGNAL
NULL_SINGULAR = 1e-9  # singular values of J below this × the largest count as zero
BOUND_EPS = 1e-3  # a fitted u within this of 0 or 1 sits on its bound
CMA_GENERATIONS = 30  # default CMA-ES budget in generations of its default population


@dataclass
class _Stage:
    kind: str
    start: np.ndarray
    end: np.ndarray
    cost: float
    n_simulations: int
    info: dict = field(default_factory=dict)


def _global_stage(ev: Evaluator, u0: np.ndarray, evals: int, seed: int, sigma0: float) -> _Stage:
    n0 = ev.n_simulations
    opts = {
        "bounds": [0.0, 1.0],
        "seed": int(seed) + 1,  # cma treats seed 0 as "random"
        "maxfevals": int(evals),
        "verbose": -9,
        "tolfun": 1e-9,
    }
    es = cma.CMAEvolutionStrategy(list(u0), sigma0, opts)
    while not es.stop():
        xs = es.ask()
        r = ev.residuals_many(np.array(xs))
        es.tell(xs, list(0.5 * np.einsum("ij,ij->i", r, r)))
    best = np.clip(np.asarray(es.result.xbest, dtype=float), 0.0, 1.0)
    cost = float(es.result.fbest)
    return _Stage("cma-es", u0, best, cost, ev.n_simulations - n0, {"generations": int(es.countiter)})


def _local_stage(ev: Evaluator, u0: np.ndarray, max_nfev: int, loss: str, step: float) -> _Stage:
    n0 = ev.n_simulations
    sol = least_squares(
        ev.residuals,
        np.clip(u0, 0.0, 1.0),
        jac=lambda u: ev.jacobian(u, step),
        bounds=(0.0, 1.0),
        method="trf",
        loss=loss,
        x_scale=1.0,
        ftol=1e-8,
        xtol=1e-8,
        gtol=1e-10,
        max_nfev=max_nfev,
    )
    r = ev.residuals(sol.x)
    return _Stage(
        "least_squares",
        u0,
        sol.x,
        0.5 * float(r @ r),
        ev.n_simulations - n0,
        {"nfev": int(sol.nfev), "status": int(sol.status), "message": str(sol.message)},
    )


def _covariance(jac: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(covariance in unit-box coordinates with inf on unseen directions, null-direction mask)."""
    m, n = jac.shape
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    s2 = float(r @ r) / max(m - n, 1)
    keep = s > NULL_SINGULAR * s[0] if s[0] > 0 else np.zeros(n, dtype=bool)
    cov = (vt[keep].T / s[keep] ** 2) @ vt[keep] * s2
    unseen = np.any(np.abs(vt[~keep]) > 1e-3, axis=0) if (~keep).any() else np.zeros(n, dtype=bool)
    cov[unseen, :] = np.inf
    cov[:, unseen] = np.inf
    return cov, unseen


def _robust_jacobian(ev: Evaluator, u: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Central-difference Jacobian whose columns stand out of the model's numerical roughness.

    Roughness of parameter j: how much the residuals change over a negligible step ``ROUGH_EPS``.
    Signal: how much they change over ± the difference step. Where the signal is below
    ``MIN_SIGNAL`` × the roughness, the column would be mostly roughness (and the standard error
    from it a false precision), so that parameter's step grows (up to ``MAX_STEP`` of its bound
    width) and the Jacobian is taken again. Returns (J, signal/roughness, steps).
    """
    n = u.shape[0]
    sign = np.where(u + ROUGH_EPS <= 1.0, 1.0, -1.0)
    probe = ev.residuals_many(u + np.eye(n) * (ROUGH_EPS * sign)[:, None])
    rough = np.linalg.norm(probe - ev.residuals(u), axis=1)
    steps = np.full(n, float(step))
    for _ in range(3):
        jac = ev.jacobian(u, steps, central=True)
        signal = np.linalg.norm(jac, axis=0) * steps
        with np.errstate(divide="ignore", invalid="ignore"):
            snr = np.where(rough > 0, signal / rough, np.where(signal > 0, np.inf, 0.0))
        grow = (snr < MIN_SIGNAL) & (steps < MAX_STEP)
        if not grow.any():
            break
        factor = np.where(snr > 0, 2.0 * MIN_SIGNAL / np.maximum(snr, 1e-12), MAX_STEP / steps)
        steps = np.where(grow, np.minimum(steps * np.maximum(factor, 2.0), MAX_STEP), steps)
    return jac, snr, steps


def _identifiability(params, u, se, unseen, snr, step, fraction) -> tuple[np.ndarray, list[str]]:
    ok = np.ones(len(params), dtype=bool)
    notes = []
    for j, p in enumerate(params):
        width = p.upper - p.lower
        if unseen[j]:
            ok[j] = False
            why = (
                "the residuals do not change along it"
                if snr[j] == 0
                else f"over ±{step[j] * width:.3g} {p.unit} it changes the residuals only {snr[j]:.2g}× "
                "as much as "
                "the model's numerical roughness does; a standard error from it would be a false precision"
            )
            notes.append(f"{p.name}: the data cannot identify it ({why})")
        elif u[j] < BOUND_EPS or u[j] > 1.0 - BOUND_EPS:
            ok[j] = False
            notes.append(
                f"{p.name}: ended on its bound [{p.lower:g}, {p.upper:g}] {p.unit}; the data push it "
                "outside the allowed range, so its value and standard error are not meaningful"
            )
        elif se[j] > fraction * width:
            ok[j] = False
            notes.append(
                f"{p.name}: the data cannot identify it (standard error {se[j]:.3g} {p.unit} is more than "
                f"{fraction:.0%} of its bound width {width:.3g} {p.unit})"
            )
    return ok, notes


def _correlation_notes(params, corr, ok, limit=0.95) -> list[str]:
    notes = []
    for i in range(len(params)):
        for j in range(i + 1, len(params)):
            if ok[i] and ok[j] and abs(corr[i, j]) > limit:
                notes.append(
                    f"{params[i].name} and {params[j].name} are strongly correlated (r = {corr[i, j]:+.3f}): "
                    "the data mostly see a combination of the two"
                )
    return notes


def _starts(ev: Evaluator, u0, n_starts, global_best, rng) -> list[np.ndarray]:
    starts = [u0] if global_best is None else [global_best, u0]
    while len(starts) < n_starts:
        starts.append(rng.uniform(0.05, 0.95, u0.shape[0]))
    return starts[: max(n_starts, 1)]


def _check_options(seed, n_starts, cma_evals, cma_sigma, max_nfev, fd_step, identify_fraction, loss):
    if isinstance(seed, bool) or not (isinstance(seed, int | np.integer) and 0 <= seed < 2**31):
        raise ValueError(f"seed must be an integer in [0, 2**31), got {seed!r}")
    if not (isinstance(cma_sigma, int | float) and 0.0 < cma_sigma <= 1.0):
        raise ValueError(f"cma_sigma must be in (0, 1] (unit-box coordinates), got {cma_sigma!r}")
    if not (isinstance(fd_step, int | float) and 0.0 < fd_step <= MAX_STEP):
        raise ValueError(f"fd_step must be in (0, {MAX_STEP}] (unit-box coordinates), got {fd_step!r}")
    if not (isinstance(n_starts, int) and 1 <= n_starts <= 100):
        raise ValueError(f"n_starts must be an integer in [1, 100], got {n_starts!r}")
    if cma_evals is not None and not (isinstance(cma_evals, int) and 1 <= cma_evals <= 10**7):
        raise ValueError(f"cma_evals must be None or an integer in [1, 1e7], got {cma_evals!r}")
    if not (isinstance(max_nfev, int) and 1 <= max_nfev <= 10**5):
        raise ValueError(f"max_nfev must be an integer in [1, 1e5], got {max_nfev!r}")
    if not (isinstance(identify_fraction, int | float) and 0.0 < identify_fraction <= 1.0):
        raise ValueError(f"identify_fraction must be in (0, 1], got {identify_fraction!r}")
    if loss not in ("linear", "soft_l1", "huber", "cauchy", "arctan"):
        raise ValueError(f"loss must be one of linear, soft_l1, huber, cauchy, arctan; got {loss!r}")


def fit(
    experiments: Experiment | SpatialExperiment | Sequence[Experiment | SpatialExperiment],
    parameters="thermal",
    start: ModelParams | SpineLayout | None = None,
    *,
    seed: int = 0,
    n_starts: int = 2,
    global_stage: bool = True,
    cma_evals: int | None = None,
    cma_sigma: float = 0.25,
    max_nfev: int = 30,
    loss: str = "linear",
    fd_step: float = 0.02,
    identify_fraction: float = 0.05,
    n_workers: int | None = None,
    solver: SolverOptions | None = None,
    progress: bool = True,
    start_name: str = "custom",
) -> FitResult:
    """Fit the chosen parameters of ``start`` to the experiments.

    Args:
        experiments: one or more :class:`~spine_gym.calibrate.data.Experiment`, or (spatial
            spine) :class:`~spine_gym.calibrate.spatial_data.SpatialExperiment`.
        parameters: ``"thermal"``, ``"mechanical"``, ``"all"``, ``"wires"`` (spatial), a list of
            names or a mapping {name: (lower, upper)} (see
            :func:`~spine_gym.calibrate.parameters.resolve_parameters`).
        start: the preset to start from and to keep for every field not fitted (default baseline);
            a :class:`~spine_gym.SpineLayout` (its params and per-wire values) for spatial
            experiments.
        seed: seeds CMA-ES and the random starts.
        n_starts: least-squares starts (the CMA-ES optimum, the start preset, random points).
        global_stage: run CMA-ES first.
        cma_evals: CMA-ES budget in candidates (default 30 generations of its default population).
        cma_sigma: CMA-ES initial step in unit-box coordinates.
        max_nfev: residual evaluations per least-squares start.
        loss: ``least_squares`` loss (``"soft_l1"`` for outliers); the uncertainties assume linear.
        fd_step: finite-difference step in unit-box coordinates.
        identify_fraction: a standard error above this fraction of the bound width is "not identified".
        n_workers: threads simulating candidates (default: all cores); 1 runs serially.
        solver: numerical options of the simulations.
        progress: show a progress bar.
        start_name: how the provenance names the start preset.

    Returns:
        A :class:`~spine_gym.calibrate.result.FitResult`.

    Long for its 18 options (signature, docstring and the settings it records); the stages run in
    one ``try`` so that an interrupt (Ctrl-C) in any of them still returns the best point seen.
    """
    single = isinstance(experiments, Experiment | SpatialExperiment)
    experiments = (experiments,) if single else tuple(experiments)
    if start is None:
        start = (
            SpineLayout.seed()
            if experiments and isinstance(experiments[0], SpatialExperiment)
            else ModelParams()
        )
    if not isinstance(start, ModelParams | SpineLayout):
        raise ValueError(f"start must be a ModelParams or a SpineLayout, got {type(start).__name__}")
    _check_options(seed, n_starts, cma_evals, cma_sigma, max_nfev, fd_step, identify_fraction, loss)
    params: tuple[FitParameter, ...] = resolve_parameters(parameters, start)
    bar = tqdm(desc="calibrate", unit="sim", disable=not progress, leave=False)
    ev = Evaluator(experiments, params, start, solver, n_workers, on_simulation=lambda k: bar.update(1))
    t0 = time.perf_counter()
    stages: list[_Stage] = []
    interrupted = False
    u0 = ev.to_unit(ev.start_values)
    try:
        global_best = None
        if global_stage:
            pop = 4 + int(3 * math.log(len(params)))
            evals = cma_evals if cma_evals is not None else CMA_GENERATIONS * pop
            bar.set_postfix_str("CMA-ES")
            stages.append(_global_stage(ev, u0, evals, seed, cma_sigma))
            global_best = stages[-1].end
        rng = np.random.default_rng(seed)
        for i, u in enumerate(_starts(ev, u0, n_starts, global_best, rng)):
            bar.set_postfix_str(f"least squares {i + 1}/{n_starts}")
            stages.append(_local_stage(ev, u, max_nfev, loss, fd_step))
        bar.set_postfix_str("uncertainty")
        u_best = ev.best_u  # the lowest cost evaluated (a stage's end or a Jacobian point)
        r = ev.residuals(u_best)
        jac, snr, steps = _robust_jacobian(ev, u_best, fd_step)
    except KeyboardInterrupt:
        if not np.isfinite(ev.best_cost):
            raise  # nothing evaluated yet: nothing to return
        interrupted = True
        u_best = ev.best_u
        r = ev.residuals(u_best)
        jac = snr = steps = None
    finally:
        bar.close()
        ev.close()
    return _result(
        ev,
        params,
        start,
        start_name,
        u_best,
        r,
        jac,
        snr,
        steps,
        stages,
        interrupted,
        identify_fraction,
        time.perf_counter() - t0,
        seed,
        dict(
            n_starts=n_starts,
            global_stage=global_stage,
            cma_evals=cma_evals,
            cma_sigma=cma_sigma,
            max_nfev=max_nfev,
            loss=loss,
            fd_step=fd_step,
            identify_fraction=identify_fraction,
            n_workers=ev.n_workers,
        ),
    )


def _result(
    ev, params, start, start_name, u, r, jac, snr, steps, stages, interrupted, fraction, wall, seed, settings
):
    n = len(params)
    values = ev.to_values(u)
    width = ev.upper - ev.lower
    warnings = []
    if jac is not None:
        cov_u, unseen = _covariance(jac, r)
        cov = cov_u * np.outer(width, width)
        se = np.sqrt(np.diag(cov))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(se, se)
        corr[~np.isfinite(corr)] = 0.0
        np.fill_diagonal(corr, 1.0)
        identified, warnings = _identifiability(
            params, u, se, unseen | (snr < MIN_SIGNAL), snr, steps, fraction
        )
        warnings += _correlation_notes(params, corr, identified)
    else:
        cov = corr = se = snr = None
        identified = np.zeros(n, dtype=bool)
        warnings.append(
            "the fit was interrupted: parameters are the best point seen, uncertainties not computed"
        )
    if ev.n_failed:
        warnings.append(f"{ev.n_failed} of {ev.n_simulations} candidate simulations failed (penalised)")
    return FitResult(
        parameters=params,
        start=start,
        start_name=start_name,
        params=ev.params_at(u),
        values=values,
        start_values=ev.start_values.copy(),
        std_errors=se,
        covariance=cov,
        correlation=corr,
        signal_to_roughness=snr,
        identified=identified,
        warnings=warnings,
        experiments=ev.experiments,
        residuals=r,
        cost=0.5 * float(r @ r),
        n_simulations=ev.n_simulations,
        wall_time=wall,
        seed=seed,
        interrupted=interrupted,
        stages=[
            dict(
                kind=s.kind,
                cost=s.cost,
                n_simulations=s.n_simulations,
                start=parameter_rows(params, ev.to_values(s.start)),
                end=parameter_rows(params, ev.to_values(s.end)),
                **s.info,
            )
            for s in stages
        ],
        settings=settings,
    )
