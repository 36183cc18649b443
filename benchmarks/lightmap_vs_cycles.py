"""Lightmap speed and error against Cycles on the same UV map, in one run on one machine.

    .venv/bin/python benchmarks/lightmap_vs_cycles.py [--resolution 128] [--qualities DRAFT,MEDIUM,HIGH]
                                                      [--samples 4,16,64,256] [--reference 2048]

Bakes the Cornell box sample with each of our quality presets into a lightmap, then bakes Cycles' Diffuse pass
(Direct + Indirect, no Color, CPU) on our UV map and resolution at increasing samples and once at ``--reference``
samples as the converged reference. Prints a table: seconds and relative RMSE over the texels Cycles bakes (the
ceiling, whose rim sits 0.5 mm above the light's back face, left out), and for each of our presets the Cycles
time needed to reach the same error (interpolated in log-log between the sample counts).
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

COMPARED = ["floor", "back wall", "left wall", "right wall", "short block", "tall block"]


def relative_rmse(values, reference, mask) -> float:
    return float(np.sqrt(np.mean((values[mask] - reference[mask]) ** 2)) / reference[mask].mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--qualities", default="DRAFT,MEDIUM,HIGH")
    parser.add_argument("--samples", default="4,16,64,256")
    parser.add_argument("--reference", type=int, default=2048)
    args = parser.parse_args()
    import bpy
    from blender_setup import cycles_lightmap_bake, load_extension, make_cornell_box, uv_coverage
    package = load_extension()
    package.register()
    job = package.radiosity_addon.job
    from radiosity_baker.radiosity_addon.lightmaps import LightmapOptions
    from radiosity_baker.radiosity_addon.presets import UserSettings
    folder = Path(tempfile.mkdtemp())
    scene_file = make_cornell_box(folder)
    options = LightmapOptions(resolution=args.resolution, padding=2)
    ours = {}
    for quality in args.qualities.split(","):
        bpy.ops.wm.open_mainfile(filepath=str(scene_file))
        started = time.perf_counter()
        bake = job.prepare(bpy.context, UserSettings(quality), job.Outputs("LIGHTMAP", lightmap=options,
                                                                          lightmap_folder=str(folder)))
        job.solve(bake, lambda fraction, message: None, lambda: False)
        ours[quality] = (bake.lightmap.light.astype(np.float64), time.perf_counter() - started)
        job.apply(bake)  # the UV map Cycles bakes on (identical for every preset: same layout)
    objects = [bpy.data.objects[name] for name in COMPARED]
    size = args.resolution
    mask = uv_coverage(objects, "Lightmap", size, size)
    reference, reference_seconds = cycles_lightmap_bake(objects, "Lightmap", size, size, args.reference)
    rows = []
    for samples in [int(s) for s in args.samples.split(",")]:
        light, seconds = cycles_lightmap_bake(objects, "Lightmap", size, size, samples)
        rows.append((f"Cycles {samples} spp", seconds, relative_rmse(light, reference, mask)))
    cycles = sorted((error, seconds) for _, seconds, error in rows)
    print(f"Cornell box lightmap {size} x {size}, {int(mask.sum())} texels compared; reference Cycles "
          f"{args.reference} spp ({reference_seconds:.1f} s)")
    print(f"{'bake':24s} {'seconds':>8s} {'rel. RMSE':>10s} {'Cycles s at same error':>24s} {'ratio':>7s}")
    for name, seconds, error in rows:
        print(f"{name:24s} {seconds:8.2f} {error:10.4f}")
    for quality, (light, seconds) in ours.items():
        error = relative_rmse(light, reference, mask)
        matched = cycles_seconds_at(error, cycles)
        ratio = f"{matched / seconds:7.2f}" if matched else "    n/a"
        matched_text = f"{matched:24.2f}" if matched else f"{'(beyond the ladder)':>24s}"
        print(f"{'radiosity ' + quality.lower():24s} {seconds:8.2f} {error:10.4f} {matched_text} {ratio}")
    sys.stdout.flush()
    os._exit(0)  # bpy 4.2 crashes at interpreter teardown


def cycles_seconds_at(error: float, cycles: list[tuple[float, float]]) -> float | None:
    """Cycles' time at the given error, log-log interpolated between the ladder's points (None outside it)."""
    errors = np.log([e for e, _ in cycles])
    seconds = np.log([s for _, s in cycles])
    if not errors.min() <= np.log(error) <= errors.max():
        return None
    return float(np.exp(np.interp(np.log(error), errors, seconds)))


if __name__ == "__main__":
    main()
