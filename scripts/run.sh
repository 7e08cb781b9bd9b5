#!/usr/bin/env bash
# Set up (scripts/setup.sh) and run the main job. Extra arguments go to the job.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
exec .venv/bin/python -m spine_gym.experiments "$@"
