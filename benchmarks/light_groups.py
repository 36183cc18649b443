"""Light groups against the ordinary bake, in one run on one machine.

    .venv/bin/python benchmarks/light_groups.py [--scene room|cornell_box] [--qualities DRAFT,MEDIUM]
                      [--resolution 256] [--target LIGHTMAP|BOTH]

Bakes a sample scene (the room's lamps are in the group 'lamps', its sun and sky in 'daylight') without and with
light groups at each quality and prints seconds, their ratio, the groups' share of the light, and how far the sum
of the groups' lightmaps lies from the ordinary bake (mean absolute difference over the mean, covered texels; and,
with BOTH, the same for the colour attributes' corners).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "addon"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", choices=("room", "cornell_box"), default="room")
    parser.add_argument("--qualities", default="DRAFT,MEDIUM")
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--target", choices=("LIGHTMAP", "BOTH"), default="LIGHTMAP")
    args = parser.parse_args()
    import bpy
    from blender_setup import corner_colors, lightmap_bake, load_extension
    load_extension().register()
    scene_file = ROOT / "sample_blends" / f"{args.scene}.blend"
    print(f"{'quality':8} {'ordinary s':>10} {'groups s':>9} {'ratio':>6} {'sum vs ordinary':>16} "
          f"{'corners':>8}  groups (share of the light)")
    for quality in args.qualities.split(","):
        results = []
        for groups in (False, True):
            bpy.ops.wm.open_mainfile(filepath=str(scene_file))
            job, report, seconds = lightmap_bake(quality, Path(tempfile.mkdtemp()), target=args.target,
                                                 lightmap_resolution=args.resolution, light_groups=groups)
            corners = [corner_colors(bpy.data.objects[o["name"]].data, "Radiosity") for o in report["objects"]
                       if o.get("color_attribute")]
            results.append((job, seconds, np.concatenate(corners) if corners else None))
        (plain, plain_s, plain_corners), (grouped, grouped_s, grouped_corners) = results
        covered = np.concatenate([page.covered.ravel() for page in plain.lightmaps])
        light = lambda job: np.concatenate([page.light.reshape(-1, 3) for page in job.lightmaps])[covered]
        ordinary, summed = light(plain), light(grouped)
        error = np.abs(summed - ordinary).sum() / ordinary.sum()
        corner_error = (f"{np.abs(grouped_corners - plain_corners).sum() / plain_corners.sum():8.2%}"
                        if plain_corners is not None else f"{'-':>8}")
        shares = {name: float(np.concatenate([page.groups[name].reshape(-1, 3) for page in grouped.lightmaps])
                              [covered].sum() / summed.sum()) for name in grouped.lightmaps[0].groups}
        print(f"{quality:8} {plain_s:10.1f} {grouped_s:9.1f} {grouped_s / plain_s:6.2f} {error:16.2%} {corner_error}  "
              + ", ".join(f"{name or 'ungrouped'} {share:.0%}" for name, share in shares.items()))


if __name__ == "__main__":
    main()
