"""Baking inside Blender: evaluated geometry (modifiers, instances), a cancelled bake, and what a bake may change."""
import bpy
import numpy as np
import pytest

from blender_setup import add_light, corner_colors, grid_plane


def scene_state():
    """Everything a bake must not change unless it finishes: attributes, UV maps, materials per mesh."""
    return {mesh.name: (sorted(a.name for a in mesh.color_attributes), sorted(uv.name for uv in mesh.uv_layers),
                        [m.name for m in mesh.materials], len(mesh.loops)) for mesh in bpy.data.meshes}


def test_cancelled_bake_changes_nothing(empty_scene, extension):
    floor = grid_plane("Floor", 2.0, 8)
    floor.data.color_attributes.new("Paint", "BYTE_COLOR", "CORNER")
    add_light("POINT", (0, 0, 1.5), 100.0)
    before = scene_state()
    job_module = extension.radiosity_addon.job
    from radiosity_baker.core import BakeCancelled
    settings = bpy.context.scene.radiosity
    job = job_module.prepare(bpy.context, settings.user_settings(), "")
    calls = []
    with pytest.raises(BakeCancelled):
        job_module.solve(job, lambda f, m: None, lambda: calls.append(1) or len(calls) > 2)
    assert scene_state() == before


def test_cancelled_while_lighting_corners_changes_nothing(empty_scene, extension, monkeypatch):
    """Esc between two objects' corners (the colour attributes are lit in the solve, batches of objects at a
    time; one object per batch here): the bake stops there and the meshes are as they were."""
    tiles = [grid_plane(name, 1.0, 2, location=(x, 0.0, 0.0)) for name, x in (("Left", -1.0), ("Right", 1.0))]
    tiles[0].data.color_attributes.new("Paint", "BYTE_COLOR", "CORNER")
    add_light("POINT", (0, 0, 1.5), 100.0)
    before = scene_state()
    monkeypatch.setattr(extension.radiosity_addon.writeback, "CORNERS_PER_BATCH", 1)
    job_module = extension.radiosity_addon.job
    from radiosity_baker.core import BakeCancelled
    job = job_module.prepare(bpy.context, bpy.context.scene.radiosity.user_settings(), "")
    messages = []
    with pytest.raises(BakeCancelled, match="colour attributes"):
        job_module.solve(job, lambda fraction, message: messages.append(message),
                         lambda: any(message.startswith("Vertex colours") for message in messages))
    assert messages[-1] == "Vertex colours: 1 of 2 objects lit" and scene_state() == before


def test_rebake_replaces_only_our_attribute(empty_scene):
    floor = grid_plane("Floor", 2.0, 4)
    floor.data.color_attributes.new("Paint", "BYTE_COLOR", "CORNER")
    add_light("POINT", (0, 0, 1.5), 100.0)
    empty_scene.radiosity.quality = "DRAFT"
    uv_maps = [uv.name for uv in floor.data.uv_layers]
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    assert sorted(a.name for a in floor.data.color_attributes) == ["Paint", "Radiosity"]
    assert [uv.name for uv in floor.data.uv_layers] == uv_maps == ["UVMap"]


def test_user_attribute_with_our_name_is_refused(empty_scene):
    floor = grid_plane("Floor", 2.0, 4)
    floor.data.color_attributes.new("Radiosity", "BYTE_COLOR", "CORNER")
    add_light("POINT", (0, 0, 1.5), 100.0)
    with pytest.raises(RuntimeError, match="did not make"):
        bpy.ops.radiosity.bake()


def test_modifiers_are_baked_on_the_evaluated_geometry(empty_scene):
    """A Solidify modifier gives the plane thickness: the bake sees the evaluated mesh, and the original mesh
    (fewer loops) still gets a value for every loop, lit from above."""
    floor = grid_plane("Floor", 2.0, 8)
    modifier = floor.modifiers.new("Thick", "SOLIDIFY")
    modifier.thickness = 0.1
    add_light("POINT", (0, 0, 1.5), 100.0)
    empty_scene.radiosity.quality = "DRAFT"
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    light = corner_colors(floor.data, "Radiosity")
    assert len(light) == len(floor.data.loops)
    top = 100 / (4 * np.pi * 1.5 ** 2) / np.pi  # under the lamp, on the top face at z = 0
    assert light.max() == pytest.approx(top, rel=0.1)


def test_collection_instance_casts_shadow_and_receives_light(empty_scene):
    """A collection instance of a block is part of the baked scene: it shadows the floor under it, and the
    radiosity mesh holds lit elements on it."""
    floor = grid_plane("Floor", 4.0, 16)
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(0, 0, 0.0))
    block = bpy.context.active_object
    collection = bpy.data.collections.new("Block")
    collection.objects.link(block)
    empty_scene.collection.objects.unlink(block)
    instance = bpy.data.objects.new("Block instance", None)
    instance.instance_type, instance.instance_collection = "COLLECTION", collection
    instance.location = (0.0, 0.0, 0.5)
    empty_scene.collection.objects.link(instance)
    add_light("POINT", (0, 0, 2.0), 200.0)
    settings = empty_scene.radiosity
    settings.quality, settings.create_radiosity_mesh = "DRAFT", True
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    positions = np.array([v.co for v in floor.data.vertices])
    loops = np.array([loop.vertex_index for loop in floor.data.loops])
    light = corner_colors(floor.data, "Radiosity")[:, 0]
    under = np.linalg.norm(positions[loops][:, :2], axis=1) < 0.1
    assert light[under].max() < 0.1 * light.max()
    mesh = next(o for o in bpy.data.objects if o.get("radiosity_mesh")).data
    corners = np.array([mesh.vertices[loop.vertex_index].co for loop in mesh.loops])
    on_block_top = np.abs(corners[:, 2] - 0.75) < 1e-4
    assert on_block_top.any() and corner_colors(mesh, "Radiosity")[on_block_top].min() > 0


def test_a_bake_does_not_see_the_radiosity_mesh_of_the_last(empty_scene, extension):
    """The Radiosity Mesh is a copy of the baked surfaces: a second bake leaves it out of the scene (it once lit
    the floor again from a coplanar copy: corners up to 78% off), so baking twice gives the same colours."""
    floor = grid_plane("Floor", 2.0, 2)
    grid_plane("Roof", 1.0, 1, location=(0, 0, 1.0))
    add_light("POINT", (0.6, 0, 1.5), 100.0)
    settings = empty_scene.radiosity
    settings.quality, settings.create_radiosity_mesh = "DRAFT", True
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    first = corner_colors(floor.data, "Radiosity")
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    assert corner_colors(floor.data, "Radiosity") == pytest.approx(first, rel=1e-6, abs=1e-9)


def test_image_texture_is_averaged_per_element(empty_scene, extension):
    """A 2 x 2 checker image (0.1 / 0.7, linear) on the base colour: elements inside a square reflect that square,
    not the image mean (so a checker floor bleeds the colour it really has under each element), through the
    default Principled BSDF's specular layer (core.bsdf: S + (1 - S) base at roughness 0.5)."""
    floor = grid_plane("Floor", 2.0, 1)
    image = bpy.data.images.new("checker", 2, 2, float_buffer=True)
    image.pixels.foreach_set(np.array([[0.1] * 3 + [1], [0.7] * 3 + [1], [0.7] * 3 + [1], [0.1] * 3 + [1]],
                                      dtype=np.float32).ravel())
    material = floor.data.materials[0]
    texture = material.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    material.node_tree.links.new(texture.outputs["Color"],
                                 material.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    add_light("POINT", (0, 0, 1.5), 100.0)
    from radiosity_baker.core.mesh import build_mesh, elements_of
    export = extension.radiosity_addon.export.export_scene(bpy.context)
    elements = elements_of(build_mesh(export.scene, 0.5, 0.25), export.scene)
    x, y = elements.centroid[:, 0], elements.centroid[:, 1]
    inside = (np.abs(x) > 0.2) & (np.abs(y) > 0.2)
    from radiosity_baker.core.bsdf import principled_reflectance
    offset, scale = principled_reflectance(0.5, 0.0, 1.5, 0.5, 0.0)
    expected = offset + scale * np.where((x < 0) == (y < 0), 0.1, 0.7)
    assert elements.reflectance[inside, 0] == pytest.approx(expected[inside])
    assert export.scene.materials[0].reflectance == pytest.approx((offset + scale * 0.4,) * 3)
