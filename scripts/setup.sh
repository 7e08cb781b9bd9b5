#!/usr/bin/env bash
# Create .venv (Python 3.11) and install spine_gym with every extra but rllib (`.[all]`: RL, Minari datasets, design
# studies, calibration, videos, tests). `pip install spine_gym` alone is the simulator and the envs.
# torch is pinned to 2.13.0 in pyproject.toml: on these machines pip takes the CPU build from local
# disk; an unpinned torch would pull several GB of CUDA wheels.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null 2>&1 || PY=python3
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
.venv/bin/python -m pip install -q --upgrade pip >/dev/null 2>&1 || true
.venv/bin/python -m pip install -q -e ".[all]" 2>&1 | grep -v "is ignored: it is neither a file nor a directory" || true
.venv/bin/python -c "import spine_gym, torch; print('spine_gym', spine_gym.__version__, '| torch', torch.__version__)"
