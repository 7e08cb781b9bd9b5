"""Scratch arrays of one planar spine's time step: the coupled sub-step's fields (CW_*), views of one
flat buffer that :func:`.integrate.advance` allocates once per call (:func:`coupled_work`).
"""

from __future__ import annotations

import numpy as np

from .._jit import jit
from .columns import X_RCACHE


# the coupled sub-step's scratch arrays: a tuple indexed by these (compile-time) constants
CW_X0, CW_XS, CW_RT, CW_RT_NEW, CW_SENS, CW_A_T, CW_B_T, CW_PIV, CW_LU, CW_VEC, CW_BACKUP = range(11)


COUPLED_WORK_SIZE = 4 + 4 + 24 + 24 + 8 + 2 + 4 + 4 + 16 + 4 + X_RCACHE  # floats of the CW_* scratch


@jit
def coupled_work(buf):
    """Scratch arrays of the coupled sub-step (the CW_* fields) as views of one flat ``buf``:
    fractions at the start and end (4), rates and slopes at the start and end (2, 12), dσ/dx (2, 4),
    the temperature terms a_t (2) and b_t (2, 2), the row exchanges (4, int64 over 4 floats) and LU
    factors (4, 4) of the step matrix, a vector (4), the state's head before the step (X_RCACHE)."""
    v = buf[:COUPLED_WORK_SIZE]
    return (
        v[0:4],
        v[4:8],
        v[8:32].reshape((2, 12)),
        v[32:56].reshape((2, 12)),
        v[56:64].reshape((2, 4)),
        v[64:66],
        v[66:70].reshape((2, 2)),
        v[70:74].view(np.int64),
        v[74:90].reshape((4, 4)),
        v[90:94],
        v[94:COUPLED_WORK_SIZE],
    )
