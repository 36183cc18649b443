"""The extension as users get it: Blender's tool validates the manifest and builds the per-platform zips; the
linux zip installs into a fresh user extension repository, loads embreex from its bundled wheel and bakes; the
macOS arm64 zip, which cannot run here, bundles for every Python the extension supports a macOS arm64 wheel of
each library Blender does not ship, warp-lang for ray casting in place of embreex."""
import json
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

from blender_setup import ROOT


def test_built_linux_zip_installs_loads_its_wheel_and_bakes(tmp_path):
    subprocess.run([sys.executable, str(ROOT / "scripts" / "build_extension.py"), "--output-dir", str(tmp_path)],
                   check=True, capture_output=True, text=True, timeout=900)
    zips = sorted(p.name for p in tmp_path.glob("*.zip"))
    assert zips == ["radiosity_baker-0.1.0-linux_x64.zip", "radiosity_baker-0.1.0-macos_arm64.zip",
                    "radiosity_baker-0.1.0-windows_x64.zip"]
    _check_macos_wheels(tmp_path / zips[1])
    user = tmp_path / "user"
    user.mkdir()
    result = subprocess.run([sys.executable, str(Path(__file__).with_name("install_and_bake.py")),
                             str(tmp_path / zips[0])], env={**os.environ, "BLENDER_USER_RESOURCES": str(user)},
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    found = json.loads(result.stdout.strip().splitlines()[-1])
    assert found["install"] == ["FINISHED"] and found["bake"] == ["FINISHED"] and found["attribute"]
    assert found["embreex"].startswith(found["local"])


def _check_macos_wheels(path: Path) -> None:
    """Every wheel of the macOS zip is tagged for macOS arm64 and listed in its manifest, and each of xatlas and
    warp-lang has one that installs on CPython 3.11 (Blender 4.2-5.0) and one for 3.13 (Blender 5.1+)."""
    with zipfile.ZipFile(path) as archive:
        wheels = [Path(name).name for name in archive.namelist() if name.endswith(".whl")]
        manifest = archive.read("blender_manifest.toml").decode()
        sources = set(archive.namelist())
    assert {"core/raycast_warp.py", "core/raycast.py"} <= sources
    assert set(wheels) <= set(re.findall(r"wheels/([^\"]+\.whl)", manifest))  # it lists every platform's
    for wheel in wheels:
        assert re.search(r"macosx_\d+_\d+_arm64\.whl$", wheel), wheel
    for package in ("warp_lang", "xatlas"):
        for python in ("cp311", "cp313"):
            tags = [wheel.split("-")[2] for wheel in wheels if wheel.startswith(package + "-")]
            assert any(tag in (python, "py3") for tag in tags), (package, python, tags)
    assert not any(wheel.startswith("embreex") for wheel in wheels)
