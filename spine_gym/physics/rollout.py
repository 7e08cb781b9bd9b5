"""The MPC's batched rollouts under their former module name, kept for one release.

Each core holds its own: :mod:`.planar.rollout` and :mod:`.spatial.rollout` (``rollout_many`` and
``rollout_many_serial`` in each). The former ``rollout_many_spatial`` and
``rollout_many_spatial_serial`` are the spatial core's ``rollout_many`` and
``rollout_many_serial``. This module only re-exports names.
"""

from __future__ import annotations

from .planar.rollout import rollout_many, rollout_many_serial
from .spatial.rollout import rollout_many as rollout_many_spatial
from .spatial.rollout import rollout_many_serial as rollout_many_spatial_serial

__all__ = ["rollout_many", "rollout_many_serial", "rollout_many_spatial", "rollout_many_spatial_serial"]
