"""Model and solver parameters: frozen dataclasses in SI units, validated on construction.

Defaults are the baseline set of MODEL.md §7; :func:`alternative` gives the §7 alternative
calibration. Make variants with :func:`dataclasses.replace` (validation runs again), never by
mutation. The kernels take flat float64 arrays built by ``to_kernel()`` (layout in
:mod:`spine_gym.physics.columns`).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from .physics import columns as L

K_BOLTZMANN = 1.380649e-23  # [J/K]
PRESET_FORMAT = "spine_gym.ModelParams/1"  # tag of a preset file written by ModelParams.to_file

_INF = math.inf


def _check(name: str, value, lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False):
    """Raise ValueError naming the field, the allowed range and the received value."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    infinite_ok = v == _INF and hi == _INF and not hi_open
    bad = (
        (not math.isfinite(v) and not infinite_ok)
        or (v <= lo if lo_open else v < lo)
        or (v >= hi if hi_open else v > hi)
    )
    if bad:
        lb = "(" if lo_open else "["
        rb = ")" if hi_open else "]"
        raise ValueError(f"{name} must be in {lb}{lo:g}, {hi:g}{rb}, got {value!r}")


@dataclass(frozen=True)
class ModelParams:
    """Physical parameters of the SMA spine (MODEL.md §7 baseline). All SI units.

    Ranges in ``_RANGES`` are what the model is valid for; construction outside them raises
    ``ValueError`` naming the field.
    """

    # --- SMA material (MAS), MODEL.md §3, §7
    E_A: float = 70e9  # [Pa] austenite modulus [LIT L1]
    E_M: float = 25e9  # [Pa] martensite modulus [LIT L1, CAL]
    eps_T: float = 0.053  # [-] transformation strain [DER §3.10]
    dsigma: float = 150e6  # [Pa] gap σ_A − σ_M, Δσ [CAL]
    T_low: float = 333.0  # [K] lower calibration temperature T_L [CAL]
    sigma_A_low: float = 80e6  # [Pa] σ_A(T_L) [CAL]
    T_high: float = 423.0  # [K] upper calibration temperature T_H [CAL]
    sigma_A_high: float = 710e6  # [Pa] σ_A(T_H) [CAL]
    V_L: float = 5e-23  # [m^3] transforming layer volume (seed's V_D) [LIT L1]
    tau: float = 0.01  # [s] relaxation time τ [LIT L1]
    rho: float = 6450.0  # [kg/m^3] density [LIT L3]
    c: float = 837.0  # [J/(kg K)] specific heat [LIT L3]
    lam_A: float = 1.00e-6  # [Ω m] resistivity, austenite [LIT L3]
    lam_M: float = 0.80e-6  # [Ω m] resistivity, martensite M+ and M- [LIT L3]
    alpha: float = 40.0  # [W/(m^2 K)] convection coefficient [CAL]
    T_E: float = 293.0  # [K] ambient temperature [ASSUMED]
    d: float = 0.5e-3  # [m] wire diameter [SEED]
    L0: float = 0.46  # [m] wire length, straight spine [ASSUMED]
    eps0: float = 0.048  # [-] pre-strain [SEED]
    n_w: int = 1  # [-] wires per side [SEED]
    # --- spine, MODEL.md §4, §7
    n_seg: int = 13  # [-] segment count N [ASSUMED]
    ls: float = 0.035  # [m] segment length [SEED]
    a: float = 0.014  # [m] wire offset from the tube axis [SEED]
    D_o: float = 0.020  # [m] tube outer diameter [SEED]
    D_i: float = 0.008  # [m] tube inner diameter [SEED]
    E_t: float = 25e6  # [Pa] tube (effective bending) modulus [CAL]
    m_seg: float = 0.0145  # [kg] mass per segment (tube + ring share) [ASSUMED]
    m_top: float = 0.025  # [kg] top disk + bolts [ASSUMED]
    g: float = 9.81  # [m/s^2] gravity

    _RANGES = {
        "E_A": (1e9, 500e9),
        "E_M": (1e9, 500e9),
        "eps_T": (1e-3, 0.2),
        "dsigma": (1e6, 2e9),
        "T_low": (150.0, 800.0),
        "sigma_A_low": (-2e9, 3e9),
        "T_high": (150.0, 900.0),
        "sigma_A_high": (-2e9, 3e9),
        "V_L": (1e-26, 1e-19),
        "tau": (1e-5, 100.0),
        "rho": (100.0, 30000.0),
        "c": (10.0, 10000.0),
        "lam_A": (1e-9, 1e-3),
        "lam_M": (1e-9, 1e-3),
        "alpha": (0.0, 1e5),
        "T_E": (150.0, 600.0),
        "d": (1e-6, 0.01),
        "L0": (0.01, 10.0),
        "eps0": (0.0, 0.2),
        "n_w": (1, 100),
        "n_seg": (1, 1000),
        "ls": (1e-4, 1.0),
        "a": (1e-4, 0.5),
        "D_o": (1e-4, 1.0),
        "D_i": (0.0, 1.0),
        "E_t": (1e5, 1e12),
        "m_seg": (0.0, 100.0),
        "m_top": (0.0, 100.0),
        "g": (0.0, 100.0),
    }

    def __post_init__(self):
        for f in dataclasses.fields(self):
            lo, hi = self._RANGES[f.name]
            v = getattr(self, f.name)
            if f.name in ("n_w", "n_seg"):
                if isinstance(v, bool) or int(v) != v:
                    raise ValueError(f"{f.name} must be an integer in [{lo}, {hi}], got {v!r}")
                object.__setattr__(self, f.name, int(v))
            _check(f.name, v, lo, hi)
        if self.D_i >= self.D_o:
            raise ValueError(f"D_i must be < D_o = {self.D_o:g} m, got {self.D_i!r}")
        if self.E_M > self.E_A:  # keeps k_E >= 0, so σ_A(T) of §3.1 is a real root at every T
            raise ValueError(f"E_M must be <= E_A = {self.E_A:g} Pa, got {self.E_M!r}")
        if self.T_high <= self.T_low:
            raise ValueError(f"T_high must be > T_low = {self.T_low:g} K, got {self.T_high!r}")
        if self.eps_T <= self.dsigma / self.E_M:  # MODEL.md §3.1 requirement, §6.3.3
            raise ValueError(
                f"eps_T must be > dsigma/E_M = {self.dsigma / self.E_M:g} so that ε_M > ε_A, "
                f"got {self.eps_T!r}"
            )
        if self.n_seg * self.ls > self.L0:
            raise ValueError(
                f"L0 must be >= n_seg*ls = {self.n_seg * self.ls:g} m (the wire spans the bent "
                f"part), got {self.L0!r}"
            )
        if self.a <= 0.5 * self.D_i:
            raise ValueError(f"a must be > D_i/2 = {0.5 * self.D_i:g} m, got {self.a!r}")
        if self.delta_eta <= 0.0 or self.delta_u <= 0.0:
            raise ValueError(
                "sigma_A_high must exceed sigma_A_low enough that the entropy and internal-energy "
                f"jumps are positive (got Δη = {self.delta_eta:g}, Δu = {self.delta_u:g})"
            )

    # ---------------------------------------------------------------- derived (MODEL.md §3.1)
    @property
    def k_E(self) -> float:
        """k_E = 1/E_M − 1/E_A [1/Pa]."""
        return 1.0 / self.E_M - 1.0 / self.E_A

    def _beta_hat(self, s: float) -> float:
        return -0.5 * (self.eps_T * (2.0 * s - self.dsigma) + self.k_E * s * (s - self.dsigma))

    @property
    def delta_eta(self) -> float:
        """Entropy jump A − M, Δη [J/(m^3 K)]."""
        return (self._beta_hat(self.sigma_A_low) - self._beta_hat(self.sigma_A_high)) / (
            self.T_high - self.T_low
        )

    @property
    def delta_u(self) -> float:
        """Internal-energy jump A − M, Δu [J/m^3]."""
        return self._beta_hat(self.sigma_A_high) + self.T_high * self.delta_eta

    @property
    def wire_area(self) -> float:
        """Cross-section of one wire A_w = π d²/4 [m^2]."""
        return math.pi * self.d**2 / 4.0

    @property
    def wire_volume(self) -> float:
        """Volume of one wire A_w L0 [m^3]."""
        return self.wire_area * self.L0

    @property
    def L_ref(self) -> float:
        """Stress-free wire length L0/(1+ε0) [m]."""
        return self.L0 / (1.0 + self.eps0)

    @property
    def I_tube(self) -> float:
        """Second moment of area of the tube π(D_o⁴ − D_i⁴)/64 [m^4]."""
        return math.pi * (self.D_o**4 - self.D_i**4) / 64.0

    @property
    def x_plus0(self) -> float:
        """Initial M+ fraction ½(1 + ε0/ε_T) at zero stress (MODEL.md §3.10)."""
        return 0.5 * (1.0 + self.eps0 / self.eps_T)

    def to_kernel(self) -> np.ndarray:
        """The flat float64 constant array ``kp`` the kernels take."""
        kp = np.zeros(L.KP_SIZE)
        kp[L.K_EA] = self.E_A
        kp[L.K_EM] = self.E_M
        kp[L.K_EPST] = self.eps_T
        kp[L.K_DSIG] = self.dsigma
        kp[L.K_KE] = self.k_E
        kp[L.K_DETA] = self.delta_eta
        kp[L.K_DU] = self.delta_u
        kp[L.K_VLKB] = self.V_L / K_BOLTZMANN
        kp[L.K_INVTAU] = 1.0 / self.tau
        kp[L.K_RHOC] = self.rho * self.c
        kp[L.K_LAMA] = self.lam_A
        kp[L.K_LAMP] = self.lam_M
        kp[L.K_LAMM] = self.lam_M
        kp[L.K_ASV] = self.alpha * 4.0 / self.d
        kp[L.K_TE] = self.T_E
        kp[L.K_L0] = self.L0
        kp[L.K_LREF] = self.L_ref
        kp[L.K_EPS0] = self.eps0
        kp[L.K_AW] = self.wire_area
        kp[L.K_NW] = float(self.n_w)
        kp[L.K_A] = self.a
        kp[L.K_LS] = self.ls
        kp[L.K_EI] = self.E_t * self.I_tube
        kp[L.K_MSEG] = self.m_seg
        kp[L.K_MTOP] = self.m_top
        kp[L.K_G] = self.g
        kp[L.K_NSEG] = float(self.n_seg)
        kp[L.K_TMAX] = 2000.0
        return kp

    def replace(self, **changes) -> ModelParams:
        """A validated copy with ``changes`` applied (``dataclasses.replace``)."""
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise ValueError(f"unknown ModelParams field(s) {sorted(unknown)}; valid fields: {field_names()}")
        return dataclasses.replace(self, **changes)

    def to_file(self, path: str | Path, provenance: dict | None = None) -> Path:
        """Write the parameters as a preset file, JSON or YAML by the suffix of ``path``.

        The file holds ``format`` (:data:`PRESET_FORMAT`), ``params`` (every field, SI units) and
        ``provenance`` (free-form, e.g. the fit that produced the values; numpy values become
        plain numbers and lists). Read it back with :meth:`from_file` / :func:`load_preset`.
        """
        path = Path(path)
        kind = _preset_kind(path)
        doc = {
            "format": PRESET_FORMAT,
            "params": dataclasses.asdict(self),
            "provenance": _plain(provenance or {}),
        }
        path.parent.mkdir(parents=True, exist_ok=True)
        if kind == "json":
            path.write_text(json.dumps(doc, indent=2) + "\n")
        else:
            path.write_text(yaml.safe_dump(doc, sort_keys=False))
        return path

    @classmethod
    def from_file(cls, path: str | Path) -> ModelParams:
        """Read a preset written by :meth:`to_file` (fields it omits keep their defaults)."""
        return load_preset(path)[0]


def _preset_kind(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix == ".json":
        return "json"
    if suffix in (".yaml", ".yml"):
        return "yaml"
    raise ValueError(f"preset file must end in .json, .yaml or .yml, got {str(path)!r}")


def _plain(value):
    """``value`` with numpy scalars/arrays and tuples turned into plain Python numbers and lists."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def load_preset(path: str | Path) -> tuple[ModelParams, dict]:
    """(parameters, provenance) of a preset file; a malformed file raises ValueError naming it."""
    path = Path(path)
    kind = _preset_kind(path)
    text = path.read_text()
    try:
        doc = json.loads(text) if kind == "json" else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as e:
        raise ValueError(f"{path}: not a valid {kind.upper()} file: {e}") from None
    is_preset = isinstance(doc, dict) and doc.get("format") == PRESET_FORMAT
    if not is_preset or not isinstance(doc.get("params"), dict):
        raise ValueError(
            f"{path}: not a spine_gym preset (expected a mapping with format = {PRESET_FORMAT!r} and a "
            "'params' mapping)"
        )
    unknown = set(doc["params"]) - set(field_names())
    if unknown:
        raise ValueError(
            f"{path}: unknown ModelParams field(s) {sorted(unknown)}; valid fields: {field_names()}"
        )
    try:
        params = ModelParams(**doc["params"])
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None
    provenance = doc.get("provenance") or {}
    if not isinstance(provenance, dict):
        raise ValueError(f"{path}: 'provenance' must be a mapping, got {type(provenance).__name__}")
    return params, provenance


# fields that enter only the heat balance, the resistance and the transformation kinetics, not the
# initial state of MODEL.md §3.10 (straight spine, T = T_E, x_A = 0) nor whether it buckles
DYNAMICS_ONLY_FIELDS = frozenset({"tau", "rho", "c", "lam_A", "lam_M", "alpha"})


def field_names() -> list[str]:
    """Names of the ModelParams fields (the parameters a design study may vary)."""
    return [f.name for f in dataclasses.fields(ModelParams)]


def baseline() -> ModelParams:
    """MODEL.md §7 baseline set."""
    return ModelParams()


def alternative() -> ModelParams:
    """MODEL.md §7 alternative calibration: α = 60 W/(m²K), stress lines 20 K lower."""
    return ModelParams(alpha=60.0, sigma_A_low=220e6, sigma_A_high=850e6)


PRESETS = {"baseline": baseline, "alternative": alternative}


@dataclass(frozen=True)
class SolverOptions:
    """Numerical options of the time integration and the composite solve (MODEL.md §5–§6).

    Attributes:
        method: composite solver: ``"newton"`` (default; coupled safeguarded Newton on the wire
            moment with one shape pass per iteration, falling back to the bracketed Illinois
            solve), ``"illinois"`` (bracketed regula falsi with full shape solves) or ``"bisect"``
            (the seed's bisection, MODEL.md §5.2).
        scheme: time step of the phase kinetics. ``"coupled"`` (default): linearly implicit Euler
            of the coupled phase–stress–temperature system (the rates at the end-of-step stress
            and temperature, through the composite solve's sensitivity), sub-steps chosen by a
            local error estimate against ``tol_x``. ``"frozen"``: MODEL.md §6.1 as written,
            implicit Euler with the rates frozen at the start of the sub-step and the step-size
            rule rate × h <= ``step_c``. MODEL.md §6.5. The planar and the spatial core
            (SPATIAL.md §8.6) both read this one field.
        tol_x: local error tolerance of the coupled scheme on the phase fractions [-].
        dense_output: let the sub-steps run across output points over which the inputs
            (voltages, loads) are held, and report the outputs inside a sub-step from the state
            linearly interpolated between its ends (default; MODEL.md §6.5, ``physics.dense``).
            ``False``: every output step ends a sub-step, as before. Used by the time loops of
            ``simulate`` (planar and spatial); the env kernels and MPC rollouts advance one
            output step per call either way.
        dense_h_max: longest sub-step across output points [s] (never below the output step):
            the step-error control bounds the local error of the implicit Euler heat balance, not
            its growth over a long quiet heating or cooling, which shifts the onsets (§6.5).
        step_c: adaptive criterion c of §6.1 b (rate × sub-step <= c) of the frozen scheme.
            ``inf`` disables it.
        h_min: smallest adaptive sub-step [s].
        h_max: largest sub-step [s] (``inf``: no cap but the output step, or the span of held
            output steps with ``dense_output``). ``scheme="frozen", step_c=inf,
            h_max=1e-4`` is the fixed-step reference of §6.2 (:data:`FINE_REFERENCE`).
        tol_moment: composite-solve tolerance on the wire moment [N m].
        tol_theta: shape-iteration tolerance on max ``|ΔΔθ_n|`` [rad].
        max_shape_iter: cap on passes of one shape solve.
        max_root_iter: cap on outer iterations of the composite solve.
        max_substeps: cap on sub-steps per output step.
    """

    method: str = "newton"
    scheme: str = "coupled"
    tol_x: float = 1e-4
    dense_output: bool = True
    dense_h_max: float = 0.05
    step_c: float = 0.01
    h_min: float = 1e-5
    h_max: float = _INF
    tol_moment: float = 1e-8
    tol_theta: float = 1e-9
    max_shape_iter: int = 500
    max_root_iter: int = 200
    max_substeps: int = 100_000

    def __post_init__(self):
        if self.method not in L.METHODS:
            raise ValueError(f"method must be one of {sorted(L.METHODS)}, got {self.method!r}")
        if self.scheme not in L.SCHEMES:
            raise ValueError(f"scheme must be one of {sorted(L.SCHEMES)}, got {self.scheme!r}")
        _check("tol_x", self.tol_x, 0.0, 0.1, lo_open=True)
        if not isinstance(self.dense_output, bool):
            raise ValueError(f"dense_output must be True or False, got {self.dense_output!r}")
        _check("dense_h_max", self.dense_h_max, 0.0, _INF, lo_open=True)
        _check("step_c", self.step_c, 0.0, _INF, lo_open=True)
        _check("h_min", self.h_min, 0.0, 1.0, lo_open=True)
        _check("h_max", self.h_max, 0.0, _INF, lo_open=True)
        _check("tol_moment", self.tol_moment, 0.0, 1.0, lo_open=True)
        _check("tol_theta", self.tol_theta, 0.0, 0.1, lo_open=True)
        _check("max_shape_iter", self.max_shape_iter, 1, 1e7)
        _check("max_root_iter", self.max_root_iter, 1, 1e7)
        _check("max_substeps", self.max_substeps, 1, 1e9)

    def to_kernel(self) -> np.ndarray:
        """The flat float64 option array ``ks`` the kernels take."""
        ks = np.zeros(L.KS_SIZE)
        ks[L.S_C] = self.step_c
        ks[L.S_HMIN] = self.h_min
        ks[L.S_HMAX] = self.h_max
        ks[L.S_TOLM] = self.tol_moment
        ks[L.S_TOLTH] = self.tol_theta
        ks[L.S_MAXSHAPE] = self.max_shape_iter
        ks[L.S_MAXROOT] = self.max_root_iter
        ks[L.S_METHOD] = L.METHODS[self.method]
        ks[L.S_MAXSUB] = self.max_substeps
        ks[L.S_SCHEME] = L.SCHEMES[self.scheme]
        ks[L.S_TOLX] = self.tol_x
        ks[L.S_DENSE] = self.dense_h_max if self.dense_output else 0.0
        return ks

    def replace(self, **changes) -> SolverOptions:
        """A validated copy with ``changes`` applied."""
        return dataclasses.replace(self, **changes)


FINE_REFERENCE = SolverOptions(scheme="frozen", step_c=_INF, h_max=1e-4)
"""The fine-step reference of MODEL.md §6.2: frozen-rate implicit Euler at fixed 0.1-ms sub-steps."""
