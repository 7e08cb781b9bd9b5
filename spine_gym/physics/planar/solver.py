"""The planar core's solve and time step under their former module name, kept for one release.

The module was split by role: the wire mechanics of a shape are :mod:`.mechanics`, the composite
solve :mod:`.composite`, the sub-steps :mod:`.substep`, their scratch :mod:`.work` and the time
integration (:func:`advance`, :func:`advance_held`, :func:`init_state`) :mod:`.integrate`. Import
from those; this module only re-exports their public names.
"""

from __future__ import annotations

from .composite import (
    NEWTON_HALVINGS,
    composite,
    composite_bracketed,
    composite_full_newton,
    composite_in,
    composite_newton,
)
from .integrate import advance, advance_held, init_state
from .mechanics import length_per_moment, mechanics_and_gain, moment_gain, stress_sensitivity, wire_mechanics
from .work import (
    COUPLED_WORK_SIZE,
    CW_A_T,
    CW_B_T,
    CW_BACKUP,
    CW_LU,
    CW_PIV,
    CW_RT,
    CW_RT_NEW,
    CW_SENS,
    CW_VEC,
    CW_X0,
    CW_XS,
    coupled_work,
)

__all__ = [
    "COUPLED_WORK_SIZE",
    "CW_A_T",
    "CW_BACKUP",
    "CW_B_T",
    "CW_LU",
    "CW_PIV",
    "CW_RT",
    "CW_RT_NEW",
    "CW_SENS",
    "CW_VEC",
    "CW_X0",
    "CW_XS",
    "NEWTON_HALVINGS",
    "advance",
    "advance_held",
    "composite",
    "composite_bracketed",
    "composite_full_newton",
    "composite_in",
    "composite_newton",
    "coupled_work",
    "init_state",
    "length_per_moment",
    "mechanics_and_gain",
    "moment_gain",
    "stress_sensitivity",
    "wire_mechanics",
]
