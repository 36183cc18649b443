"""Render a preview of a baked .blend: the add-on's material hookup makes every baked mesh emit its base colour x
its baked light (the lightmap if one was baked, else the colour attribute), which a Cycles render converges in a
few samples. Usage: python scripts/render_preview.py BAKED.blend OUT.png

The .blend is not saved: the hooked-up materials exist only in this process.
"""
import runpy
import sys
from pathlib import Path

import bpy

ROOT = Path(__file__).resolve().parents[1]


def main(blend: str, png: str) -> None:
    package = runpy.run_path(str(ROOT / "radiosity_addon" / "__main__.py"), run_name="loader")["load_package"]()
    package.register()
    bpy.ops.wm.open_mainfile(filepath=blend)
    assert bpy.ops.radiosity.preview() == {"FINISHED"}, "nothing baked in this file"
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 8
    scene.cycles.max_bounces = 0
    scene.render.filepath = png
    scene.render.image_settings.file_format = "PNG"
    bpy.ops.render.render(write_still=True)
    print(f"wrote {png}")


if __name__ == "__main__":
    main(*sys.argv[1:])
