"""A third-party level against Cycles: the scenes in ../shared/scenes, baked as a new user would bake them.

    .venv/bin/python benchmarks/shared_scene.py [SCENE.blend] [--qualities draft,medium] [--reference 256]
        [--folder DIR] [--cache benchmarks/cache]

Each quality bakes a lightmap with the command line in a child process, at its default density (timed, with the
child's peak resident memory and the report's rays, links and stage times). Cycles' Diffuse pass (Direct +
Indirect, no Color) is then baked on the baked file's Lightmap UV map at the same resolution, twice at
``--reference`` samples (seeds 1 and 2: their mean is the reference, and its noise variance, a quarter of their
mean squared difference, is removed from every squared error; kept in ``--cache``). Compared are the texels whose
centre lies inside a chart triangle (blender_setup.uv_coverage) of every object baked into the page, linked
duplicates past the first left out (Cycles bakes a shared mesh's UV map once), and so are texels Cycles leaves
unbaked (0 in both bakes: its rasteriser misses centres in facets far thinner than a texel) and objects Cycles bakes
black (a mirror or glass has no diffuse lobe, where our lightmap holds the light that reaches it). Printed per quality:

- relative RMSE over those texels, the share of texels over twice Cycles plus 10% of the mean level (the issue's
  leak bound), the samples and seconds Cycles needs for its noise to fall to our error, and the worst texels'
  (ours, Cycles) values;
- the objects carrying most of the squared error, with their own relative RMSE and bias (per texel, its own noise
  removed: a quarter of the two bakes' squared difference there);
- the seam gap: along every UV seam between two faces within 30 degrees of each other, the lightmap read
  bilinearly on both sides at the same surface points (a quarter, half and three quarters along the edge), the
  mean absolute difference over the page's mean level.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "addon"))
sys.path.insert(0, str(ROOT / "benchmarks"))
SCENE = ROOT.parent / "shared" / "scenes" / "grey_white_room.blend"
LEAK_SHARE_OF_MEAN = 0.10   # a texel over 2 x Cycles + this share of the mean level counts as a leak
SEAM_FACE_ANGLE_DEG = 30.0  # seams between faces bent more than this are creases, where light may differ
NO_DIFFUSE_SHARE = 0.01     # objects Cycles bakes below this share of the mean level have no diffuse lobe (mirrors)
WORST_OBJECTS = 8
WORST_TEXELS = 5


def read_page(path: str) -> np.ndarray:
    """(height, width, 3) float64 light of an EXR page, row 0 at the bottom (as Blender's pixels)."""
    import OpenImageIO as oiio
    pixels = oiio.ImageInput.open(path)
    try:
        light = pixels.read_image(format="float")[..., :3]
    finally:
        pixels.close()
    return np.ascontiguousarray(light[::-1], dtype=np.float64)


def bilinear(light: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(k, 3) light read at (k, 2) UVs as a renderer reads a texture: bilinear between texel centres, clamped."""
    height, width = light.shape[:2]
    x = np.clip(uv[:, 0] * width - 0.5, 0, width - 1)
    y = np.clip(uv[:, 1] * height - 0.5, 0, height - 1)
    x0, y0 = np.minimum(x.astype(int), width - 2), np.minimum(y.astype(int), height - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    return ((1 - fx) * (1 - fy) * light[y0, x0] + fx * (1 - fy) * light[y0, x0 + 1] +
            (1 - fx) * fy * light[y0 + 1, x0] + fx * fy * light[y0 + 1, x0 + 1])


def seam_points(mesh, uv_map: str) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) UVs on each side of the mesh's UV seams at the same surface points: for every edge of two faces
    within SEAM_FACE_ANGLE_DEG whose ends have other UVs in one face than in the other, the points a quarter, half
    and three quarters along it."""
    loops = len(mesh.loops)
    vertex = np.empty(loops, dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", vertex)
    uv = np.empty(loops * 2, dtype=np.float64)
    mesh.uv_layers[uv_map].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    start = np.empty(len(mesh.polygons), dtype=np.int64)
    count = np.empty(len(mesh.polygons), dtype=np.int64)
    normal = np.empty(len(mesh.polygons) * 3)
    mesh.polygons.foreach_get("loop_start", start)
    mesh.polygons.foreach_get("loop_total", count)
    mesh.polygons.foreach_get("normal", normal)
    normal = normal.reshape(-1, 3)
    face = np.repeat(np.arange(len(start)), count)
    following = np.arange(loops) + 1
    last = start + count - 1
    following[last] = start
    a, b = vertex, vertex[following]
    swap = a > b
    key = np.where(swap, b, a) * (len(mesh.vertices) + 1) + np.where(swap, a, b)
    uv_low = np.where(swap[:, None], uv[following], uv)   # the UV at the lower-numbered vertex
    uv_high = np.where(swap[:, None], uv, uv[following])
    order = np.argsort(key, kind="stable")
    pair = np.flatnonzero(key[order][1:] == key[order][:-1])
    first, second = order[pair], order[pair + 1]
    bent = np.einsum("ij,ij->i", normal[face[first]], normal[face[second]]) < np.cos(np.radians(SEAM_FACE_ANGLE_DEG))
    apart = (np.abs(uv_low[first] - uv_low[second]).max(axis=1) > 1e-6) | \
            (np.abs(uv_high[first] - uv_high[second]).max(axis=1) > 1e-6)
    seam = np.flatnonzero(apart & ~bent)
    t = np.array([0.25, 0.5, 0.75])[None, :, None]
    sides = [(uv_low[edge][:, None] * (1 - t) + uv_high[edge][:, None] * t).reshape(-1, 2)
             for edge in (first[seam], second[seam])]
    return sides[0], sides[1]


def seam_gap(objects, light: np.ndarray, uv_map: str) -> tuple[float, int]:
    """(mean |difference| across the objects' UV seams / the page's mean level, seam points read)."""
    differences = []
    for obj in objects:
        one, other = seam_points(obj.data, uv_map)
        if len(one):
            differences.append(np.abs(bilinear(light, one) - bilinear(light, other)).mean(axis=1))
    if not differences:
        return 0.0, 0
    gaps = np.concatenate(differences)
    return float(gaps.mean() / light.reshape(-1, 3).mean()), len(gaps)


def measured_bake(scene_file: Path, quality: str, folder: Path, reuse: bool) -> dict:
    """production_scene.command_line_bake's report of the lightmap bake at ``quality``, kept in ``folder`` beside
    the bake; with ``reuse``, the one kept there by an earlier run, if any."""
    from production_scene import command_line_bake
    kept = folder / f"{scene_file.stem}_{quality}_measured.json"
    if reuse and kept.exists():
        return json.loads(kept.read_text())
    report = command_line_bake(scene_file, quality, "lightmap", folder)
    kept.write_text(json.dumps(report))
    return report


def compare_quality(quality: str, scene_file: Path, folder: Path, reference_samples: int, cache: str,
                    reuse: bool) -> None:
    import bpy
    from blender_setup import uv_coverage
    from lightmap_vs_cycles import reference_bakes, reference_noise_variance, relative_rmse
    report = measured_bake(scene_file, quality, folder, reuse)
    timings = ", ".join(f"{stage} {seconds:.0f} s" for stage, seconds in report["timings"].items())
    print(f"\n{scene_file.name} at {quality}: {report['wall_seconds']:.0f} s wall ({timings}; lightmap "
          f"{sum(report['lightmap']['timings'].values()):.0f} s), peak {report['peak_rss_gib']:.2f} GiB resident "
          f"(estimate {report['memory']['estimated_gb']:.2f} GiB, limit {report['memory']['limit_gb']:.1f} GiB), "
          f"{report['rays'] / 1e6:.0f} M rays, {report['solve'].get('links', 0) / 1e6:.1f} M links, "
          f"{report['elements']} elements, {report['lightmap']['texels']} texels")
    from radiosity_baker.radiosity_addon.export import export_scene
    from radiosity_baker.radiosity_addon.lightmaps import OFFSET_PROPERTY
    bpy.ops.wm.open_mainfile(filepath=str(folder / f"{scene_file.stem}_{quality}_lightmap.blend"))
    exported = export_scene(bpy.context).scene
    pages = {}
    for entry in report["objects"]:
        if entry["uv_map"] and OFFSET_PROPERTY not in bpy.data.objects[entry["name"]]:
            pages.setdefault(entry["image"], []).append(bpy.data.objects[entry["name"]])
    for image, objects in pages.items():
        light = read_page(image)
        height, width = light.shape[:2]
        first, second, cycles_seconds = reference_bakes(f"{scene_file.stem}_{quality}", exported, objects,
                                                        width, height, reference_samples, cache)
        reference = 0.5 * (first + second)
        baked = (first.max(axis=-1) > 0) | (second.max(axis=-1) > 0)
        own = {obj.name: uv_coverage([obj], "Lightmap", width, height) & baked for obj in objects}
        level = reference[np.logical_or.reduce(list(own.values()))].mean()
        black = [obj for obj in objects if reference[own[obj.name]].mean() < NO_DIFFUSE_SHARE * level]
        objects = [obj for obj in objects if obj not in black]
        mask = np.logical_or.reduce([own[obj.name] for obj in objects])
        variance = reference_noise_variance(first, second, mask)
        mean = reference[mask].mean()
        error = relative_rmse(light, reference, mask, variance)
        ours_grey, cycles_grey = light.mean(axis=-1), reference.mean(axis=-1)
        leak = mask & (ours_grey > 2 * cycles_grey + LEAK_SHARE_OF_MEAN * mean)
        gap, seam_count = seam_gap(objects, light, "Lightmap")
        print(f"page {Path(image).name} {width} x {height}, {int(mask.sum())} texels on {len(objects)} objects; "
              f"Cycles {reference_samples} spp {cycles_seconds:.0f} s per bake, its noise "
              f"{np.sqrt(variance) / mean:.4f} (removed); left out, as Cycles bakes no diffuse light on them: "
              f"{', '.join(obj.name for obj in black) or 'none'}")
        print(f"  relative RMSE {error:.4f}, bias {light[mask].mean() / mean - 1:+.4f}, texels over 2 x Cycles + "
              f"{LEAK_SHARE_OF_MEAN:.0%} of the mean: {int(leak.sum())} ({leak.sum() / mask.sum():.2%}), "
              f"seam gap {gap:.4f} of the mean ({seam_count} seam points)")
        # One bake's noise is twice the variance of the two bakes' mean; it falls as samples^-1/2.
        samples = reference_samples * 2 * variance / (error * mean) ** 2
        seconds = cycles_seconds * samples / reference_samples
        print(f"  Cycles reaches our error at about {samples:.0f} spp, {seconds:.0f} s on this page (its noise's "
              f"samples^-1/2 law from the {reference_samples} spp bakes; ours {report['wall_seconds']:.0f} s)")
        # Per texel, its own noise (a quarter of the two bakes' squared difference): a white sofa's texels are
        # noisier than the page's mean, and the page's variance left their noise in their objects' error.
        texel_variance = ((first - second) ** 2).mean(axis=-1) / 4.0
        squared = np.where(mask, ((light - reference) ** 2).mean(axis=-1) - texel_variance, 0.0)
        worst = np.argsort(squared.ravel())[::-1][:WORST_TEXELS]
        print("  worst texels (x, y: ours / Cycles): " + ", ".join(
            f"({k % width}, {k // width}: {ours_grey.ravel()[k]:.3f} / {cycles_grey.ravel()[k]:.3f})"
            for k in worst))
        rows = []
        for obj in objects:
            texels = own[obj.name] & mask
            if texels.any():
                rows.append((squared[texels].sum() / squared.sum(), obj.name, int(texels.sum()),
                             relative_rmse(light, reference, texels, float(texel_variance[texels].mean())),
                             light[texels].mean() / reference[texels].mean() - 1))
        print(f"  {'object':34s} {'share of squared error':>22s} {'texels':>7s} {'rel. RMSE':>10s} {'bias':>7s}")
        for share, name, texels, own_error, bias in sorted(rows, reverse=True)[:WORST_OBJECTS]:
            print(f"  {name[:34]:34s} {share:22.3f} {texels:7d} {own_error:10.4f} {bias:+7.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene", nargs="?", default=str(SCENE))
    parser.add_argument("--qualities", default="draft,medium")
    parser.add_argument("--reference", type=int, default=256, help="Cycles samples of each reference bake")
    parser.add_argument("--folder", help="where bakes go (default: a new temporary folder)")
    parser.add_argument("--reuse", action="store_true", help="compare the bakes an earlier run left in --folder")
    parser.add_argument("--cache", default=str(ROOT / "benchmarks" / "cache"),
                        help="folder keeping the reference bakes between runs ('' to recompute)")
    args = parser.parse_args()
    folder = Path(args.folder or tempfile.mkdtemp())
    folder.mkdir(parents=True, exist_ok=True)
    from blender_setup import load_extension
    load_extension().register()
    for quality in args.qualities.split(","):
        compare_quality(quality, Path(args.scene), folder, args.reference, args.cache, args.reuse)
        sys.stdout.flush()
    os._exit(0)  # bpy 4.2 crashes at interpreter teardown


if __name__ == "__main__":
    main()
