"""The extension as users get it: Blender's tool validates the manifest and builds the per-platform zips, and the
linux zip installs into a fresh user extension repository, loads embreex from its bundled wheel and bakes."""
import json
import os
import subprocess
import sys
from pathlib import Path

from blender_setup import ROOT


def test_built_linux_zip_installs_loads_its_wheel_and_bakes(tmp_path):
    subprocess.run([sys.executable, str(ROOT / "scripts" / "build_extension.py"), "--output-dir", str(tmp_path)],
                   check=True, capture_output=True, text=True, timeout=900)
    zips = sorted(p.name for p in tmp_path.glob("*.zip"))
    assert zips == ["radiosity_baker-0.1.0-linux_x64.zip", "radiosity_baker-0.1.0-windows_x64.zip"]
    user = tmp_path / "user"
    user.mkdir()
    result = subprocess.run([sys.executable, str(Path(__file__).with_name("install_and_bake.py")),
                             str(tmp_path / zips[0])], env={**os.environ, "BLENDER_USER_RESOURCES": str(user)},
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    found = json.loads(result.stdout.strip().splitlines()[-1])
    assert found["install"] == ["FINISHED"] and found["bake"] == ["FINISHED"] and found["attribute"]
    assert found["embreex"].startswith(found["local"])
