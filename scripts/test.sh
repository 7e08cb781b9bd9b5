#!/usr/bin/env bash
# Set up (scripts/setup.sh) and run the whole test suite. Extra arguments go to pytest.
#
# The numba kernels most tests call are compiled into their on-disk cache first, planar and spatial side by
# side (scripts/warm_kernels.py): on a fresh clone the test processes would otherwise compile the same
# kernels each. The tests then run on TEST_WORKERS pytest-xdist workers (default: one per core, at most
# 8); the tests of a file with a fixture built once per module stay on one worker (tests/conftest.py).
# TEST_WORKERS=0 runs them in this one process. A failed warm-up does not stop the suite: the tests
# that call the failing code report it.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 PYTHONHASHSEED=0
.venv/bin/python scripts/warm_kernels.py planar &
PLANAR=$!
.venv/bin/python scripts/warm_kernels.py spatial || echo "scripts/warm_kernels.py spatial failed (above)" >&2
wait "$PLANAR" || echo "scripts/warm_kernels.py planar failed (above)" >&2
CORES=$(.venv/bin/python -c "import os; print(len(os.sched_getaffinity(0)))")
WORKERS=${TEST_WORKERS:-$((CORES < 8 ? CORES : 8))}
exec .venv/bin/python -m pytest -q -n "$WORKERS" --dist loadgroup "$@"
