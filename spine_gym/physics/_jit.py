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
    """Parallel kernel (``prange`` loops run across cores): ``@njit(cache=True, parallel=True)``.

    It compiles a copy of ``func`` named ``<name>_parallel``: numba names a cache file after the
    function and keys its index by signature and bytecode only, not by ``parallel``, so a
    ``jit(f)`` / ``pjit(f)`` twin pair would share one cache entry per signature and the one
    compiled last would be loaded for both (seen: the serial twin ran the threaded code, 20-40 ms
    instead of 0.1 ms per step of 16 envs on the loaded machine).
    """
    twin = type(func)(func.__code__, func.__globals__, func.__name__, func.__defaults__, func.__closure__)
    twin.__qualname__ = func.__qualname__ + "_parallel"
    twin.__doc__ = func.__doc__
    return numba.njit(cache=True, nogil=True, parallel=True)(twin)
