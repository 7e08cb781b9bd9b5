#!/usr/bin/env bash
# Set up (scripts/setup.sh) and run the main job: evaluate the shipped PPO/SAC policies against the
# step-voltage, bang-bang and PID baselines on the fixed scenario suite of spine_gym/agents/scenarios.py,
# print one table per scenario group and write CSVs and PNG plots to results/eval/.
# Extra arguments go to `python -m spine_gym.agents.evaluate` (e.g. --suite quick, --out DIR, --plain).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
exec .venv/bin/python -m spine_gym.agents.evaluate "$@"
