"""What Cycles renders where two objects' faces overlap in one plane, facing the same way.

    .venv/bin/python benchmarks/coplanar_render.py [--samples 64]

Two 2 m wide quads of two objects overlap by 1 m in one plane under a sun; Cycles renders them from above with an
orthographic camera. Prints the rendered value (red channel, scene-linear) along the row through the middle, and
its mean over each quad alone and over the overlap. Cycles' bake gives such texels no light (its rays from one
face meet the other at distance zero: benchmarks/coplanar_overlaps.py); this shows whether its render does too.
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

WIDTH_PX, HEIGHT_PX = 84, 40
VIEW_WIDTH_M = 4.2  # the camera's view: 5 cm pixels from x = -2.1 m to 2.1 m


def overlapping_quads(bpy) -> None:
    """Quad A from x = -2 to 0.5 m and quad B from x = -0.5 to 2 m, both in z = 0 facing up, and a sun."""
    scene = bpy.context.scene
    for name, (x0, x1) in {"A": (-2.0, 0.5), "B": (-0.5, 2.0)}.items():
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata([(x0, -1, 0), (x1, -1, 0), (x1, 1, 0), (x0, 1, 0)], [], [(0, 1, 2, 3)])
        scene.collection.objects.link(bpy.data.objects.new(name, mesh))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.3, 0.2, 0.0)
    scene.collection.objects.link(sun)
    scene.world = bpy.data.worlds.new("Black")


def render_row(bpy, samples: int, folder: Path) -> np.ndarray:
    """(WIDTH_PX,) the red channel of the rendered image's middle row, left to right."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples = "CPU", samples
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", VIEW_WIDTH_M
    camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y = WIDTH_PX, HEIGHT_PX
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(folder / "render.exr")
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(scene.render.filepath)
    pixels = np.array(image.pixels[:]).reshape(HEIGHT_PX, WIDTH_PX, 4)  # bottom row first
    return pixels[HEIGHT_PX // 2, :, 0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--samples", type=int, default=64)
    args = parser.parse_args()
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    overlapping_quads(bpy)
    with tempfile.TemporaryDirectory() as folder:
        row = render_row(bpy, args.samples, Path(folder))
    x = (np.arange(WIDTH_PX) + 0.5) * VIEW_WIDTH_M / WIDTH_PX - VIEW_WIDTH_M / 2
    parts = {"A alone (-1.9 to -0.6 m)": (x > -1.9) & (x < -0.6), "overlap (-0.4 to 0.4 m)": np.abs(x) < 0.4,
             "B alone (0.6 to 1.9 m)": (x > 0.6) & (x < 1.9)}
    print(f"Cycles render, {args.samples} spp, middle row (x in m: value)")
    print("  ".join(f"{a:+.2f}: {v:.3f}" for a, v in zip(x[::6], row[::6])))
    for name, where in parts.items():
        print(f"{name:28s} mean {row[where].mean():.3f}")


if __name__ == "__main__":
    main()
