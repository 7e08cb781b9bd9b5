"""Rows dealt out one at a time to the threads of a ``prange`` loop.

numba's ``prange`` splits its iterations into one contiguous block per thread, fixed before the
loop starts. The env kernels' rows are spines whose control periods differ in cost (in the random
drive regime of ``benchmarks/bench_training_share.py``: median ~11 µs, 90th percentile ~2×, 99th
~5×, the slowest ~10×), so with fixed blocks every parallel step waits for the thread that drew
the expensive rows. Here each iteration of the ``prange`` loop takes the next row from a shared
counter (:func:`take`, an atomic fetch-and-add) and keeps taking rows until they run out: the
first iteration of each thread's block does the work, a thread that finishes early takes more
rows, and the later iterations find none left (one plain read each). Each row is computed as before (rows
are independent), so the results do not depend on which thread took a row; the serial twin of a
kernel (``_jit.jit`` of the same body) runs its one worker over every row in order.

``numba.set_parallel_chunksize`` would do the same, but only from Python around every call (a few
µs of ctypes calls per step): a kernel that calls it, or ``numba.get_num_threads``, cannot be
cached (numba: "uses dynamic globals").
"""

from __future__ import annotations

import numpy as np
from numba.core import cgutils, types
from numba.extending import intrinsic

from ._jit import jit

__all__ = ["counter", "take"]


@intrinsic
def _fetch_add(typingctx, arr):
    """``arr[0] += 1`` as one atomic operation (sequentially consistent); returns the old value."""
    if not (isinstance(arr, types.Array) and arr.dtype == types.int64 and arr.ndim == 1):
        return None
    sig = types.int64(arr)

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        zero = context.get_constant(types.intp, 0)
        ptr = cgutils.get_item_pointer(context, builder, signature.args[0], ary, [zero])
        one = context.get_constant(types.int64, 1)
        return builder.atomic_rmw("add", ptr, one, "seq_cst")

    return sig, codegen


@jit
def counter():
    """A fresh shared row counter (one int64 at 0) for :func:`take`."""
    return np.zeros(1, dtype=np.int64)


@jit
def take(count, n):
    """The next row index in [0, n) from the shared ``count`` (:func:`counter`), or -1 when all are
    taken. Safe to call from every thread of a ``prange`` loop at once; once all are taken it only
    reads the counter (no atomic traffic between the threads)."""
    if count[0] >= n:
        return -1
    j = _fetch_add(count)
    return j if j < n else -1
