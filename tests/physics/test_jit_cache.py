"""The serial and the parallel twin of a kernel keep separate on-disk cache entries.

numba keys its cache by function name and signature, not by the ``parallel`` flag: compiled from
one function, ``step_many_serial`` loaded the machine code of ``step_many`` once that had been cached
(the single env and ``parallel=False`` vector envs then started OpenMP threads and, on a busy
machine, ran ~10x slower). Two fresh processes share the normal cache: the first runs the parallel
kernel (so its entry exists), the second runs only serial code and must not start numba's threads.
"""

import subprocess
import sys

STEP = (
    "import numpy as np, gymnasium as gym, spine_gym\n"
    "from numba.np.ufunc import parallel as npar\n"
    "env = gym.make_vec('SmaSpine-v0', num_envs=3, vectorization_mode='vector_entry_point', parallel={p})\n"
    "env.reset(seed=0); env.step(np.zeros((3, 2), np.float32))\n"
    "single = gym.make('SmaSpine-v0'); single.reset(seed=0); single.step(np.zeros(2, np.float32))\n"
    "print('threads started:', npar._is_initialized)\n"
)


def _run(parallel: bool | None) -> str:
    r = subprocess.run(
        [sys.executable, "-c", STEP.format(p=parallel)], capture_output=True, text=True, timeout=300
    )
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_serial_kernel_never_runs_the_parallel_machine_code():
    assert "threads started: True" in _run(parallel=True)
    assert "threads started: False" in _run(parallel=False)


def test_default_kernel_at_small_n_starts_no_threads():
    """Below PARALLEL_MIN_ENVS sub-envs the default (parallel=None) is the serial kernel,
    so OpenMP's thread pool (and its spinning idle workers) never starts."""
    assert "threads started: False" in _run(parallel=None)
