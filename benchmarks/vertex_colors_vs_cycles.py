"""Vertex colours against Cycles' own vertex bake, corner by corner, in one run on one machine.

    .venv/bin/python benchmarks/vertex_colors_vs_cycles.py [--scenes quad_room,quad_room_diffuse,cornell_box,room]
                      [--quality MEDIUM] [--samples 1024]

Scenes: ``quad_room``, a 2 m room whose six walls are single quads (every vertex on a corner or an edge of the
room), a red and a green wall, a 0.6 m block on the floor and a 60 W lamp, with Blender's default Principled BSDF;
``quad_room_diffuse``, the same with Specular IOR Level 0 (a purely diffuse reflector); and the Cornell box and room
samples. Each is baked with each indirect method (Automatic, Final Gather, Interpolate), then Cycles' Diffuse bake
(Direct + Indirect, no Color, CPU, 64 bounces) into a corner attribute twice (two seeds): their mean is the
reference and their difference its noise, which is removed from the squared error. Prints our seconds (the whole
bake: export, solve, writing), relative RMSE, mean bias, and the 95th percentile and the worst of the corners'
relative errors where Cycles has light. Left out, as in tests/addon/test_cornell_vs_cycles.py: the Cornell box's
ceiling (its rim sits 0.5 mm above the light's back face) and floor corners under its blocks (Cycles bakes them
dark; we take the visible floor's).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "addon"))
from blender_setup import corner_colors, cycles_vertex_bake, load_extension, make_sample, quad_room  # noqa: E402

METHODS = ("auto", "gather", "interpolate")


def sample(name: str, folder: Path) -> list[str]:
    import bpy
    bpy.ops.wm.open_mainfile(filepath=str(make_sample(name, folder)))
    return [obj.name for obj in bpy.context.scene.objects if obj.type == "MESH" and obj.visible_get()
            and not (name == "cornell_box" and obj.name in ("ceiling", "light"))]


def compared_corners(scene_name: str, objects) -> np.ndarray:
    """(corners,) True for the corners compared (the Cornell box's floor corners under its blocks are not)."""
    from test_cornell_vs_cycles import under_the_blocks
    return np.concatenate([~under_the_blocks(obj) if scene_name == "cornell_box" and obj.name == "floor"
                           else np.ones(len(obj.data.loops), dtype=bool) for obj in objects])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenes", default="quad_room,quad_room_diffuse,cornell_box,room")
    parser.add_argument("--quality", default="MEDIUM")
    parser.add_argument("--samples", type=int, default=1024)
    args = parser.parse_args()
    import bpy
    load_extension().register()
    from radiosity_baker.radiosity_addon import job
    from radiosity_baker.radiosity_addon.settings import UserSettings
    folder = Path(tempfile.mkdtemp())
    print("| scene | corners | indirect | our seconds | rel. RMSE | mean bias | p95 corner | worst corner |")
    print("|---|---:|---|---:|---:|---:|---:|---:|")
    for scene_name in args.scenes.split(","):
        names = quad_room(scene_name.endswith("diffuse")) if scene_name.startswith("quad_room") else \
            sample(scene_name, folder)
        ours = {}
        for method in METHODS:
            started = time.perf_counter()
            work = job.prepare(bpy.context, UserSettings(quality=args.quality, vertex_indirect=method,
                                                         attribute_name=f"Ours {method}", own_mesh_copies=True), "")
            job.solve(work, lambda fraction, message: None, lambda: False)
            job.write_outputs(work)
            seconds = time.perf_counter() - started
            objects = [bpy.data.objects[name] for name in names]
            ours[method] = (np.concatenate([corner_colors(o.data, f"Ours {method}") for o in objects]), seconds)
        objects = [bpy.data.objects[name] for name in names]
        for seed in (1, 2):
            cycles_vertex_bake(objects, args.samples, f"Cycles {seed}", seed)
        first, second = (np.concatenate([corner_colors(obj.data, f"Cycles {seed}") for obj in objects])
                         for seed in (1, 2))
        keep = compared_corners(scene_name, objects)
        reference, noise = (first + second)[keep] / 2, np.mean((first - second)[keep] ** 2) / 4
        for method in METHODS:
            light, seconds = ours[method][0][keep], ours[method][1]
            error = np.sqrt(max(np.mean((light - reference) ** 2) - noise, 0.0)) / reference.mean()
            lit = reference.mean(axis=1) > 1e-6  # per-corner errors where Cycles has light
            corner = np.abs(light - reference)[lit].mean(axis=1) / reference[lit].mean(axis=1)
            print(f"| {scene_name} | {len(reference)} | {method} | {seconds:.1f} | {error:.2%} | "
                  f"{light.mean() / reference.mean() - 1:+.2%} | {np.percentile(corner, 95):.1%} | "
                  f"{corner.max():.1%} |")
        print(f"(Cycles {args.samples} spp x 2, its noise {np.sqrt(noise) / reference.mean():.2%}, removed)")


if __name__ == "__main__":
    main()
