"""The direct term of each light type and of mesh emission, through the whole export path, against a Cycles
vertex-colour bake of the same plane (Diffuse, Direct + Indirect, no Color; the plane alone has no indirect light).

Tolerance 3% on the plane's mean and 3% relative RMSE over its vertices (Cycles at 1024 samples per vertex).
"""
import bpy
import numpy as np
import pytest

from blender_setup import add_light, corner_colors, cycles_vertex_bake, grid_plane

LIGHTS = {
    "point": ("POINT", (0.3, -0.2, 1.0), 100.0, {"shadow_soft_size": 0.0}),
    "sized point": ("POINT", (0.3, -0.2, 1.0), 100.0, {"shadow_soft_size": 0.25}),
    "spot": ("SPOT", (0.0, 0.0, 1.5), 300.0, {"spot_size": np.radians(70), "spot_blend": 0.3,
                                              "shadow_soft_size": 0.0}),
    "sun": ("SUN", (0.0, 0.0, 3.0), 2.0, {"angle": 0.0}),
    "area square": ("AREA", (0.2, 0.0, 0.8), 60.0, {"shape": "SQUARE", "size": 0.6}),
    "area disk": ("AREA", (0.2, 0.0, 0.8), 60.0, {"shape": "DISK", "size": 0.6}),
    "area rectangle": ("AREA", (0.2, 0.0, 0.8), 60.0, {"shape": "RECTANGLE", "size": 0.8, "size_y": 0.3}),
}


def bake_both(scene, plane):
    settings = scene.radiosity
    settings.quality = "CUSTOM"
    settings.element_size, settings.patch_size = 0.0625, 0.5
    settings.adaptive_passes, settings.light_samples = 0, 6
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    cycles_vertex_bake([plane], samples=1024)
    return corner_colors(plane.data, "Radiosity"), corner_colors(plane.data, "Cycles")


def assert_matches_cycles(ours, cycles):
    assert ours.mean(axis=0) == pytest.approx(cycles.mean(axis=0), rel=0.03)
    assert np.sqrt(np.mean((ours - cycles) ** 2)) <= 0.03 * cycles.mean()


@pytest.mark.parametrize("name", list(LIGHTS))
def test_light_direct_term_matches_cycles(empty_scene, name):
    kind, location, energy, data = LIGHTS[name]
    plane = grid_plane("Floor", 2.0, 16)
    light = add_light(kind, location, energy, **data)
    light.rotation_euler = (0.3, 0.2, 0.0) if kind in ("SPOT", "AREA", "SUN") else (0.0, 0.0, 0.0)
    assert_matches_cycles(*bake_both(empty_scene, plane))


def test_mesh_emission_matches_cycles(empty_scene):
    """A Principled emitter (strength 5) 0.8 m above the plane, facing it (it is baked too; only the plane is
    compared)."""
    plane = grid_plane("Floor", 2.0, 16)
    bpy.ops.mesh.primitive_plane_add(size=0.6, location=(0.2, 0.0, 0.8), rotation=(np.pi, 0.0, 0.0))
    emitter = bpy.context.active_object
    material = bpy.data.materials.new("Glow")
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.8, 0.5, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 5.0
    emitter.data.materials.append(material)
    assert_matches_cycles(*bake_both(empty_scene, plane))
