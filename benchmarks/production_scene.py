"""Production-scale bakes: time, peak memory and error against Cycles on the procedural courtyard.

    .venv/bin/python benchmarks/production_scene.py [--triangles 250000,500000,1000000]
        [--qualities draft,medium] [--targets lightmap,vertex_colors] [--compare-triangles 250000]
        [--compare-density 6] [--samples 64,128,256] [--reference 256] [--cache benchmarks/cache]

Part 1, scaling: sample_blends/courtyard.py makes the courtyard at each triangle count (same layout, finer
tessellation and more props); each quality and target is baked by the command line in a child process, as a user
would run it, with the default density. Prints the wall time, the child's peak resident memory, and the solve's
pieces (input triangles after clipping), elements, tree nodes and links, and the lightmap's texels.

Part 2, error: at ``--compare-triangles``, each quality bakes a lightmap at ``--compare-density`` texels per metre
(one density gives every quality the same UV layout), then Cycles' Diffuse pass (Direct + Indirect, no Color) is
baked on that UV map: twice at ``--reference`` samples (seeds 1 and 2; their mean is the reference and their
difference its noise, removed from every squared error; kept in ``--cache`` for the next run on the same scene
and UV map) and once at each of ``--samples``. The error is the
relative RMSE over the texels Cycles bakes, and Cycles' time at each of our errors is read along the ladder and by
Cycles' noise law, as in benchmarks/lightmap_vs_cycles.py (linked duplicates past the first are left out: Cycles
bakes a shared mesh's UV map once; so are texels pushed out of closed geometry, and texels Cycles leaves unbaked,
0 in both reference bakes). The table is printed twice:
over all those texels, and without those on coplanar overlaps, where Cycles bakes two same-facing faces in one
plane black (benchmarks/coplanar_overlaps.py). Then the texels over twice Cycles plus four times its noise (light
leaks, issue 14's bound along decals and contacts), in all and per kind of object with its error and mean bias.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "addon"))
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "sample_blends"))


def courtyard_file(triangles: int, folder: Path) -> Path:
    """The courtyard at ``triangles`` saved as a .blend in ``folder`` (made by a child process: saving resets
    this process's Blender data)."""
    path = folder / f"courtyard_{triangles}.blend"
    if not path.exists():
        subprocess.run([sys.executable, str(ROOT / "sample_blends" / "courtyard.py"), str(path),
                        "--triangles", str(triangles)], check=True, stdout=subprocess.DEVNULL)
    return path


def command_line_bake(scene_file: Path, quality: str, target: str, folder: Path) -> dict:
    """Bake with the command line in a child process; returns its report plus wall seconds and peak RSS."""
    report_file = folder / f"{scene_file.stem}_{quality}_{target}.json"
    (folder / f"{quality}_{target}").mkdir(exist_ok=True)
    command = [sys.executable, "-m", "radiosity_addon", "bake", str(scene_file),
               "-o", str(folder / f"{scene_file.stem}_{quality}_{target}.blend"), "--report", str(report_file),
               "--quality", quality, "--target", target, "--lightmap-dir", str(folder / f"{quality}_{target}")]
    started = time.perf_counter()
    child = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    _, status, usage = os.wait4(child.pid, 0)
    seconds = time.perf_counter() - started
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{' '.join(command)} failed:\n{child.stderr.read()}")
    report = json.loads(report_file.read_text())
    report["wall_seconds"] = seconds
    report["peak_rss_gib"] = usage.ru_maxrss * 1024 / 2 ** 30  # Linux reports kilobytes; GiB, as the estimate
    return report


def scaling_table(counts: list[int], qualities: list[str], targets: list[str], folder: Path) -> None:
    print(f"{'triangles':>10s} {'quality':8s} {'target':14s} {'wall s':>8s} {'peak GiB':>8s} {'est. GiB':>8s} "
          f"{'pieces':>8s} {'elements':>9s} {'nodes':>7s} {'links':>9s} {'texels':>9s}")
    for count in counts:
        scene_file = courtyard_file(count, folder)
        for quality in qualities:
            for target in targets:
                report = command_line_bake(scene_file, quality, target, folder)
                solve = report["solve"]
                texels = report["lightmap"]["texels"] if "lightmap" in report else 0
                print(f"{count:10d} {quality:8s} {target:14s} {report['wall_seconds']:8.1f} "
                      f"{report['peak_rss_gib']:8.2f} {report['memory']['estimated_gb']:8.2f} "
                      f"{solve['pieces']:8d} {solve['element_sides']:9d} "
                      f"{solve['nodes']:7d} {solve['links']:9d} {texels:9d}", flush=True)


def error_table(count: int, qualities: list[str], density: float, samples: list[int], reference_samples: int,
                folder: Path, cache: str) -> None:
    import bpy
    from blender_setup import cycles_lightmap_bake, lightmap_bake, load_extension, uv_coverage
    from lightmap_vs_cycles import print_against_cycles, reference_bakes, reference_noise_variance, relative_rmse
    package = load_extension()
    package.register()
    from radiosity_baker.radiosity_addon.lightmaps import OFFSET_PROPERTY
    from coplanar_overlaps import coplanar_overlap_texels
    scene_file = courtyard_file(count, folder)
    ours = {}
    for quality in qualities:
        bpy.ops.wm.open_mainfile(filepath=str(scene_file))
        (folder / "compare").mkdir(exist_ok=True)
        bake, report, seconds = lightmap_bake(quality, folder / "compare", texels_per_metre=density,
                                              lightmap_padding=2)
        page, = bake.lightmaps  # one page at this density
        ours[quality] = (page.light.astype(np.float64), seconds)
        height, width = page.light.shape[:2]
        moved = page.moved
        overlap = coplanar_overlap_texels(bake.export.scene, *bake.lightmap_plan.page_triangles[0], width, height)
    objects = [bpy.data.objects[entry["name"]] for entry in report["objects"] if entry["uv_map"]]
    objects = [obj for obj in objects if OFFSET_PROPERTY not in obj]
    first, second, reference_seconds = reference_bakes(f"courtyard_{count}", bake.export.scene, objects, width,
                                                       height, reference_samples, cache)
    baked = (first.max(axis=-1) > 0) | (second.max(axis=-1) > 0)  # Cycles' rasteriser misses slivers' texels
    mask = uv_coverage(objects, "Lightmap", width, height) & ~moved & baked
    reference = 0.5 * (first + second)
    ladder = [(spp,) + cycles_lightmap_bake(objects, "Lightmap", width, height, spp, seed=3) for spp in samples]
    for compared, which in ((mask, "all texels"), (mask & ~overlap, "without texels on coplanar overlaps "
                                                                    "(benchmarks/coplanar_overlaps.py)")):
        variance = reference_noise_variance(first, second, compared)
        print(f"\ncourtyard {count} triangles, lightmap {width} x {height} ({density:g} texels/m), "
              f"{int(compared.sum())} texels compared on {len(objects)} objects, {which}; reference: 2 x Cycles "
              f"{reference_samples} spp ({reference_seconds:.1f} s each), its noise "
              f"{np.sqrt(variance) / reference[compared].mean():.4f} (removed from the errors below)")
        rows = [(spp, seconds, relative_rmse(light, reference, compared, variance)) for spp, light, seconds in ladder]
        print_against_cycles(rows, {quality: (relative_rmse(light, reference, compared, variance), seconds)
                                    for quality, (light, seconds) in ours.items()})
    noise = np.sqrt(reference_noise_variance(first, second, mask))
    too_bright = {quality: too_bright_texels(light, reference, noise) & mask for quality, (light, _) in ours.items()}
    print(f"\nover 2 x Cycles + 4 sigma (sigma {noise:.4f}, the reference's noise over all texels): " +
          ", ".join(f"{quality} {int(over.sum())}" for quality, over in too_bright.items()))
    kinds = {}  # objects by name without their number: "column north", "ceiling east", "crate"
    for obj in objects:
        kinds.setdefault(obj.name.rstrip("0123456789. "), []).append(obj)
    print(f"\n{'relative RMSE per kind':26s}" + "".join(f"{quality:>10s}" for quality in ours) + "   mean bias" +
          "   over 2 x Cycles + 4 sigma")
    for name, group in sorted(kinds.items()):
        own = uv_coverage(group, "Lightmap", width, height) & mask
        if own.sum() < 50:
            continue
        own_variance = reference_noise_variance(first, second, own)
        errors = [relative_rmse(light, reference, own, own_variance) for light, _ in ours.values()]
        bias = [light[own].mean() / reference[own].mean() - 1 for light, _ in ours.values()]
        print(f"{name:26s}" + "".join(f"{error:10.4f}" for error in errors) +
              "   " + " ".join(f"{b:+.3f}" for b in bias) +
              "   " + " ".join(f"{int((over & own).sum()):d}" for over in too_bright.values()))
    np.savez(folder / f"compare_{count}_{density:g}.npz", first=first, second=second, mask=mask, overlap=overlap,
             **{quality: light for quality, (light, _) in ours.items()})


def too_bright_texels(light: np.ndarray, reference: np.ndarray, noise: float) -> np.ndarray:
    """Texels whose light (mean of the channels) is over twice Cycles' plus four times its noise: where the issue
    counts a light leak (issue 14's target along decals and contacts)."""
    return light.mean(axis=-1) > 2.0 * reference.mean(axis=-1) + 4.0 * noise


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--triangles", default="250000,500000,1000000")
    parser.add_argument("--qualities", default="draft,medium")
    parser.add_argument("--targets", default="lightmap,vertex_colors")
    parser.add_argument("--compare-triangles", type=int, default=250_000, help="0: no comparison with Cycles")
    parser.add_argument("--compare-density", type=float, default=6.0, help="texels per metre")
    parser.add_argument("--samples", default="64,128,256")
    parser.add_argument("--reference", type=int, default=256)
    parser.add_argument("--folder", help="where scenes and bakes go (default: a new temporary folder)")
    parser.add_argument("--cache", default=str(ROOT / "benchmarks" / "cache"),
                        help="folder keeping the reference bakes between runs ('' to recompute)")
    args = parser.parse_args()
    folder = Path(args.folder or tempfile.mkdtemp())
    folder.mkdir(parents=True, exist_ok=True)
    qualities = args.qualities.split(",")
    if args.triangles:
        scaling_table([int(n) for n in args.triangles.split(",")], qualities, args.targets.split(","), folder)
    if args.compare_triangles:
        error_table(args.compare_triangles, qualities, args.compare_density,
                    [int(n) for n in args.samples.split(",")], args.reference, folder, args.cache)
    sys.stdout.flush()
    os._exit(0)  # bpy 4.2 crashes at interpreter teardown


if __name__ == "__main__":
    main()
