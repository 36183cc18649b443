"""Relighting from a cache: a bake split by light source, mixed again for new lamp strengths and colours, world
strength and light groups, equals a new bake of the edited scene; anything else that changed is refused by name."""
import json
import pickle
from pathlib import Path

import bpy
import numpy as np
import pytest

from blender_setup import corner_colors, lightmap_bake, run_cli
from test_light_groups_blender import grouped_scene


def relight(tmp_path, cache, **settings):
    """Update Light through the job API: (the job, the report)."""
    from radiosity_baker.radiosity_addon import job
    from radiosity_baker.radiosity_addon.settings import UserSettings
    user = UserSettings(**{"quality": "MEDIUM", "target": "BOTH", "lightmap_resolution": 64, **settings})
    relit = job.relight_job(bpy.context, user, str(tmp_path / "relit"), str(cache))
    return relit, job.write_outputs(relit)


def edit_lights():
    """The sun-off / warmer lamps / half world edit: lamp 'left' off, the right one warmer, the world halved."""
    bpy.data.objects["Point"].data.energy = 0.0
    bpy.data.objects["Point.001"].data.color = (1.0, 0.45, 0.2)
    half_world()


def half_world():
    background = bpy.context.scene.world.node_tree.nodes["Background"]
    background.inputs["Strength"].default_value *= 0.5


def lamps_off_and_red():
    """Before the bake: lamp 'left' off, the right one pure red (its green and blue channels dark)."""
    bpy.data.objects["Point"].data.energy = 0.0
    bpy.data.objects["Point.001"].data.color = (1.0, 0.0, 0.0)


def lamps_on_and_orange():
    """Lamp 'left' switched on (80 W), the right one orange, the world halved."""
    bpy.data.objects["Point"].data.energy = 80.0
    bpy.data.objects["Point.001"].data.color = (1.0, 0.6, 0.3)
    half_world()


@pytest.mark.parametrize("before, edit, left_lit", [(lambda: None, edit_lights, False),
                                                     (lamps_off_and_red, lamps_on_and_orange, True)])
def test_relight_equals_a_new_bake(tmp_path, extension, before, edit, left_lit):
    """Baked with a cache, the lights edited, then Update Light: the lightmap and the colour attributes equal a
    new bake of the edited scene within 0.1% on the mean (the issue's bound), and each group's light is its
    share of it; no ray was cast (the relight took under a second). Also when the edit turns on a lamp that was
    off when baked, and raises colour channels that were dark."""
    grouped_scene()
    before()
    cache = tmp_path / "room.rlcache"
    lightmap_bake("medium", tmp_path / "baked", target="BOTH", lightmap_resolution=64, light_groups=True,
                  relight_cache=str(cache))
    assert cache.is_file()
    edit()
    _, report = relight(tmp_path, cache, light_groups=True)
    assert report["timings"]["relight"] < 1.0
    floor = bpy.data.objects["Floor"].data
    relit_corners = corner_colors(floor, "Radiosity")
    relit_image = np.array(bpy.data.images["Radiosity Lightmap"].pixels[:]).reshape(64, 64, 4)[..., :3]
    groups = {name: corner_colors(floor, f"Radiosity {name}") for name in ("left", "right", "sky", "ungrouped")}
    assert (groups["left"].max() > 0.0) == left_lit
    assert sum(groups.values()) == pytest.approx(relit_corners, rel=1e-5, abs=1e-6)
    fresh, _, _ = lightmap_bake("medium", tmp_path / "fresh", target="BOTH", lightmap_resolution=64,
                                lightmap_image="Fresh", attribute_name="Fresh")
    again = corner_colors(floor, "Fresh")
    assert np.abs(relit_corners - again).sum() < 0.001 * again.sum()
    covered = fresh.lightmaps[0].covered
    page = fresh.lightmaps[0].light
    assert np.abs(relit_image - page)[covered].sum() < 0.001 * page[covered].sum()


def test_twice_the_light_relights_to_exactly_twice(tmp_path, extension):
    """Every lamp and the world at twice their strength: the relit outputs are exactly twice the baked ones."""
    grouped_scene()
    cache = tmp_path / "room.rlcache"
    baked, _, _ = lightmap_bake("draft", tmp_path / "baked", target="BOTH", lightmap_resolution=64,
                                relight_cache=str(cache))
    floor = bpy.data.objects["Floor"].data
    before = corner_colors(floor, "Radiosity")
    for obj in bpy.data.objects:
        if obj.type == "LIGHT":
            obj.data.energy *= 2
    bpy.context.scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value *= 2
    relight(tmp_path, cache, quality="DRAFT")
    assert corner_colors(floor, "Radiosity") == pytest.approx(2 * before, rel=1e-6, abs=1e-9)
    image = np.array(bpy.data.images["Radiosity Lightmap"].pixels[:]).reshape(64, 64, 4)[..., :3]
    assert image == pytest.approx(2 * baked.lightmaps[0].light, rel=1e-3, abs=1e-6)  # through a half-float EXR


@pytest.mark.parametrize("edit, named", [
    (lambda: bpy.data.objects["Roof"].location.__setitem__(2, 1.2), "geometry"),
    (lambda: bpy.data.materials["Floor material"].node_tree.nodes["Principled BSDF"].inputs["Base Color"]
     .__setattr__("default_value", (0.9, 0.1, 0.1, 1.0)), "material 'Floor material'"),
    (lambda: bpy.data.objects["Point"].location.__setitem__(0, 0.0), "lamp 'Point'"),
    (lambda: bpy.ops.object.light_add(type="POINT", location=(0, 0, 0.5)), "lamp 'Point.003'"),
])
def test_a_stale_cache_is_refused_naming_what_changed(tmp_path, extension, edit, named):
    grouped_scene()
    cache = tmp_path / "room.rlcache"
    lightmap_bake("draft", tmp_path / "baked", target="BOTH", lightmap_resolution=64, relight_cache=str(cache))
    edit()
    from radiosity_baker.core import SceneError
    with pytest.raises(SceneError, match=named):
        relight(tmp_path, cache, quality="DRAFT")


def test_the_command_line_bakes_a_cache_and_relights_from_it(tmp_path, extension):
    """--cache writes the cache beside the bake; --relight on the edited file writes the relit outputs; on a file
    whose geometry moved it exits 4 naming the geometry."""
    grouped_scene()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "in.blend"))
    code, stderr = run_cli(tmp_path / "in.blend", "-o", tmp_path / "baked.blend", "--quality", "draft",
                           "--cache", tmp_path / "in.rlcache", "--report", tmp_path / "baked.json")
    assert code == 0, stderr
    assert json.loads((tmp_path / "baked.json").read_text())["relight_cache"] == str(tmp_path / "in.rlcache")
    edit_lights()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "edited.blend"))
    code, stderr = run_cli(tmp_path / "edited.blend", "-o", tmp_path / "relit.blend", "--quality", "draft",
                           "--relight", tmp_path / "in.rlcache", "--report", tmp_path / "relit.json")
    assert code == 0, stderr
    assert "relight" in json.loads((tmp_path / "relit.json").read_text())["timings"]
    bpy.data.objects["Roof"].location.z = 1.5
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "moved.blend"))
    code, stderr = run_cli(tmp_path / "moved.blend", "-o", tmp_path / "nope.blend", "--quality", "draft",
                           "--relight", tmp_path / "in.rlcache")
    assert code == 4 and "geometry" in stderr
    assert not (tmp_path / "nope.blend").exists()


def test_the_panel_says_when_the_cache_no_longer_fits(tmp_path, extension):
    """The panel's check (run a moment after each change of the scene) is quiet after a light edit and names the
    geometry once a mesh moved; Update Light then refuses."""
    scene = grouped_scene()
    settings = scene.radiosity
    settings.quality, settings.target, settings.lightmap_resolution = "DRAFT", "LIGHTMAP", 64
    settings.lightmap_folder, settings.relight_cache = str(tmp_path), str(tmp_path / "room.rlcache")
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    operators = extension.radiosity_addon.operators
    edit_lights()
    operators.check_scene()
    assert operators.STATUS["relight"] == ""
    assert bpy.ops.radiosity.update_light() == {"FINISHED"}
    bpy.data.objects["Roof"].location.z = 1.3
    operators.check_scene()
    assert "geometry" in operators.STATUS["relight"]
    with pytest.raises(RuntimeError, match="geometry"):
        bpy.ops.radiosity.update_light()


class _Touch:
    """A pickle payload: unpickling it creates the file ``marker`` (a crafted cache could run any code there)."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return Path.touch, (self.marker,)


def test_a_blend_naming_a_planted_pickle_runs_nothing(tmp_path, extension):
    """A .blend from elsewhere whose relighting cache is a pickle that would create a file when loaded: opened,
    the panel's check, Update Light and --relight each refuse it, naming the file, and the file is never made."""
    grouped_scene()
    marker, planted = tmp_path / "ran", tmp_path / "crafted.rlcache"
    planted.write_bytes(pickle.dumps({"format": "radiosity-relight", "version": 2, "key": _Touch(marker)}))
    bpy.context.scene.radiosity.relight_cache = str(planted)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "crafted.blend"))
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "crafted.blend"))
    operators = extension.radiosity_addon.operators
    operators.check_scene()
    assert "crafted.rlcache" in operators.STATUS["relight"] and "is not a relighting cache" in \
        operators.STATUS["relight"]
    with pytest.raises(RuntimeError, match="crafted.rlcache"):
        bpy.ops.radiosity.update_light()
    code, stderr = run_cli(tmp_path / "crafted.blend", "-o", tmp_path / "relit.blend", "--quality", "draft",
                           "--relight", planted)
    assert code != 0 and "crafted.rlcache" in stderr
    assert not marker.exists() and not (tmp_path / "relit.blend").exists()


def test_the_radiosity_mesh_of_a_bake_with_a_cache_holds_the_scene_s_light(tmp_path, extension):
    """A bake with a cache solves every lamp on, the one that is off included (the basis); its Radiosity Mesh
    still shows the scene's light: its area-weighted mean light equals that of a bake without a cache within 1%
    (the two solves' links and residuals differ; the lamp that is off, the brightest, would add over 30%)."""
    grouped_scene()
    lamps_off_and_red()
    lightmap_bake("draft", tmp_path / "plain", target="VERTEX_COLORS", create_radiosity_mesh=True)
    plain = radiosity_mesh_mean_light()
    lightmap_bake("draft", tmp_path / "cached", target="VERTEX_COLORS", create_radiosity_mesh=True,
                  relight_cache=str(tmp_path / "room.rlcache"))
    assert radiosity_mesh_mean_light() == pytest.approx(plain, rel=0.01)


def radiosity_mesh_mean_light() -> np.ndarray:
    """(3,) the Radiosity Mesh's light averaged over its area."""
    mesh = next(o for o in bpy.data.objects if o.get("radiosity_mesh")).data
    corners = np.array([mesh.vertices[loop.vertex_index].co for loop in mesh.loops]).reshape(-1, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    light = corner_colors(mesh, "Radiosity").reshape(-1, 3, 3).mean(axis=1)
    return (area[:, None] * light).sum(axis=0) / area.sum()
