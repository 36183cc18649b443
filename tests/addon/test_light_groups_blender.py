"""Light groups in Blender: lamps, emissive objects and the world in Cycles' light groups (View Layer > Light
Groups) each get their own lightmap pages and colour attribute; the main outputs hold their sum, which is the
ordinary bake's light."""
import json

import bpy
import numpy as np
import pytest

from blender_setup import add_light, corner_colors, grid_plane, lightmap_bake, run_cli


def grouped_scene(world_group: str = "sky"):
    """A 2 m floor under a 1 m roof, a lamp in group 'left' and one in 'right', a third lamp and a grey world (in
    ``world_group``); Light Groups on, Draft."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    grid_plane("Floor", 2.0, 4)
    grid_plane("Roof", 1.0, 2, location=(0, 0, 1.0))
    for name in ("left", "right", "sky"):
        bpy.context.view_layer.lightgroups.add(name=name)
    add_light("POINT", (-0.8, 0, 1.5), 80.0).lightgroup = "left"
    add_light("POINT", (0.8, 0, 1.5), 60.0, color=(1.0, 0.6, 0.3)).lightgroup = "right"
    add_light("POINT", (0, 0.8, 0.5), 20.0)
    scene.world = bpy.data.worlds.new("Grey")
    scene.world.use_nodes = True
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.2, 0.2, 0.2, 1.0)
    scene.world.lightgroup = world_group
    return scene


def test_groups_bake_apart_and_sum_to_the_ordinary_bake(tmp_path, extension):
    """Each group's lightmap pages and colour attribute are written beside the main ones; the main ones equal the
    sum of the groups (to float32 round-off) and an ordinary bake without groups within 0.5% on the mean (the
    issue's bound; light is linear in emission)."""
    grouped_scene()
    ordinary, _, _ = lightmap_bake("draft", tmp_path / "ordinary", target="BOTH", lightmap_resolution=64,
                                   lightmap_image="Ordinary", attribute_name="Ordinary")
    job, report, _ = lightmap_bake("draft", tmp_path / "groups", target="BOTH", lightmap_resolution=64,
                                   light_groups=True)
    names = ["ungrouped", "left", "right", "sky"]
    assert sorted(entry["name"] for entry in report["light_groups"]) == sorted(names)
    entry = {e["name"]: e for e in report["light_groups"]}
    assert entry["left"]["images"] and entry["right"]["lights"] == ["Point.001"] and entry["sky"]["world"]
    floor = bpy.data.objects["Floor"].data
    main = corner_colors(floor, "Radiosity")
    groups = [corner_colors(floor, f"Radiosity {name}") for name in names]
    assert sum(groups) == pytest.approx(main, rel=1e-5, abs=1e-6)
    assert np.abs(main - corner_colors(floor, "Ordinary")).sum() < 0.005 * main.sum()
    assert groups[1][:, 0].sum() > 0 and groups[2][:, 0].sum() > groups[2][:, 2].sum()  # the right lamp is orange
    pages = {name: bpy.data.images[f"Radiosity Lightmap {name}"] for name in names}
    assert all(image.filepath.startswith(str(tmp_path / "groups")) for image in pages.values())
    covered = job.lightmaps[0].covered
    light, plain = job.lightmaps[0].light, ordinary.lightmaps[0].light
    assert np.array_equal(light, sum(job.lightmaps[0].groups.values()))
    assert np.abs(light - plain)[covered].sum() < 0.005 * plain[covered].sum()


def test_the_preview_shows_one_group_or_the_sum(tmp_path, extension):
    """Preview Group picks the group's pages for the material preview; a group that was not baked hooks up
    nothing (a warning names it)."""
    scene = grouped_scene()
    settings = scene.radiosity
    settings.quality, settings.target, settings.light_groups = "DRAFT", "LIGHTMAP", True
    settings.lightmap_resolution, settings.lightmap_folder = 64, str(tmp_path)
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    settings.preview_light_group = "left"
    assert bpy.ops.radiosity.preview() == {"FINISHED"}
    group = bpy.data.node_groups["Radiosity Baked Light"]
    assert [n.image.name for n in group.nodes if n.type == "TEX_IMAGE"] == ["Radiosity Lightmap left"]
    assert bpy.ops.radiosity.preview() == {"FINISHED"}  # off again
    settings.preview_light_group = "nowhere"
    assert bpy.ops.radiosity.preview() == {"CANCELLED"}
    assert not any(extension.radiosity_addon.hookup.REMEMBERED in material for material in bpy.data.materials)


def test_the_command_line_bakes_light_groups_and_reports_them(tmp_path, extension):
    """--light-groups on the command line; a world in a group the view layer does not list is ungrouped, with a
    warning naming it."""
    grouped_scene(world_group="missing")
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "in.blend"))
    code, stderr = run_cli(tmp_path / "in.blend", "-o", tmp_path / "out.blend", "--report", tmp_path / "r.json",
                           "--quality", "draft", "--light-groups")
    assert code == 0, stderr
    report = json.loads((tmp_path / "r.json").read_text())
    assert sorted(entry["name"] for entry in report["light_groups"]) == ["left", "right", "ungrouped"]
    assert any("'missing'" in warning for warning in report["warnings"])
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "out.blend"))
    floor = bpy.data.objects["Floor"].data
    assert {"Radiosity", "Radiosity left", "Radiosity right", "Radiosity ungrouped"} <= set(
        floor.color_attributes.keys())
