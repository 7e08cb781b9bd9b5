"""The spatial core's solve, time step, record and time loop under their former module name, kept
for one release.

The module was split by role, with the planar core's module names: state views and work arrays
:mod:`.work`, the wire mechanics of a shape :mod:`.mechanics`, the composite solve
:mod:`.composite`, the sub-steps :mod:`.substep`, the time integration :mod:`.integrate`, the
record row :mod:`.record` and the recorded time loop :mod:`.run`. Import from those; this module
only hands out their public names (and the state columns of :mod:`.columns`).
"""

from __future__ import annotations

from . import columns as _columns
from . import composite as _composite
from . import integrate as _integrate
from . import mechanics as _mechanics
from . import record as _record
from . import run as _run
from . import substep as _substep
from . import work as _work

_HOMES = (_run, _record, _integrate, _composite, _mechanics, _substep, _work, _columns)


def __getattr__(name: str):
    """A public name of the modules that replaced this one."""
    for home in _HOMES:
        if not name.startswith("_") and hasattr(home, name):
            return getattr(home, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
