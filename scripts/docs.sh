#!/usr/bin/env bash
# Build the documentation site (Sphinx + Furo + MyST; docs/conf.py) into docs/_build/html.
# Python: the activated virtual environment ($VIRTUAL_ENV) if there is one, else .venv (set up first
# by scripts/setup.sh if it is missing). The `docs` extra is installed into it if Sphinx, Furo or
# myst-nb are missing. Warnings are errors (-W; --keep-going reports all of them), broken internal
# links included. Every build starts from scratch (the old docs/_build/html is removed and -E
# re-reads every page), so that no warning hides in a cached page and no page of an older build
# (a source page of viewcode is only rewritten when its module changes) stays behind. Extra
# arguments go to sphinx-build. No network is needed and no notebook is executed.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -n "${VIRTUAL_ENV:-}" ] && [ -x "$VIRTUAL_ENV/bin/python" ]; then
  PY=$VIRTUAL_ENV/bin/python
else
  [ -x .venv/bin/python ] || bash scripts/setup.sh
  PY=.venv/bin/python
fi
if ! "$PY" -c "import sphinx, furo, myst_parser, myst_nb" 2>/dev/null; then
  "$PY" -m pip install -q -e ".[docs]" 2>&1 | grep -v "is ignored: it is neither a file nor a directory" || true
fi
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} MKL_NUM_THREADS=${MKL_NUM_THREADS:-1}
rm -rf docs/_build/html
exec "$PY" -m sphinx -W --keep-going -E -b html docs docs/_build/html "$@"
