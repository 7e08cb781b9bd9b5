"""Online choice between a batch's serial and parallel step kernel, by their measured step times.

The two kernels of a vector env (:mod:`.step_kernels`, ``*_serial`` and ``prange``) give the same
results bit for bit, so which one runs a step changes nothing but its speed, and that depends on
what else the machine runs: on idle cores the parallel kernel on 2 threads runs ~1.8x the serial
one at 256 envs, beside one CPU-bound process it can drop far below it (each parallel step waits at
its join for the thread that shares a core with the other process). :class:`KernelChoice` keeps
whichever is faster now:

* it times every step of the kernel in use (seconds per env row stepped, so autoresets that step
  fewer rows do not count as fast steps) and keeps the last ``window`` of them; a parallel step in
  wall time, a serial step in the calling thread's CPU time (the serial kernel runs on that thread
  alone). Wall time would charge the serial kernel for OpenMP workers that still spin after a
  parallel step (libgomp's default: up to ``GOMP_SPINCOUNT`` rounds, milliseconds) and compete
  with the calling thread: every probe of the parallel kernel would make the serial one look slow
  for the next steps and could keep the choice on a parallel kernel 10x slower. Where the calling
  thread gets less than a core (two or more other busy processes on two cores) CPU time
  understates the serial step's wall time, which errs towards the serial kernel;
* every ``interval`` steps it probes the other kernel for up to ``probe`` steps and switches if the
  probe's median is below ``1 - margin`` times the current kernel's recent median; a probe whose
  steps are all slower than ``abort`` times that median ends at once (a probe of a kernel that is
  5x slower costs about one step);
* a probe that loses doubles ``interval`` (up to ``max_interval``), a switch sets it back to
  ``first_interval``; so on a steady machine the probes cost ~1 % of the steps;
* if the recent median rises above ``rise`` times its value at the last decision (load that
  started since), it probes at once instead of waiting for the interval.

The first step of each kernel in a process is not used (it may load the kernel from numba's cache
and start the thread pool). The clock is injectable so that tests can force switches.
"""

from __future__ import annotations

import os
import time
from collections import deque
from collections.abc import Callable

import numba

__all__ = ["KernelChoice", "launch_threads", "step_clock"]


def step_clock(parallel: bool) -> float:
    """Seconds for timing a step of the kernel ``parallel``: wall time for the parallel kernel, the
    calling thread's CPU time for the serial one (module docstring)."""
    return time.perf_counter() if parallel else time.thread_time()


def _median(values) -> float:
    s = sorted(values)
    m = len(s) // 2
    return s[m] if len(s) % 2 else 0.5 * (s[m - 1] + s[m])


class KernelChoice:
    """Which kernel runs the next step (:attr:`parallel`), updated by :meth:`timed` steps.

    Args:
        parallel: the kernel of the first steps (True: the parallel one).
        window: recent steps of the kernel in use whose median is its current cost (>= probe).
        probe: steps of the other kernel per probe.
        first_interval: steps of the kernel in use before the first probe and after a switch.
        max_interval: the longest wait between probes.
        margin: the probe must be faster by this fraction to switch (in [0, 1)).
        abort: a probe ends early once all its steps so far are slower than this many times the
            current median (> 1).
        rise: probe at once when the current median exceeds this many times its value at the last
            decision (> 1).
        clock: ``clock(parallel)`` -> seconds, monotonic, for a step of that kernel
            (default :func:`step_clock`).
    """

    def __init__(
        self,
        parallel: bool = True,
        *,
        window: int = 16,
        probe: int = 4,
        first_interval: int = 32,
        max_interval: int = 1024,
        margin: float = 0.1,
        abort: float = 2.0,
        rise: float = 1.5,
        clock: Callable[[bool], float] = step_clock,
    ):
        if not 1 <= probe <= window:
            raise ValueError(f"KernelChoice needs 1 <= probe <= window, got probe={probe}, window={window}")
        if not 1 <= first_interval <= max_interval:
            raise ValueError(
                "KernelChoice needs 1 <= first_interval <= max_interval, "
                f"got {first_interval}, {max_interval}"
            )
        if not (0.0 <= margin < 1.0 and abort > 1.0 and rise > 1.0):
            raise ValueError(
                f"KernelChoice needs margin in [0, 1), abort > 1, rise > 1; got {margin}, {abort}, {rise}"
            )
        self.parallel = bool(parallel)  # the kernel of the next step
        self.current = self.parallel  # the kernel chosen (differs from `parallel` during a probe)
        self._window, self._probe_len = window, probe
        self._first, self._max = first_interval, max_interval
        self._margin, self._abort, self._rise = margin, abort, rise
        self._clock = clock
        self._times: deque[float] = deque(maxlen=window)  # seconds per row, kernel in use
        self._probe: list[float] = []
        self._interval = self._until = first_interval
        self._ref = 0.0  # the median at the last decision (0: none yet)
        self._seen = [False, False]  # a first step of [serial, parallel] was taken
        self.steps = [0, 0]  # steps run by [serial, parallel]
        self.switches = 0
        self.probes = 0
        self._t0 = 0.0

    def start(self) -> None:
        """Call right before the step runs (with the kernel :attr:`parallel`)."""
        self._t0 = self._clock(self.parallel)

    def stop(self, rows: int) -> None:
        """Call right after the step, which stepped ``rows`` (>= 1) env rows; updates :attr:`parallel`."""
        per_row = (self._clock(self.parallel) - self._t0) / rows
        k = int(self.parallel)
        self.steps[k] += 1
        first, self._seen[k] = not self._seen[k], True
        if self.parallel == self.current:
            self._own_step(per_row, first)
        else:
            self._probe_step(per_row, first)

    def _own_step(self, per_row: float, first: bool) -> None:
        if not first:
            self._times.append(per_row)
        self._until -= 1
        if len(self._times) < self._probe_len:
            return
        rose = self._ref > 0.0 and _median(self._times) > self._rise * self._ref
        if self._until <= 0 or rose:
            self.parallel = not self.current  # probe the other kernel
            self._probe = []
            self.probes += 1

    def _probe_step(self, per_row: float, first: bool) -> None:
        if not first:
            self._probe.append(per_row)
        if not self._probe:
            return
        now = _median(self._times)
        if len(self._probe) < self._probe_len and min(self._probe) <= self._abort * now:
            return  # keep probing
        other = _median(self._probe)
        if other < (1.0 - self._margin) * now:  # switch
            self.current = self.parallel
            self._times.clear()
            self._times.extend(self._probe)
            self._ref = other
            self._interval = self._first
            self.switches += 1
        else:  # stay
            self.parallel = self.current
            self._ref = now
            self._interval = min(2 * self._interval, self._max)
        self._until = self._interval


# GNU OpenMP's wait policy for numba's worker threads (read once, when numba loads the runtime)
OMP_WAIT_POLICY = "PASSIVE"


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
