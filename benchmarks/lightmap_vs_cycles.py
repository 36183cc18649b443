"""Lightmap speed and error against Cycles on the same UV map, in one run on one machine.

    .venv/bin/python benchmarks/lightmap_vs_cycles.py [--scene cornell_box|room] [--resolution 128]
                      [--qualities DRAFT,MEDIUM,HIGH] [--samples 4,16,64,256,1024] [--reference 4096]

Bakes a sample scene with each of our quality presets into a lightmap, then bakes Cycles' Diffuse pass
(Direct + Indirect, no Color, CPU, 64 bounces, no clamping) on our UV map and resolution at increasing samples,
and twice (two seeds) at ``--reference`` samples: their mean is the reference, and their difference measures the
noise left in it, which is subtracted from every squared error (an unbiased estimate of the error against the
converged answer). Prints seconds and relative RMSE over the texels Cycles bakes, and for each of our presets the
Cycles time needed to reach the same error: by log-log interpolation along the sample ladder, and by Cycles' noise
law (error ~ samples^-1/2 from the ladder's lowest-error rung, time a fixed cost plus a cost per sample fitted to
the ladder; ``cycles_seconds_by_noise_law``). Left out: the Cornell
box's ceiling, whose rim sits 0.5 mm above the light's back face, and linked duplicates past the first (Cycles
bakes a shared mesh's UV map once), and texels whose centre lies inside closed geometry (a floor under a block:
Cycles bakes the dark inside, we push the sample out to the visible floor beside it).
"""
from __future__ import annotations

import argparse
import hashlib
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "addon"))
from blender_setup import triangle_uvs  # noqa: E402

LEFT_OUT = {"cornell_box": {"ceiling", "light"}, "room": set()}


def reference_noise_variance(first, second, mask) -> float:
    """The noise variance of the mean of two reference bakes with independent seeds over the masked texels: the
    mean squared difference of the two over 4 (each has variance v, their difference 2 v, their mean v / 2)."""
    return float(np.mean((first[mask] - second[mask]) ** 2) / 4.0)


def relative_rmse(values, reference, mask, reference_variance=0.0) -> float:
    """sqrt(mean squared difference - the reference's own noise variance) / mean of the reference."""
    squared = np.mean((values[mask] - reference[mask]) ** 2) - reference_variance
    return float(np.sqrt(max(squared, 0.0)) / reference[mask].mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", choices=sorted(LEFT_OUT), default="cornell_box")
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--qualities", default="DRAFT,MEDIUM,HIGH")
    parser.add_argument("--samples", default="4,16,64,256,1024")
    parser.add_argument("--reference", type=int, default=4096)
    parser.add_argument("--cache", default=str(ROOT / "benchmarks" / "cache"),
                        help="folder keeping reference bakes between runs ('' to recompute)")
    args = parser.parse_args()
    import bpy
    from blender_setup import cycles_lightmap_bake, lightmap_bake, load_extension, make_sample, uv_coverage
    package = load_extension()
    package.register()
    from radiosity_baker.radiosity_addon.lightmaps import OFFSET_PROPERTY
    folder = Path(tempfile.mkdtemp())
    scene_file = make_sample(args.scene, folder)
    ours = {}
    for quality in args.qualities.split(","):
        bpy.ops.wm.open_mainfile(filepath=str(scene_file))
        # a fixed resolution is one atlas page; the UV map Cycles bakes on is the same for every preset
        bake, report, seconds = lightmap_bake(quality, folder, lightmap_resolution=args.resolution,
                                              lightmap_padding=2)
        page, = bake.lightmaps
        ours[quality] = (page.light.astype(np.float64), seconds)
        moved = page.moved  # sample points inside closed geometry: Cycles bakes the inside there
    objects = [bpy.data.objects[entry["name"]] for entry in report["objects"] if entry["uv_map"]]
    objects = [o for o in objects if o.name not in LEFT_OUT[args.scene] and OFFSET_PROPERTY not in o]
    size = args.resolution
    mask = uv_coverage(objects, "Lightmap", size, size) & ~moved
    first, second, reference_seconds = reference_bakes(args.scene, bake.export.scene, objects, size, size,
                                                       args.reference, args.cache)
    reference = 0.5 * (first + second)
    variance = reference_noise_variance(first, second, mask)
    rows = []
    for samples in [int(s) for s in args.samples.split(",")]:
        light, seconds = cycles_lightmap_bake(objects, "Lightmap", size, size, samples, seed=3)
        rows.append((samples, seconds, relative_rmse(light, reference, mask, variance)))
    print(f"{args.scene} lightmap {size} x {size}, {int(mask.sum())} texels compared; reference: 2 x Cycles "
          f"{args.reference} spp ({reference_seconds:.1f} s each), its noise "
          f"{np.sqrt(variance) / reference[mask].mean():.4f} (removed from the errors below)")
    print_against_cycles(rows, {quality.lower(): (relative_rmse(light, reference, mask, variance), seconds)
                                for quality, (light, seconds) in ours.items()})
    print(f"\n{'relative RMSE per object':24s}" + "".join(f"{quality.lower():>10s}" for quality in ours))
    for obj in objects:
        own = uv_coverage([obj], "Lightmap", size, size) & mask
        own_variance = reference_noise_variance(first, second, own)
        errors = [relative_rmse(light, reference, own, own_variance) for light, _ in ours.values()]
        print(f"{obj.name:24s}" + "".join(f"{error:10.4f}" for error in errors))
    sys.stdout.flush()
    os._exit(0)  # bpy 4.2 crashes at interpreter teardown


def print_against_cycles(ladder: list[tuple[int, float, float]], ours: dict[str, tuple[float, float]]) -> None:
    """The table: Cycles' ladder (samples, seconds, error), then each of ours (quality -> (error, seconds)) with
    the Cycles time at the same error and the ratio of the two times, read two ways: along the ladder
    (``cycles_seconds_at``) and by Cycles' noise law (``cycles_seconds_by_noise_law``)."""
    cycles = sorted((error, seconds) for _, seconds, error in ladder)
    print(f"{'bake':24s} {'seconds':>8s} {'rel. RMSE':>10s} {'Cycles s at same error':>24s} {'ratio':>7s} "
          f"{'by N^-1/2':>10s} {'ratio':>7s}")
    for samples, seconds, error in ladder:
        print(f"{f'Cycles {samples} spp':24s} {seconds:8.2f} {error:10.4f}")
    for quality, (error, seconds) in ours.items():
        matched, extrapolated = cycles_seconds_at(error, cycles)
        ratio = f"{matched / seconds:7.2f}" if matched else "    n/a"
        matched_text = f"{matched:23.2f}{'*' if extrapolated else ' '}" if matched else f"{'(beyond the ladder)':>24s}"
        by_law = cycles_seconds_by_noise_law(error, ladder)
        law_text = f"{by_law:10.2f} {by_law / seconds:7.2f}" if by_law else f"{'n/a':>10s} {'n/a':>7s}"
        print(f"{'radiosity ' + quality:24s} {seconds:8.2f} {error:10.4f} {matched_text} {ratio} {law_text}")
    print("* extrapolated below the ladder along its two lowest-error points")


def reference_bakes(name: str, scene, objects, width: int, height: int, samples: int,
                    cache: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Cycles' two reference bakes (seeds 1 and 2) on the objects' Lightmap UV map and the seconds one took, read
    from the ``cache`` folder when an earlier run baked the same (``''``: always bake)."""
    from blender_setup import cycles_lightmap_bake
    path = Path(cache) / reference_file(name, scene, objects, f"{width}x{height}", samples) if cache else None
    if path is not None and path.exists():
        stored = np.load(path)
        return stored["first"], stored["second"], float(stored["seconds"])
    first, seconds = cycles_lightmap_bake(objects, "Lightmap", width, height, samples, seed=1)
    second, _ = cycles_lightmap_bake(objects, "Lightmap", width, height, samples, seed=2)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, first=first, second=second, seconds=seconds)
    return first, second, seconds


def reference_file(name: str, scene, objects, size: str, samples: int) -> str:
    """A reference bake's file name, keyed by what it depends on: Blender's version, the exported scene
    (geometry, materials, lights, world) and the UV map it is baked on."""
    import bpy
    digest = hashlib.sha1(bpy.app.version_string.encode())
    digest.update(scene.triangles.tobytes())
    digest.update(repr((scene.reflectance.tolist(), scene.emitted_radiance.tolist(), scene.lights,
                        scene.world)).encode())
    for obj in objects:
        digest.update(obj.name.encode() + triangle_uvs(obj.data, "Lightmap").tobytes())
    return f"{name}_{size}_{samples}_{digest.hexdigest()[:12]}.npz"


def cycles_seconds_at(error: float, cycles: list[tuple[float, float]]) -> tuple[float | None, bool]:
    """Cycles' time at the given error, log-log interpolated between the ladder's points; below the ladder's
    lowest error, extrapolated along the line through its two lowest-error points (Monte Carlo error falls as
    samples^-1/2, so that line is close to error ~ seconds^-1/2). Returns (seconds or None, extrapolated)."""
    errors = np.log([e for e, _ in cycles])
    seconds = np.log([s for _, s in cycles])
    if errors.min() <= np.log(error) <= errors.max():
        return float(np.exp(np.interp(np.log(error), errors, seconds))), False
    if np.log(error) < errors.min() and len(cycles) >= 2:
        slope = (seconds[1] - seconds[0]) / (errors[1] - errors[0])
        return float(np.exp(seconds[0] + slope * (np.log(error) - errors[0]))), True
    return None, False


def cycles_seconds_by_noise_law(error: float, ladder: list[tuple[int, float, float]]) -> float | None:
    """Cycles' time at the given error by its noise law: an unbiased Monte Carlo estimate's error falls as
    samples^-1/2, so from the ladder's lowest-error rung (N samples at error e) the error takes N (e / error)^2
    samples; Cycles' time is a fixed cost (scene and BVH) plus a cost per sample, both fitted by least squares to
    the ladder's (samples, seconds). None with fewer than two rungs."""
    if len(ladder) < 2:
        return None
    samples, seconds, errors = (np.array(column, dtype=np.float64) for column in zip(*ladder))
    per_sample, fixed = np.polyfit(samples, seconds, 1)
    lowest = errors.argmin()
    return float(fixed + per_sample * samples[lowest] * (errors[lowest] / error) ** 2)


if __name__ == "__main__":
    main()
