"""The one place where numba options live (STYLE.md: "keep numba options in one place").

Every kernel is compiled with ``cache=True`` so that the compiled machine code is written next to
the source (``__pycache__``) and later processes load it instead of compiling again. No
``fastmath``: the exponent clamp of MODEL.md §6.3.1 and the bracket logic rely on IEEE semantics.
"""

from __future__ import annotations

import os

import numba

__all__ = ["hot", "jit", "jit_inline", "launch_threads", "pjit"]

# GNU OpenMP's wait policy for numba's worker threads (read once, when numba loads the runtime)
OMP_WAIT_POLICY = "PASSIVE"


def jit(func):
    """Serial kernel: ``@njit(cache=True, nogil=True)``."""
    return numba.njit(cache=True, nogil=True)(func)


def jit_inline(func):
    """Small serial helper inlined into its jitted callers at numba IR level (``inline="always"``):
    for helpers that take tuples of arrays and do little work per call (the env's bookkeeping,
    ``envs/_bookkeeping.py``), where a real call (its arguments' reference counts) costs more than
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


def launch_threads() -> str:
    """Start numba's thread pool (once per process) with idle workers that sleep; returns the layer.

    numba starts its pool at the first parallel call; with its OpenMP layer (GNU libgomp here) the
    idle workers then spin after every parallel loop until ``GOMP_SPINCOUNT`` runs out. Beside a
    CPU-bound process a spinning worker is just one more CPU-bound thread: the scheduler gives it
    its turn late, and every parallel step waits at the loop's join for it (the native vector env
    at 64 envs ran at 0.05-0.16x its serial kernel beside one busy process). Sleeping workers
    (``OMP_WAIT_POLICY=PASSIVE``) are woken at the next loop and, having slept, are scheduled at
    once. libgomp reads the variable only when it is loaded, so this sets it for that moment
    (restoring the environment after: nothing else in the process, e.g. torch's own OpenMP runtime,
    sees it), unless the user set ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` (theirs then holds). If
    the pool is already running, or numba picked another layer (``tbb``, ``workqueue``), this
    changes nothing. benchmarks/README.md (``bench_contention.py``) has the measurements.
    """
    if "OMP_WAIT_POLICY" in os.environ or "GOMP_SPINCOUNT" in os.environ:
        numba.get_num_threads()  # starts the pool
        return numba.threading_layer()
    os.environ["OMP_WAIT_POLICY"] = OMP_WAIT_POLICY
    try:
        numba.get_num_threads()  # starts the pool; libgomp reads its environment as it loads
    finally:
        del os.environ["OMP_WAIT_POLICY"]
    return numba.threading_layer()


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
    which keeps them alive; so a ``jit`` wrapper allocates the scratch (``solver.composite``,
    ``solver._advance``, ``tube.solve_shape``) and hands it to the ``hot`` kernel (``*_in``,
    ``solver._span``). Arithmetic and results are unchanged (bit for bit).
    """
    return numba.njit(cache=True, nogil=True, _nrt=False)(func)
