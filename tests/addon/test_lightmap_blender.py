"""Lightmaps in Blender: the command line's lightmap outputs, what a lightmap bake may change, determinism, and
agreement with Cycles' Diffuse bake (Direct + Indirect, no Color) on the same UV map and resolution."""
import filecmp
import json

import bpy
import numpy as np
import pytest

from blender_setup import add_light, cycles_lightmap_bake, grid_plane, make_cornell_box, uv_coverage
SIZE = 128

from test_cli import run_cli, scene_file  # noqa: F401 (a fixture)


def test_cli_lightmap_outputs_and_determinism(scene_file, tmp_path):
    """--target both: each baked object reports its UV map, image and resolution; its existing UV map is kept;
    baking twice gives byte-identical EXR files."""
    files = []
    for run in ("a", "b"):
        folder = tmp_path / run
        folder.mkdir()
        code, stderr = run_cli(scene_file, "-o", folder / "out.blend", "--report", folder / "report.json",
                               "--quality", "draft", "--target", "both", "--resolution", "64")
        assert code == 0, stderr
        files.append(folder / "Radiosity_Lightmap.exr")
    report = json.loads((tmp_path / "a" / "report.json").read_text())
    assert {o["name"] for o in report["objects"]} == {"Floor", "Roof"}
    for entry in report["objects"]:
        assert entry["uv_map"] == "Lightmap" and entry["resolution"] == [64, 64]
        assert entry["image"] == str(files[0]) and entry["color_attribute"] == "Radiosity"
    assert filecmp.cmp(files[0], files[1], shallow=False)
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "a" / "out.blend"))
    floor = bpy.data.objects["Floor"].data
    assert [uv.name for uv in floor.uv_layers] == ["UVMap", "Lightmap"]
    assert floor.uv_layers.active.name == "UVMap"
    image = bpy.data.images["Radiosity Lightmap"]
    assert tuple(image.size) == (64, 64)


def test_lightmap_name_clash_is_refused(scene_file, tmp_path):
    code, stderr = run_cli(scene_file, "-o", tmp_path / "out.blend", "--target", "lightmap", "--uv-map", "UVMap")
    assert code == 4 and "already has a UV map 'UVMap'" in stderr


def test_cornell_lightmap_matches_cycles(tmp_path, extension):
    """Draft lightmap at 128 x 128 against Cycles at 1024 samples on the same UV map, over the texels both bake.

    Measured (bpy 5.2.3): per-surface means 0.89-1.00 of Cycles' (red lowest), relative RMSE 11-13% on walls and
    blocks, 24% on the floor (block shadows and the bright patch under the light, at 4 mm texels). The ceiling,
    whose rim sits 0.5 mm above the light's back face (light that changes within a millimetre), is left out. The
    issue's goal (3% at High) is not reached; this guards the Draft preset CI can afford.
    """
    bpy.ops.wm.open_mainfile(filepath=str(make_cornell_box(tmp_path)))
    settings = bpy.context.scene.radiosity
    settings.quality, settings.target, settings.lightmap_resolution = "DRAFT", "LIGHTMAP", SIZE
    settings.lightmap_padding = 2
    settings.lightmap_folder = str(tmp_path)
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    from radiosity_baker.core.image_file import read_image
    ours = read_image(str(tmp_path / "Radiosity_Lightmap.exr"))[..., :3]
    names = ["floor", "back wall", "left wall", "right wall", "short block", "tall block"]
    objects = [bpy.data.objects[name] for name in names]
    cycles, _ = cycles_lightmap_bake(objects, "Lightmap", SIZE, SIZE, samples=1024)
    errors, ratios = {}, {}
    for name in names:
        mask = uv_coverage([bpy.data.objects[name]], "Lightmap", SIZE, SIZE)
        ratios[name] = ours[mask].mean(axis=0) / cycles[mask].mean(axis=0)
        errors[name] = np.sqrt(np.mean((ours[mask] - cycles[mask]) ** 2)) / cycles[mask].mean()
    for name in names:
        assert ratios[name] == pytest.approx(1.0, abs=0.13), name
        assert errors[name] <= (0.30 if name == "floor" else 0.16), name


def material_snapshot(material):
    """Everything about a node tree a hookup could change: nodes, their input values, and links."""
    tree = material.node_tree
    values = lambda node: [tuple(s.default_value) if hasattr(s.default_value, "__len__") else s.default_value
                           for s in node.inputs if hasattr(s, "default_value")]
    nodes = sorted((n.name, n.bl_idname, tuple(n.location), str(values(n))) for n in tree.nodes)
    links = sorted((l.from_node.name, l.from_socket.identifier, l.to_node.name, l.to_socket.identifier)
                   for l in tree.links)
    return nodes, links, sorted(material.keys())


def test_preview_hooks_up_materials_and_restores_them_exactly(empty_scene, tmp_path):
    """Preview makes each baked material emit base colour x lightmap; previewing again restores every node,
    value and link (the textured base colour included)."""
    floor = grid_plane("Floor", 2.0, 2)
    material = floor.data.materials[0]
    texture = material.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = bpy.data.images.new("checker", 8, 8)
    bsdf = material.node_tree.nodes["Principled BSDF"]
    material.node_tree.links.new(texture.outputs["Color"], bsdf.inputs["Base Color"])
    add_light("POINT", (0, 0, 1.5), 100.0)
    settings = empty_scene.radiosity
    settings.quality, settings.target, settings.lightmap_resolution = "DRAFT", "LIGHTMAP", 32
    settings.lightmap_folder = str(tmp_path)
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    before = material_snapshot(material)
    assert bpy.ops.radiosity.preview() == {"FINISHED"}
    output = material.node_tree.nodes["Material Output"]
    shown = output.inputs["Surface"].links[0].from_node
    assert shown.type == "EMISSION"
    group = shown.inputs["Color"].links[0].from_node
    assert group.inputs["Base Color"].links[0].from_node == texture
    images = [n.image for n in group.node_tree.nodes if n.type == "TEX_IMAGE"]
    assert images == [bpy.data.images["Radiosity Lightmap"]]
    assert bpy.ops.radiosity.preview() == {"FINISHED"}
    assert material_snapshot(material) == before
