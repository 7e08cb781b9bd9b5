"""The planar core's recorded time loop under its former module name, kept for one release.

The loop of one spine is :mod:`.run` (:func:`~.run.run`, :func:`~.run.empty_record`), the record row
:mod:`.record`. Import from those; this module only re-exports their names.
"""

from __future__ import annotations

from .record import OUT_ANGLE, OUT_RES_L, OUT_RES_R, OUT_SIZE, OUT_TIP_X, OUT_TIP_Y, record
from .run import empty_record, run

__all__ = [
    "OUT_ANGLE",
    "OUT_RES_L",
    "OUT_RES_R",
    "OUT_SIZE",
    "OUT_TIP_X",
    "OUT_TIP_Y",
    "empty_record",
    "record",
    "run",
]
