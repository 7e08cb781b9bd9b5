"""The record row of one planar spine: the state's head and the outputs derived from it (MODEL.md §6.1, 2.).

One row per output step: the state's head (``columns`` X_*), then the bending angle Θ, the wire
resistivities and the tip position in the OUT_* columns. :func:`.run.run` and the
:func:`.integrate.advance_held` dense output write it; the envs measure with it (:mod:`.control`).
"""

from __future__ import annotations

from .._jit import hot
from ..sma import resistivity
from .columns import X_HEAD, X_ML, X_MR, X_PL, X_PR
from .tube import tip_position

# columns written by ``record`` after the state's head
OUT_ANGLE, OUT_RES_R, OUT_RES_L, OUT_TIP_X, OUT_TIP_Y = range(X_HEAD, X_HEAD + 5)
OUT_SIZE = X_HEAD + 5


@hot
def record(state, kp, row):
    """Write the state's head, Θ [rad], the wire resistivities [Ω m] and the tip position [m]."""
    n = (state.shape[0] - X_HEAD) // 2
    for i in range(X_HEAD):
        row[i] = state[i]
    dth = state[X_HEAD : X_HEAD + n]
    theta = 0.0
    for i in range(n):
        theta += dth[i]
    row[OUT_ANGLE] = theta
    row[OUT_RES_R] = resistivity(state[X_PR], state[X_MR], kp)
    row[OUT_RES_L] = resistivity(state[X_PL], state[X_ML], kp)
    tx, ty = tip_position(dth, kp)
    row[OUT_TIP_X] = tx
    row[OUT_TIP_Y] = ty
