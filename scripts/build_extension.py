"""Build the extension zips with Blender's own tool (blender_ext.py inside the bpy wheel).

    .venv/bin/python scripts/build_extension.py [--output-dir dist]

Copies the tracked sources into build/extension, downloads the wheels each platform in the manifest bundles (BUNDLED:
a ray-casting library, embreex or, on macOS where embreex has no wheel, warp-lang; and xatlas) for Python 3.11
(Blender 4.2-5.0) and 3.13 (Blender 5.1+) into its wheels/ folder (never committed), lists them in the copied
manifest, then runs `blender_ext.py validate` and `build --split-platforms`, which gives each platform's zip the
wheels whose tags match it.
"""
from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# pip takes explicit --platform tags literally, so list every manylinux level the pinned wheels use.
PLATFORM_TAGS = {"linux-x64": ["manylinux_2_28_x86_64", "manylinux_2_17_x86_64", "manylinux2014_x86_64"],
                 "windows-x64": ["win_amd64"], "macos-arm64": ["macosx_11_0_arm64"]}
PYTHONS = ("3.11", "3.13")


def blender_ext() -> Path:
    import importlib.util
    spec = importlib.util.find_spec("bpy")
    folders = [Path(spec.origin).parent] if spec and spec.origin else []
    found = sorted(f for folder in folders for f in folder.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        sys.exit("error: blender_ext.py not found inside the bpy module")
    return found[-1]


# What Blender does not ship (it ships numpy and OpenImageIO), per platform: core.raycast uses embreex where it
# has wheels and Warp elsewhere.
BUNDLED = {"linux-x64": ("embreex", "xatlas"), "windows-x64": ("embreex", "xatlas"),
           "macos-arm64": ("warp-lang", "xatlas")}


def bundled_pins(platform: str) -> list[str]:
    lines = (ROOT / "requirements" / "core.txt").read_text().splitlines()
    return [line.strip() for line in lines if line.split("==")[0] in BUNDLED[platform]]


def copy_sources(target: Path) -> None:
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, check=True, capture_output=True, text=True).stdout.split()
    for name in files:
        (target / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, target / name)


def download_wheels(target: Path, platforms: list[str]) -> list[str]:
    wheels = target / "wheels"
    wheels.mkdir(exist_ok=True)
    for platform in platforms:
        for python in PYTHONS:
            subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary=:all:",
                            "--python-version", python,
                            *(f"--platform={tag}" for tag in PLATFORM_TAGS[platform]), "-d", str(wheels),
                            *bundled_pins(platform)], check=True)
    return sorted(f"./wheels/{w.name}" for w in wheels.glob("*.whl"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--output-dir", default=str(ROOT / "dist"))
    args = parser.parse_args()
    source = ROOT / "build" / "extension"
    shutil.rmtree(source, ignore_errors=True)
    source.mkdir(parents=True)
    copy_sources(source)
    manifest = (source / "blender_manifest.toml").read_text()
    platforms = re.findall(r'"([a-z]+-[a-z0-9]+)"', re.search(r"^platforms = \[(.*)\]", manifest, re.M).group(1))
    wheels = download_wheels(source, platforms)
    listed = "wheels = [\n" + "".join(f'  "{w}",\n' for w in wheels) + "]"
    (source / "blender_manifest.toml").write_text(re.sub(r"^wheels = \[\]", listed, manifest, flags=re.M))
    output = Path(args.output_dir)
    output.mkdir(parents=True, exist_ok=True)
    tool = blender_ext()
    subprocess.run([sys.executable, str(tool), "validate", str(source)], check=True)
    subprocess.run([sys.executable, str(tool), "build", "--source-dir", str(source), "--output-dir", str(output),
                    "--split-platforms"], check=True)
    print("\n".join(str(p) for p in sorted(output.glob("*.zip"))))


if __name__ == "__main__":
    main()
