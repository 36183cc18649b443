"""Helpers for add-on tests with the bpy module: load the extension package, build scenes, bake with Cycles."""
from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def load_extension():
    """The repository root imported as the package ``radiosity_baker`` (as Blender imports the extension)."""
    return runpy.run_path(str(ROOT / "radiosity_addon" / "__main__.py"), run_name="loader")["load_package"]()


def make_cornell_box(folder: Path) -> Path:
    runpy.run_path(str(ROOT / "sample_blends" / "make_samples.py"), run_name="samples")["cornell_box"](
        folder / "cornell_box.blend")
    return folder / "cornell_box.blend"


def corner_colors(mesh, name: str) -> np.ndarray:
    """(loops, 3) RGB of a CORNER colour attribute."""
    attribute = mesh.color_attributes[name]
    rgba = np.empty(len(attribute.data) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", rgba)
    return rgba.reshape(-1, 4)[:, :3].astype(np.float64)


def cycles_vertex_bake(objects, samples: int, name: str = "Cycles") -> None:
    """Cycles' Diffuse bake (Direct + Indirect, no Color) into a new FLOAT_COLOR corner attribute of each object."""
    import bpy
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.seed = 1
    for obj in scene.objects:
        obj.select_set(False)
    for obj in objects:
        attribute = obj.data.color_attributes.new(name, "FLOAT_COLOR", "CORNER")
        obj.data.color_attributes.active_color = attribute
        obj.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT"}, target="VERTEX_COLORS")


def grid_plane(name: str, size: float, cuts: int, location=(0.0, 0.0, 0.0), colour=(0.5, 0.5, 0.5)):
    """A size x size plane of cuts x cuts quads facing +Z, with a Principled material of the given base colour."""
    import bpy
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=cuts, y_subdivisions=cuts, size=size, location=location)
    obj = bpy.context.active_object
    obj.name = name
    material = bpy.data.materials.new(f"{name} material")
    material.use_nodes = True
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*colour, 1.0)
    obj.data.materials.append(material)
    return obj


def add_light(kind: str, location, energy: float, **data):
    import bpy
    bpy.ops.object.light_add(type=kind, location=location)
    light = bpy.context.active_object
    light.data.energy = energy
    for key, value in data.items():
        setattr(light.data, key, value)
    return light
