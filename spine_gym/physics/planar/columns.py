"""Columns of the planar core's state vector (MODEL.md §6.4): one spine, two wires (right, left).

``state`` is the full model state of one planar spine (dynamic states, last mechanical solution,
Newton sensitivity and energy accumulators) as one flat float64 array; its length depends on the
segment count N (:func:`state_size`). The constants ``kp``, the solver options ``ks`` and the
status codes both cores share are in :mod:`spine_gym.physics.columns`; the spatial core's
columns are :mod:`spine_gym.physics.spatial.columns`.
"""

from __future__ import annotations

from ..columns import RATE_KP

# ---------------------------------------------------------------- state vector
(
    X_PR,  # x+ right wire
    X_MR,  # x- right wire
    X_PL,  # x+ left wire
    X_ML,  # x- left wire
    X_TR,  # [K] temperature right
    X_TL,  # [K] temperature left
    X_MW,  # [N m] wire moment of the last mechanical solution
    X_SR,  # [Pa] stress right
    X_SL,  # [Pa] stress left
    X_ER,  # [-] strain right
    X_EL,  # [-] strain left
    X_TIME,  # [s] model time
    X_QJR,  # [J/m^3] accumulated Joule heat, right wire (per unit volume)
    X_QJL,  # [J/m^3] accumulated Joule heat, left wire
    X_QCR,  # [J/m^3] accumulated convective loss, right
    X_QCL,  # [J/m^3] accumulated convective loss, left
    X_QLR,  # [J/m^3] accumulated latent heat released into the wire, right
    X_QLL,  # [J/m^3] accumulated latent heat released into the wire, left
    X_HNEXT,  # [s] sub-step the coupled scheme's error control proposes next (0: none yet)
    X_RCACHE,  # start of RCACHE_SIZE floats: (σ_R, T_R, σ_L, T_L) and the rates and slopes there
) = range(20)
RCACHE_SIZE = 4 + len(RATE_KP) + 24  # the coupled scheme's rates at the end of its last sub-step, keyed by
# (σ_R, T_R, σ_L, T_L) and the 9 constants they depend on (RATE_KP)
X_HEAD = X_RCACHE + RCACHE_SIZE  # size of the fixed part; then Δθ[N], then the sensitivity s = dΔθ/dM [N]


def state_size(n_seg: int) -> int:
    """Length of the state vector for ``n_seg`` segments."""
    return X_HEAD + 2 * n_seg
