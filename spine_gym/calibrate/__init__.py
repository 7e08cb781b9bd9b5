"""Calibrate the model to a user's own spine: fit ModelParams to measured traces, with uncertainties.

* :class:`Experiment` — one measured run (CSV or arrays; validated, :mod:`.data`).
* :class:`SpatialExperiment` — one run of a spatial spine: a voltage per wire, the tip bending
  vector or tip position, any per-wire temperatures/resistances (:mod:`.spatial_data`); fitted
  from a :class:`~spine_gym.SpineLayout` start, with per-wire parameters ``wire<j>.<value>``.
* :func:`fit` — CMA-ES global stage + bounded least squares from several starts, candidates
  simulated in parallel, standard errors, correlations and identifiability warnings (:mod:`.fit`).
* :class:`FitResult` — report, PNG plots, ``to_file`` (a ``ModelParams`` preset with the fit's
  provenance, usable as ``domain_randomization="fit.json"``) (:mod:`.result`).
* :func:`synthetic_experiment`, :func:`synthetic_spatial_experiment` — "measured" traces from a
  known parameter set (layout) plus noise.

Command line: ``python -m spine_gym.calibrate --help``. Worked example: ``docs/calibration.md``.
Needs the ``calibrate`` extra (scipy, cma).
"""

from .data import CHANNELS, DEFAULT_NOISE, Experiment
from .fit import fit
from .model import simulate_experiment, synthetic_experiment, synthetic_spatial_experiment
from .parameters import PARAMETER_SETS, FitParameter
from .result import FitResult
from .spatial_data import SPATIAL_DEFAULT_NOISE, SpatialExperiment

__all__ = [
    "CHANNELS",
    "DEFAULT_NOISE",
    "Experiment",
    "FitParameter",
    "FitResult",
    "PARAMETER_SETS",
    "SPATIAL_DEFAULT_NOISE",
    "SpatialExperiment",
    "fit",
    "simulate_experiment",
    "synthetic_experiment",
    "synthetic_spatial_experiment",
]
