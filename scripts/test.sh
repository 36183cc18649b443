#!/usr/bin/env bash
# Set up .venv (Python 3.13, pinned requirements) on a fresh machine and run the test suite.
# Extra arguments go to pytest, e.g. scripts/test.sh -k formfactor
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/python ]; then
  "$(scripts/python.sh)" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r requirements/test.txt
exec .venv/bin/python -m pytest "$@"
