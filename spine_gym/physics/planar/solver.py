"""The planar core's solve and time step under their former module name, kept for one release.

The module was split by role: the wire mechanics of a shape are :mod:`.mechanics`, the composite
solve :mod:`.composite`, the sub-steps :mod:`.substep`, their scratch :mod:`.work` and the time
integration (``advance``, ``advance_held``, ``init_state``) :mod:`.integrate`. Import from those;
this module only hands out their public names (and the state columns of :mod:`.columns`).
"""

from __future__ import annotations

from . import columns as _columns
from . import composite as _composite
from . import integrate as _integrate
from . import mechanics as _mechanics
from . import substep as _substep
from . import work as _work

_HOMES = (_integrate, _composite, _mechanics, _substep, _work, _columns)


def __getattr__(name: str):
    """A public name of the modules that replaced this one."""
    for home in _HOMES:
        if not name.startswith("_") and hasattr(home, name):
            return getattr(home, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
