#!/usr/bin/env bash
# Prints the path of a Python 3.13 interpreter (bpy 5.2 needs 3.13): $PYTHON, python3.13, or pyenv's 3.13.x.
set -euo pipefail
if [ -n "${PYTHON:-}" ]; then echo "$PYTHON"; exit 0; fi
if command -v python3.13 >/dev/null 2>&1; then command -v python3.13; exit 0; fi
if command -v pyenv >/dev/null 2>&1; then
  for v in $(pyenv versions --bare 2>/dev/null | grep -E '^3\.13(\.[0-9]+)?$' | sort -V -r); do
    candidate="$(pyenv root)/versions/$v/bin/python3"
    [ -x "$candidate" ] && { echo "$candidate"; exit 0; }
  done
fi
echo "error: Python 3.13 not found; install it (e.g. 'pyenv install 3.13') or set PYTHON=/path/to/python3.13" >&2
exit 1
