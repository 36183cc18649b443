"""Benchmark: the classic progressive solver on the interior scene at growing element counts, as a table.

    .venv/bin/python benchmarks/solve_interior.py [--sizes 1.0 0.5 0.25 0.125] [--patch 1.0] [--method raycast]

Each size runs in its own process so that peak memory (ru_maxrss) belongs to that size alone. The raw embreex
rate is measured in the same run on the same scene: incoherent random rays through our RayCaster (all cores)
and through one embreex call (one core).
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from interior import interior_scene  # noqa: E402

from core import BakeSettings, bake  # noqa: E402
from core.raycast import RayCaster  # noqa: E402


def run_one(element_size: float, patch_size: float, method: str, threshold: float) -> dict:
    scene = interior_scene()
    started = time.perf_counter()
    solution = bake(scene, BakeSettings(element_size_m=element_size, patch_size_m=patch_size, form_factors=method,
                                        residual_threshold=threshold, solver="progressive"))
    seconds = time.perf_counter() - started
    return {"element_size_m": element_size, "elements": solution.element_count,
            "patches": len(solution.state.patches.area_m2), "seconds": seconds,
            "near_field_seconds": solution.seconds.get("near field", 0.0), "rays": solution.rays_cast,
            "shots": solution.history[-1].shots, "residual": solution.residual,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def raw_embree_rays_per_second(count: int = 2_000_000) -> tuple[float, float]:
    """(all cores through RayCaster, one embreex call on one core) for random rays inside the room."""
    scene = interior_scene()
    caster = RayCaster(scene.triangles)
    rng = np.random.default_rng(0)
    origins = rng.random((count, 3)) * [6, 5, 3]
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    distances = np.full(count, np.inf)
    started = time.perf_counter()
    caster.occluded(origins, directions, distances)
    threaded = count / (time.perf_counter() - started)
    started = time.perf_counter()
    caster._scene.run(origins.astype(np.float32), directions.astype(np.float32), query="OCCLUDED")
    single = count / (time.perf_counter() - started)
    return threaded, single


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=float, nargs="+", default=[1.0, 0.5, 0.25, 0.125])
    parser.add_argument("--patch", type=float, default=1.0)
    parser.add_argument("--method", default="raycast", choices=["raycast", "hemicube"])
    parser.add_argument("--threshold", type=float, default=0.01)
    parser.add_argument("--one", type=float, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one is not None:
        print(json.dumps(run_one(args.one, args.patch, args.method, args.threshold)))
        return
    threaded, single = raw_embree_rays_per_second()
    rows = []
    for size in args.sizes:
        output = subprocess.run([sys.executable, __file__, "--one", str(size), "--patch", str(args.patch),
                                 "--method", args.method, "--threshold", str(args.threshold)],
                                check=True, capture_output=True, text=True).stdout
        rows.append(json.loads(output.strip().splitlines()[-1]))
    print(f"Interior scene, {args.method} form factors, patch size {args.patch} m, residual threshold "
          f"{args.threshold}; raw embreex (random occlusion rays): {threaded / 1e6:.2f} M rays/s on all cores, "
          f"{single / 1e6:.2f} M rays/s on one core\n")
    print("| elements | patches | shots | seconds | of which near field | rays cast | M rays/s | of raw (all cores) "
          "| peak RSS MB | residual |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        rate = r["rays"] / r["seconds"]
        print(f"| {r['elements']} | {r['patches']} | {r['shots']} | {r['seconds']:.1f} | {r['near_field_seconds']:.1f} "
              f"| {r['rays'] / 1e6:.1f} M "
              f"| {rate / 1e6:.2f} | {rate / threaded:.0%} | {r['peak_rss_mb']:.0f} | {r['residual']:.4f} |")
    base = rows[0]
    print("\nScaling against the smallest size: " + ", ".join(
        f"{r['elements'] / base['elements']:.0f}x elements -> {r['seconds'] / base['seconds']:.1f}x time"
        for r in rows[1:]))


if __name__ == "__main__":
    main()
