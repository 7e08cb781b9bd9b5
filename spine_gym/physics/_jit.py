"""The one place where numba options live: every kernel takes its flags from here, so a change of
flags reaches all kernels at once and no two kernels are compiled with different options by accident.

Every kernel is compiled with ``cache=True`` so that the compiled machine code is written next to
the source (``__pycache__``) and later processes load it instead of compiling again. No
``fastmath``: the exponent clamp of MODEL.md §6.3.1 and the bracket logic rely on IEEE semantics.
"""

from __future__ import annotations

import numba

__all__ = ["hot", "jit", "jit_inline", "pjit"]

def jit(func):
    """Serial kernel: ``@njit(cache=True, nogil=True)``."""
    return numba.njit(cache=True, nogil=True)(func)


def jit_inline(func):
    """Small serial helper inlined into its jitted callers at numba IR level (``inline="always"``):
    for helpers that take tuples of arrays and do little work per call (the env's bookkeeping,
    ``envs/readout.py``), where a real call (its arguments' reference counts) costs more than
    the work. Same numerics as :func:`jit` (no ``fastmath``)."""
    return numba.njit(cache=True, nogil=True, inline="always")(func)


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


def hot(func):
    """Serial kernel without reference counting: ``@njit(cache=True, nogil=True, _nrt=False)``.

    For the sub-step kernels of both cores and everything they call (the MAS rates, the shape
    pass, the composite solve and its fallbacks, the coupled step, the records). numba counts the
    references of every array argument, tuple member and view with atomic increments and
    decrements; in the spatial 20-s run those were ~30 % of the run's time, and in the planar env
    step (random drives, 8 envs) the planar kernels without them take 0.55-0.65x the time. Without
    NRT a kernel may not allocate (compile error, also in whatever it calls: numba compiles the
    callees for its flags) and must not return an array or call a kernel that returns one (views,
    wire_block: that reference would never be released). Its arrays are borrowed from the caller,
    which keeps them alive; so a ``jit`` wrapper allocates the scratch (``planar.composite.composite``,
    ``planar.integrate._advance``, ``planar.tube.solve_shape``) and hands it to the ``hot`` kernel (``*_in``,
    ``planar.integrate._span``). Arithmetic and results are unchanged (bit for bit).
    """
    return numba.njit(cache=True, nogil=True, _nrt=False)(func)
