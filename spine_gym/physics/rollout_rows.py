"""What an open-loop rollout of either core records after a control step (the MPC's predictors,
:mod:`.planar.rollout`, :mod:`.spatial.rollout`): its state's row while it runs, and after a failed
step the last valid row, so that the caller can score and reject it.
"""

from __future__ import annotations

from ._jit import jit
from .columns import OK

__all__ = ["HOLD", "RECORD", "START", "record_source"]

RECORD, START, HOLD = 0, 1, 2  # what a rollout records after a control step (record_source)


@jit
def record_source(status, h):
    """What a rollout records after control step ``h``: RECORD its state (status OK), START its
    start state (it failed in the first step), HOLD its last valid row (it failed earlier)."""
    if status == OK:
        return RECORD
    return START if h == 0 else HOLD
