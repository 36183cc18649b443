#!/usr/bin/env bash
# Prints the path of a working Python of version $PYTHON_VERSION (default 3.13, for bpy 5.2; 3.11 for bpy 4.2):
# $PYTHON, else pyenv's newest matching version, else pythonX.Y on the PATH. Each candidate is run once to prove
# it works (a pyenv shim for a version that is installed but not selected exists and fails).
set -euo pipefail
want="${PYTHON_VERSION:-3.13}"
works() { "$1" -c "import sys; assert '%d.%d' % sys.version_info[:2] == '$want'" >/dev/null 2>&1; }
candidates=()
[ -n "${PYTHON:-}" ] && candidates+=("$PYTHON")
if command -v pyenv >/dev/null 2>&1; then
  for v in $(pyenv versions --bare 2>/dev/null | grep -E "^${want//./\\.}(\.[0-9]+)?$" | sort -V -r); do
    candidates+=("$(pyenv root)/versions/$v/bin/python3")
  done
fi
command -v "python$want" >/dev/null 2>&1 && candidates+=("$(command -v "python$want")")
for candidate in "${candidates[@]}"; do
  if works "$candidate"; then echo "$candidate"; exit 0; fi
done
echo "error: no working Python $want found; install it (e.g. 'pyenv install $want') or set PYTHON=/path/to/python$want" >&2
exit 1
