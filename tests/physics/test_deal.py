"""Rows dealt out one at a time to the threads of a prange loop (spine_gym.physics._deal).

Every row is taken exactly once whatever the number of rows and threads; the serial twin of a
kernel takes them in order; and with one slow row the other thread takes the rest, which fixed
blocks of rows (numba's own prange schedule) would not allow.
"""

import numba
import numpy as np
import pytest

from spine_gym.physics._deal import counter, take


def _dealt(hits, order, tid, spin):
    """Each taken row j: hits[j] += 1, order[k] = j for the k-th row this kernel took, tid[j] the
    numba thread that took it; row j first spins spin[j] iterations."""
    todo = counter()
    seq = counter()
    n = hits.shape[0]
    for _slot in numba.prange(n):
        j = take(todo, n)
        while j >= 0:
            s = 0.0
            for q in range(spin[j]):
                s += np.sqrt(q + 1.0)
            hits[j] += 1 if s >= 0.0 else 2
            order[take(seq, n)] = j
            tid[j] = numba.get_thread_id()
            j = take(todo, n)


parallel = numba.njit(parallel=True)(_dealt)
serial = numba.njit(_dealt)
THREADS = min(2, numba.config.NUMBA_NUM_THREADS)


def _run(kernel, n, spin=None):
    hits = np.zeros(n, dtype=np.int64)
    order = np.full(n, -1, dtype=np.int64)
    tid = np.full(n, -1, dtype=np.int64)
    kernel(hits, order, tid, np.zeros(n, dtype=np.int64) if spin is None else spin)
    return hits, order, tid


@pytest.mark.parametrize("n", [0, 1, 2, 7, 64, 1000])
def test_every_row_is_taken_exactly_once(n):
    numba.set_num_threads(THREADS)
    hits, order, _ = _run(parallel, n)
    assert np.all(hits == 1)
    assert np.array_equal(np.sort(order), np.arange(n))


def test_the_serial_twin_takes_the_rows_in_order():
    hits, order, tid = _run(serial, 50)
    assert np.all(hits == 1) and np.array_equal(order, np.arange(50))


def test_take_reports_exhaustion_without_moving_the_counter():
    c = counter()
    assert [take(c, 3) for _ in range(5)] == [0, 1, 2, -1, -1]
    assert c[0] == 3  # the calls after the last row only read the counter


@pytest.mark.skipif(THREADS < 2, reason="needs two numba threads")
def test_a_slow_row_does_not_hold_back_the_rows_after_it():
    """Row 0 takes ~10^7 iterations, the 63 others none: with fixed blocks the thread of row 0
    would also run rows 1..31; dealt out, the other thread runs (nearly) all of them."""
    numba.set_num_threads(2)
    n = 64
    spin = np.zeros(n, dtype=np.int64)
    spin[0] = 20_000_000
    _run(parallel, n)  # compile first
    hits, _, tid = _run(parallel, n, spin)
    assert np.all(hits == 1)
    slow = tid[0]
    assert np.count_nonzero(tid == slow) < n // 4
