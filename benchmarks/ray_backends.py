"""The two ray-casting backends (core.raycast) side by side, in one run on one machine.

    .venv/bin/python benchmarks/ray_backends.py [--rays 2000000] [--resolution 256] [--qualities DRAFT,MEDIUM]

1. Throughput: random rays through the Cornell box and room samples' triangles (their exported scenes), first hit
   and occlusion, on one thread and on all cores; millions of rays per second, and Warp's share of Embree's.
2. Bakes: each sample's lightmap (our presets, one square page of ``--resolution``) with each backend: seconds,
   and the relative RMSE of the Warp bake from the Embree bake over the texels the page covers.
Warp's kernels are loaded (and compiled on a machine's first use) before anything is timed.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "addon"))
from blender_setup import lightmap_bake, load_extension, make_sample  # noqa: E402

BACKENDS = ("embree", "warp")


def throughput(raycast, triangles: np.ndarray, rays: int, threads: int) -> dict:
    """Million rays per second per backend and query, on random rays from inside the scene's bounding box."""
    rng = np.random.default_rng(0)
    low, high = triangles.reshape(-1, 3).min(axis=0), triangles.reshape(-1, 3).max(axis=0)
    origins = rng.uniform(low, high, (rays, 3))
    directions = rng.normal(size=(rays, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    distances = np.full(rays, 0.25 * np.linalg.norm(high - low))
    rates = {}
    for name in BACKENDS:
        os.environ[raycast.BACKEND_VARIABLE] = name
        caster = raycast.RayCaster(triangles, threads)
        for query, run in (("first hit", lambda: caster.first_hit(origins, directions)),
                           ("occlusion", lambda: caster.occluded(origins, directions, distances))):
            run()  # warm up
            started = time.perf_counter()
            run()
            rates[name, query] = rays / (time.perf_counter() - started) / 1e6
        caster.close()
    return rates


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rays", type=int, default=2_000_000)
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--qualities", default="DRAFT,MEDIUM")
    args = parser.parse_args()
    import bpy
    package = load_extension()
    package.register()
    from radiosity_baker.core import raycast
    from radiosity_baker.core.raycast_warp import Scene as WarpScene
    WarpScene(np.zeros((1, 3, 3), np.float32))  # load (or compile) the kernels before any timing
    folder = Path(tempfile.mkdtemp())
    print(f"{os.cpu_count()} cores")
    print("| scene | triangles | query | threads | Embree M rays/s | Warp M rays/s | Warp / Embree |")
    print("|---|---:|---|---:|---:|---:|---:|")
    bakes = []
    for scene_name in ("cornell_box", "room"):
        scene_file = make_sample(scene_name, folder)
        lights = {}
        for quality in args.qualities.split(","):
            for name in BACKENDS:
                os.environ[raycast.BACKEND_VARIABLE] = name
                bpy.ops.wm.open_mainfile(filepath=str(scene_file))
                bake, _, seconds = lightmap_bake(quality, folder / name, lightmap_resolution=args.resolution)
                page, = bake.lightmaps
                lights[quality, name] = (page.light.astype(np.float64), page.covered, seconds)
                triangles = bake.export.scene.triangles
            embree, warp = lights[quality, "embree"], lights[quality, "warp"]
            covered = embree[1]
            error = np.sqrt(np.mean((warp[0][covered] - embree[0][covered]) ** 2)) / embree[0][covered].mean()
            bakes.append((scene_name, quality, embree[2], warp[2], error))
        for threads in (1, os.cpu_count() or 1):
            rates = throughput(raycast, triangles, args.rays, threads)
            for query in ("first hit", "occlusion"):
                embree_rate, warp_rate = rates["embree", query], rates["warp", query]
                print(f"| {scene_name} | {len(triangles):,} | {query} | {threads} | {embree_rate:.2f} | "
                      f"{warp_rate:.2f} | {warp_rate / embree_rate:.2f} |")
    print()
    print("| scene | quality | Embree bake s | Warp bake s | Warp / Embree time | Warp's rel. RMSE from Embree |")
    print("|---|---|---:|---:|---:|---:|")
    for scene_name, quality, embree_seconds, warp_seconds, error in bakes:
        print(f"| {scene_name} | {quality} | {embree_seconds:.1f} | {warp_seconds:.1f} | "
              f"{warp_seconds / embree_seconds:.2f} | {error:.3%} |")


if __name__ == "__main__":
    main()
