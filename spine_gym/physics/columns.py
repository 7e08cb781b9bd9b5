"""Index constants of the flat float64 arrays both cores take (MODEL.md §6.4), and their status codes.

Column indices, not geometry (the spine's geometry is :mod:`spine_gym.layout`). Two arrays
travel between Python and the jitted kernels of either core:

* ``kp``  — physical constants (primary and derived), built by :meth:`spine_gym.params.ModelParams.to_kernel`.
* ``ks``  — solver options, built by :meth:`spine_gym.params.SolverOptions.to_kernel`.

The state of one spine is each core's own: :mod:`.planar.columns` (X_*) and
:mod:`.spatial.columns` (with the spatial core's wire and module tables). Flat arrays (rather than
structs) make a batch of spines a 2-D array, one row per environment, which is what the vector
environment and the design sweeps need.
"""

from __future__ import annotations

# ---------------------------------------------------------------- kp: physical constants
(
    K_EA,  # [Pa] austenite modulus
    K_EM,  # [Pa] martensite modulus
    K_EPST,  # [-] transformation strain eps_T
    K_DSIG,  # [Pa] gap between the instability stresses, Δσ
    K_KE,  # [1/Pa] k_E = 1/E_M - 1/E_A
    K_DETA,  # [J/(m^3 K)] entropy jump Δη
    K_DU,  # [J/m^3] internal-energy jump Δu
    K_VLKB,  # [K m^3/J] V_L / k_B   (λ = V_L/(k_B T))
    K_INVTAU,  # [1/s] 1/τ
    K_RHOC,  # [J/(m^3 K)] ρ c
    K_LAMA,  # [Ω m] resistivity of austenite
    K_LAMP,  # [Ω m] resistivity of M+
    K_LAMM,  # [Ω m] resistivity of M-
    K_ASV,  # [W/(m^3 K)] α S_V, S_V = 4/d
    K_TE,  # [K] ambient temperature
    K_L0,  # [m] wire length in the straight spine
    K_LREF,  # [m] stress-free wire length L0/(1+eps0)
    K_EPS0,  # [-] pre-strain
    K_AW,  # [m^2] cross-section of one wire
    K_NW,  # [-] wires per side (float)
    K_A,  # [m] wire offset a
    K_LS,  # [m] segment arc length
    K_EI,  # [N m^2] tube bending stiffness E_t I
    K_MSEG,  # [kg] mass per segment
    K_MTOP,  # [kg] top-disk mass
    K_G,  # [m/s^2] gravity
    K_NSEG,  # [-] segment count N (float)
    K_TMAX,  # [K] temperature above which the kernel declares a failure (sanity bound)
    KP_SIZE,
) = range(29)

# ---------------------------------------------------------------- ks: solver options
(
    S_C,  # [-] adaptive criterion c: r·h <= c (MODEL.md §6.1 b)
    S_HMIN,  # [s] smallest adaptive sub-step
    S_HMAX,  # [s] largest sub-step (inf: the output step, or the span of held ones with S_DENSE)
    S_TOLM,  # [N m] moment tolerance of the composite solve
    S_TOLTH,  # [rad] shape-iteration tolerance (max |ΔΔθ_n|)
    S_MAXSHAPE,  # [-] cap on shape passes per shape solve
    S_MAXROOT,  # [-] cap on outer iterations of the composite solve
    S_METHOD,  # [-] 0 bisection (seed), 1 Illinois (bracketed), 2 coupled Newton (default)
    S_MAXSUB,  # [-] cap on sub-steps per output step
    S_SCHEME,  # [-] time step: 0 frozen rates with r·h <= c (MODEL.md §6.1), 1 coupled (default)
    S_TOLX,  # [-] local error tolerance of the coupled step on the phase fractions
    S_DENSE,  # [s] longest sub-step across output points with held inputs (dense output); 0: off
    KS_SIZE,
) = range(13)

METHOD_BISECT = 0
METHOD_ILLINOIS = 1
METHOD_NEWTON = 2
METHODS = {"bisect": METHOD_BISECT, "illinois": METHOD_ILLINOIS, "newton": METHOD_NEWTON}

SCHEME_FROZEN = 0
SCHEME_COUPLED = 1
SCHEMES = {"frozen": SCHEME_FROZEN, "coupled": SCHEME_COUPLED}

# kp entries the rates depend on (§3.1–3.4): part of the rate caches' keys (planar X_RCACHE, the
# spatial state's tail), so that a state advanced with other constants (the MPC's nominal model on a
# copy of a randomised plant's state) recomputes them
RATE_KP = (K_EA, K_EM, K_EPST, K_DSIG, K_KE, K_DETA, K_DU, K_VLKB, K_INVTAU)

# ---------------------------------------------------------------- status codes
OK = 0
ERR_SHAPE = 1  # shape iteration did not converge (and the starting shape is stable: a solver limit)
ERR_ROOT = 2  # composite solve did not converge
ERR_NONFINITE = 3  # a non-finite number appeared
ERR_SUBSTEPS = 4  # more sub-steps than allowed in one output step
ERR_TEMPERATURE = 5  # wire temperature outside the model's range
ERR_BUCKLING = 6  # the equilibrium is unstable: a load past buckling (physics.stability), or, in the spatial
# core, the equilibrium path ends at a wire's slack kink past which the spine is unstable (SPATIAL.md §8.11)

STATUS_TEXT = {
    OK: "ok",
    ERR_SHAPE: "shape iteration did not converge (iteration cap too small, or the bracketed solvers' "
    "tube-only shape iteration is past the bare tube's buckling load: use method='newton')",
    ERR_ROOT: "composite constitutive/bending solve did not converge",
    ERR_NONFINITE: "a non-finite value appeared in the model state",
    ERR_SUBSTEPS: "more adaptive sub-steps than allowed in one output step",
    ERR_TEMPERATURE: "a wire temperature left the model's valid range",
    ERR_BUCKLING: "load beyond buckling: the spine's equilibrium under these loads is unstable",
}
