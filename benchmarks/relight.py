"""Update Light against a new bake, in one run on one machine.

    .venv/bin/python benchmarks/relight.py [--qualities MEDIUM] [--element-size 0.05] [--resolution 512]

Bakes the room sample with a relighting cache (each lamp, the sun and the sky a source of the basis), edits its
lights as a lighting artist would, then relights from the cache and bakes the edited scene anew. Two edits:
"evening" (sun off, lamps warmer, world halved) and "morning" (baked at night, with the sun off and the world
halved; relit with the sun on, the lamps off and the world at full strength). Prints per quality (and, with
--element-size, for Custom elements of that size) and edit: elements, texels, sources, the bake with the cache, the
new bake and the relight in seconds, how far the relit lightmap and colour attributes lie from the new bake (mean
absolute difference over the mean), and the cache's size.
"""
from __future__ import annotations

import argparse
import itertools
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "addon"))


def evening(bpy) -> None:
    """Sun off, the lamps warmer (a 3000 K-ish tint), the world at half strength."""
    for obj in bpy.data.objects:
        if obj.type == "LIGHT" and obj.data.type == "SUN":
            obj.data.energy = 0.0
        elif obj.type == "LIGHT":
            obj.data.color = (1.0, 0.7, 0.45)
    _scale_world(bpy, 0.5)


def night(bpy) -> None:
    """Sun off (its strength kept in a custom property), the world at half strength."""
    for obj in bpy.data.objects:
        if obj.type == "LIGHT" and obj.data.type == "SUN":
            obj["day_strength"], obj.data.energy = obj.data.energy, 0.0
    _scale_world(bpy, 0.5)


def morning(bpy) -> None:
    """After ``night``: the sun back at its strength, the lamps off, the world at full strength."""
    for obj in bpy.data.objects:
        if obj.type == "LIGHT":
            obj.data.energy = obj["day_strength"] if obj.data.type == "SUN" else 0.0
    _scale_world(bpy, 2.0)


def _scale_world(bpy, factor: float) -> None:
    bpy.context.scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value *= factor


# (name, what is done before the bake, the edit relit afterwards)
EDITS = [("evening", lambda bpy: None, evening), ("morning", night, morning)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--qualities", default="MEDIUM")
    parser.add_argument("--element-size", type=float, default=0.0, help="also bake Custom elements of this size")
    parser.add_argument("--resolution", type=int, default=512)
    args = parser.parse_args()
    import bpy
    from blender_setup import corner_colors, lightmap_bake, load_extension
    load_extension().register()
    from radiosity_baker.radiosity_addon import job as bake_job
    from radiosity_baker.radiosity_addon.settings import UserSettings
    runs = [(quality, {}) for quality in args.qualities.split(",")]
    if args.element_size:
        runs.append(("CUSTOM", {"element_size": args.element_size, "patch_size": max(args.element_size, 0.5),
                                "residual": 0.001, "light_samples": 7, "lightmap_indirect": "auto"}))
    print(f"{'quality':8} {'edit':8} {'elements':>9} {'texels':>8} {'sources':>7} {'bake+cache s':>12} "
          f"{'new bake s':>10} {'relight s':>9} {'lightmap':>8} {'corners':>8} {'cache MB':>8}")
    for (quality, custom), (edit, before, after) in itertools.product(runs, EDITS):
        folder = Path(tempfile.mkdtemp())
        settings = dict(target="BOTH", lightmap_resolution=args.resolution, **custom)
        bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / "room.blend"))
        before(bpy)
        cache = folder / "room.rlcache"
        baked, report, cached_s = lightmap_bake(quality, folder / "baked", relight_cache=str(cache), **settings)
        after(bpy)
        started = time.perf_counter()
        relit = bake_job.relight_job(bpy.context, UserSettings(quality=quality, **settings), str(folder / "relit"),
                                     str(cache))
        bake_job.write_outputs(relit)
        relight_s = time.perf_counter() - started
        names = [o["name"] for o in report["objects"]]
        relit_corners = np.concatenate([corner_colors(bpy.data.objects[n].data, "Radiosity") for n in names])
        relit_light = bake_job._mixed(relit, relit.lightmaps[0])
        fresh, _, fresh_s = lightmap_bake(quality, folder / "fresh", lightmap_image="Fresh", attribute_name="Fresh",
                                          **settings)
        corners = np.concatenate([corner_colors(bpy.data.objects[n].data, "Fresh") for n in names])
        covered, light = fresh.lightmaps[0].covered, fresh.lightmaps[0].light
        page_error = np.abs(relit_light - light)[covered].sum() / light[covered].sum()
        corner_error = np.abs(relit_corners - corners).sum() / corners.sum()
        print(f"{quality:8} {edit:8} {report['elements']:9d} {report['lightmap']['texels']:8d} {len(baked.sources):7d} "
              f"{cached_s:12.1f} {fresh_s:10.1f} {relight_s:9.2f} {page_error:8.3%} {corner_error:8.3%} "
              f"{os.path.getsize(cache) / 2 ** 20:8.1f}")


if __name__ == "__main__":
    main()
