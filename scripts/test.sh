#!/usr/bin/env bash
# Set up .venv on a fresh machine and run the whole test suite (core tests, then add-on tests on bpy 5.2).
# Extra arguments go to pytest, e.g. scripts/test.sh -k formfactor
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup_venv.sh
exec .venv/bin/python -m pytest "$@"
