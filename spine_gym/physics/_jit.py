"""The one place where numba options live (STYLE.md: "keep numba options in one place").

Every kernel is compiled with ``cache=True`` so that the compiled machine code is written next to
the source (``__pycache__``) and later processes load it instead of compiling again. No
``fastmath``: the exponent clamp of MODEL.md §6.3.1 and the bracket logic rely on IEEE semantics.
"""

from __future__ import annotations

import numba

__all__ = ["jit", "pjit"]


def jit(func):
    """Serial kernel: ``@njit(cache=True, nogil=True)``."""
    return numba.njit(cache=True, nogil=True)(func)


def pjit(func):
    """Parallel kernel (``prange`` loops run across cores): ``@njit(cache=True, parallel=True)``."""
    return numba.njit(cache=True, nogil=True, parallel=True)(func)
