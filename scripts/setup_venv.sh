#!/usr/bin/env bash
# Create .venv (Python 3.13) with the pinned test requirements, bpy included; pip caches the large bpy wheel.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/python ]; then
  "$(scripts/python.sh)" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r requirements/test.txt
