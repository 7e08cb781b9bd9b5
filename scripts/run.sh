#!/usr/bin/env bash
# Set up (scripts/setup.sh) and run the main job: on each family's -v1 id (SmaSpine-v1, SmaSpine3D-v1,
# SmaSpineChain-v1), evaluate the shipped policies against the step-voltage, bang-bang and PID baselines on the
# fixed scenario suite of spine_gym/agents/scenarios.py, at equal terms: a policy trained with a higher voltage
# ceiling gets its own table, with the baselines run at that ceiling. Prints one table per scenario group and the
# ratios to the PID, writes CSVs and PNG plots to results/eval/<env id>[_v_max_<V>]/ and ends with where they went.
# Extra arguments go to `python -m spine_gym.agents.family_comparison` (e.g. --suite quick, -o DIR, --plain,
# --no-plots, --envs SmaSpine-v1).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
exec .venv/bin/python -m spine_gym.agents.family_comparison "$@"
