"""One control period of the envs' spines under its former module name, kept for one release.

Each core holds its own: :mod:`.planar.control` and :mod:`.spatial.control` (``step_spine`` and
``record_many`` in each). The former ``step_spine_spatial`` and ``record_many_spatial`` are the
spatial core's ``step_spine`` and ``record_many``. The batch loops ``step_many`` /
``step_many_spatial`` (and their ``*_serial`` twins), which no env calls, are in the repository's
``benchmarks/spine_loops.py``. This module only re-exports names.
"""

from __future__ import annotations

from .planar.control import record_many, step_spine
from .spatial.control import record_many as record_many_spatial
from .spatial.control import step_spine as step_spine_spatial

__all__ = ["record_many", "record_many_spatial", "step_spine", "step_spine_spatial"]
