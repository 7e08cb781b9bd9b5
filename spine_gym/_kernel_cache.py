"""Stale numba caches: clear every cached kernel when any kernel source changed.

numba re-validates a cached kernel (``cache=True``, files ``*.nbi``/``*.nbc`` in ``__pycache__``)
only against its *own* source file, not against the callees it compiled in from other modules: after
an edit of ``physics/planar/integrate.py`` the kernels of ``physics/planar/control.py`` would keep
running the old ``advance``. A digest of all kernel sources, stored beside the cache, catches that. It runs when
``spine_gym`` is imported, before any kernel is loaded (numba loads a cache at a kernel's first call).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numba

__all__ = ["KERNEL_CACHE_DIRS", "KERNEL_SOURCES", "STAMP_NAME", "clear_stale_caches"]

_PACKAGE = Path(__file__).resolve().parent
# every file that defines kernels: the cache must go when any of them changes
KERNEL_SOURCES = (*sorted((_PACKAGE / "physics").rglob("*.py")), _PACKAGE / "envs" / "readout.py")
# the stamp lives in the first; physics/planar and physics/spatial hold the cores' kernels
KERNEL_CACHE_DIRS = (
    *(_PACKAGE / "physics" / d / "__pycache__" for d in (".", "planar", "spatial")),
    _PACKAGE / "envs" / "__pycache__",
)
STAMP_NAME = "spine_gym_sources.sha256"


def clear_stale_caches(sources, cache_dirs) -> bool:
    """Delete the cached kernels in ``cache_dirs`` if ``sources`` changed since the last call.

    Returns True if caches were cleared. A read-only install keeps its caches (returns False).
    """
    digest = hashlib.sha256(b"".join(Path(f).read_bytes() for f in sources)).hexdigest()
    dirs = [Path(d) for d in cache_dirs]
    stamp = dirs[0] / STAMP_NAME
    if stamp.is_file() and stamp.read_text() == digest:
        return False
    try:
        for d in dirs:
            for f in (*d.glob("*.nbi"), *d.glob("*.nbc")):
                f.unlink(missing_ok=True)
        dirs[0].mkdir(parents=True, exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        return False
    return True


def clear_package_caches() -> bool:
    """:func:`clear_stale_caches` on spine_gym's own kernels; a user-set NUMBA_CACHE_DIR is left alone."""
    if numba.config.CACHE_DIR:
        return False
    return clear_stale_caches(KERNEL_SOURCES, KERNEL_CACHE_DIRS)


clear_package_caches()  # at import of spine_gym (its first import), before any kernel is loaded
