#!/usr/bin/env bash
# Prints the path of a working Python 3.13 interpreter (bpy 5.2 needs 3.13):
# $PYTHON, else pyenv's newest 3.13.x, else python3.13 on the PATH. Each candidate is run once to prove it works
# (a pyenv shim for a version that is installed but not selected exists and fails).
set -euo pipefail
works() { "$1" -c 'import sys; assert sys.version_info[:2] == (3, 13)' >/dev/null 2>&1; }
candidates=()
[ -n "${PYTHON:-}" ] && candidates+=("$PYTHON")
if command -v pyenv >/dev/null 2>&1; then
  for v in $(pyenv versions --bare 2>/dev/null | grep -E '^3\.13(\.[0-9]+)?$' | sort -V -r); do
    candidates+=("$(pyenv root)/versions/$v/bin/python3")
  done
fi
command -v python3.13 >/dev/null 2>&1 && candidates+=("$(command -v python3.13)")
for candidate in "${candidates[@]}"; do
  if works "$candidate"; then echo "$candidate"; exit 0; fi
done
echo "error: no working Python 3.13 found; install it (e.g. 'pyenv install 3.13') or set PYTHON=/path/to/python3.13" >&2
exit 1
