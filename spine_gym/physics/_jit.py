"""The one place where numba options live (STYLE.md: "keep numba options in one place").

Every kernel is compiled with ``cache=True`` so that the compiled machine code is written next to
the source (``__pycache__``) and later processes load it instead of compiling again. No
``fastmath``: the exponent clamp of MODEL.md §6.3.1 and the bracket logic rely on IEEE semantics.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numba

__all__ = ["jit", "pjit", "clear_stale_caches"]

_PACKAGE = Path(__file__).resolve().parent.parent
# every file that defines kernels: a kernel's cache must go when any of them changes
KERNEL_SOURCES = (*sorted((_PACKAGE / "physics").glob("*.py")), _PACKAGE / "envs" / "_bookkeeping.py")
STAMP_NAME = "spine_gym_sources.sha256"


def clear_stale_caches(sources, cache_dirs) -> bool:
    """Delete numba's cached kernels (``*.nbi``, ``*.nbc``) in ``cache_dirs`` if ``sources`` changed.

    numba re-validates a cached kernel only against its *own* file, not against the callees it
    inlined from other modules, so after an edit of ``solver.py`` the kernels of ``env_kernels.py``
    would keep running the old ``advance``. A digest of all kernel sources, stored beside the cache,
    catches that. Returns True if caches were cleared. A read-only install keeps its caches.
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


KERNEL_CACHE_DIRS = (_PACKAGE / "physics" / "__pycache__", _PACKAGE / "envs" / "__pycache__")

if not numba.config.CACHE_DIR:  # a user-chosen NUMBA_CACHE_DIR is the user's to manage
    clear_stale_caches(KERNEL_SOURCES, KERNEL_CACHE_DIRS)


def jit(func):
    """Serial kernel: ``@njit(cache=True, nogil=True)``."""
    return numba.njit(cache=True, nogil=True)(func)


def pjit(func):
    """Parallel kernel (``prange`` loops run across cores): ``@njit(cache=True, parallel=True)``.

    Compiled from a twin of ``func`` named ``<name>__parallel``: numba's on-disk cache is keyed by
    the function's name and signature, not by its flags, so ``jit(f)`` and ``pjit(f)`` of one ``f``
    would share one cache entry and the serial kernel would load the parallel machine code (and
    start OpenMP threads) or the other way round.
    """
    twin = type(func)(  # types.FunctionType: the same code under another name
        func.__code__, func.__globals__, f"{func.__name__}__parallel", func.__defaults__, func.__closure__
    )
    twin.__qualname__ = f"{func.__qualname__}__parallel"
    twin.__module__ = func.__module__
    twin.__doc__ = func.__doc__
    return numba.njit(cache=True, nogil=True, parallel=True)(twin)
