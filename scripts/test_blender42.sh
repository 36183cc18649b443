#!/usr/bin/env bash
# The whole test suite again on Blender 4.2 LTS (bpy 4.2, Python 3.11, numpy 1.26) in .venv-bpy42.
# Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv-bpy42/bin/python ]; then
  PYTHON_VERSION=3.11 "$(PYTHON_VERSION=3.11 scripts/python.sh)" -m venv .venv-bpy42
fi
.venv-bpy42/bin/python -m pip install --quiet --disable-pip-version-check -r requirements/blender42.txt
exec .venv-bpy42/bin/python -m pytest "$@"
