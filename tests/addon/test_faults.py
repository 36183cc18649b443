"""The fault matrix of the command line: a full disk, an interrupt, an output that is the input, bounds on every
number, and odd scenes. In every case the exit code and the one-line reason are the documented ones, earlier
files keep their bytes, and no temporary file is left behind."""
import hashlib
import json
import os
import signal
import subprocess
import sys
import time

import bpy
import numpy as np
import pytest

from blender_setup import ROOT, add_light, corner_colors, grid_plane, run_cli, save_scene

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="file size limits and signals are POSIX")
OUTPUTS = ("out.blend", "report.json", "Radiosity_Lightmap.exr", "Radiosity_Lightmap.png")
BAKE = ("--quality", "draft", "--target", "both", "--png-exposure", "0")


def digests(folder):
    return {path.name: hashlib.sha256(path.read_bytes()).hexdigest() for path in sorted(folder.iterdir())}


def leftovers(folder):
    return [path.name for path in folder.iterdir() if ".partial-" in path.name]


@pytest.fixture
def baked(tmp_path, extension):
    """A scene and a good earlier bake of it (every output present)."""
    source = save_scene(tmp_path / "in.blend")
    code, stderr = run_cli(source, "-o", tmp_path / "out.blend", "--report", tmp_path / "report.json", *BAKE)
    assert code == 0, stderr
    assert all((tmp_path / name).exists() for name in OUTPUTS)
    return tmp_path


@pytest.mark.parametrize("fails", ["out.blend", "Radiosity_Lightmap.exr"])
def test_a_full_disk_keeps_every_earlier_output(baked, fails):
    """Files may not grow past a limit just under the size of the one that should fail (the .blend is the
    largest output, the EXR the next): the bake exits 5 naming it, and no output changes."""
    sizes = sorted((baked / name).stat().st_size for name in OUTPUTS)
    limit = (sizes[-1] + sizes[-2]) // 2 if fails == "out.blend" else (sizes[-2] + sizes[-3]) // 2
    assert (baked / fails).stat().st_size > limit
    before = digests(baked)
    code, stderr = run_cli(baked / "in.blend", "-o", baked / "out.blend", "--report", baked / "report.json", *BAKE,
                           "--seed", "1", file_size_limit=limit)
    assert code == 5 and "Cannot write" in stderr and str(baked / fails) in stderr, stderr  # or its .blend1
    assert digests(baked) == before and not leftovers(baked)


def test_two_bakes_into_one_output_do_not_mix(baked):
    """While a bake (here this process, holding the claim as a bake does) writes out.blend, a second bake into it
    exits 5 naming the file and the holder's process id, and changes nothing. Two bakes started together (seeds 1
    and 2) each finish or are refused so, at least one finishes, and the outputs are whole: the .blend, the report
    and the lightmap of one bake, Blender's backup of the earlier .blend, no claim and no temporary left."""
    from radiosity_baker.core.staged_files import claimed
    command = (baked / "in.blend", "-o", baked / "out.blend", "--report", baked / "report.json", *BAKE)
    before = digests(baked)
    with claimed(str(baked / "out.blend")):
        code, stderr = run_cli(*command)
    assert code == 5 and f"process {os.getpid()}" in stderr and str(baked / "out.blend") in stderr, stderr
    assert digests(baked) == before
    bakes = [subprocess.Popen([sys.executable, "-m", "radiosity_addon", "bake", *map(str, command), "--seed", seed],
                              cwd=ROOT, stderr=subprocess.PIPE, text=True) for seed in ("1", "2")]
    results = [(bake.wait(timeout=600), bake.stderr.read()) for bake in bakes]
    assert all(code == 0 or (code == 5 and "Another bake" in stderr) for code, stderr in results), results
    assert any(code == 0 for code, _ in results)
    report = json.loads((baked / "report.json").read_text())
    assert report["output"] == str(baked / "out.blend")
    bpy.ops.wm.open_mainfile(filepath=str(baked / "out.blend"))
    assert corner_colors(bpy.data.objects["Floor"].data, "Radiosity").max() > 0
    assert {path.name for path in baked.iterdir()} == {*before, "out.blend1"}  # Blender's backup of the old file


def test_the_input_is_replaced_only_with_overwrite(baked):
    """Refused without --overwrite; with it, a full disk changes nothing, and a bake replaces the input and keeps
    the old one as in.blend1 (Blender's backup)."""
    source = baked / "in.blend"
    before = digests(baked)
    code, stderr = run_cli(source, "-o", source, "--quality", "draft")
    assert code == 2 and "--overwrite" in stderr
    code, stderr = run_cli(source, "-o", source, "--quality", "draft", "--overwrite", file_size_limit=40_000)
    assert code == 5 and digests(baked) == before and not leftovers(baked), stderr
    code, stderr = run_cli(source, "-o", source, "--quality", "draft", "--overwrite")
    assert code == 0, stderr
    assert hashlib.sha256((baked / "in.blend1").read_bytes()).hexdigest() == before["in.blend"]
    bpy.ops.wm.open_mainfile(filepath=str(source))
    assert corner_colors(bpy.data.objects["Floor"].data, "Radiosity").max() > 0


@pytest.mark.parametrize("report", ["/dev/full", "{folder}", "/proc/radiosity_report.json"])
def test_an_unwritable_report_leaves_no_new_blend(tmp_path, extension, report):
    source = save_scene(tmp_path / "in.blend")
    code, stderr = run_cli(source, "-o", tmp_path / "out.blend", "--report", report.format(folder=tmp_path),
                           "--quality", "draft")
    assert code == 5 and ("report file" in stderr or "Cannot write" in stderr), stderr
    assert sorted(path.name for path in tmp_path.iterdir()) == ["in.blend"]


def _interrupts_as_in_a_terminal():
    """A shell starts background jobs (a CI script run with &) with SIGINT ignored, and children inherit that;
    Python then leaves it ignored. The bake under test gets the default, as a user's terminal gives it."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize("signal_number, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_an_interrupt_cancels_cleanly(tmp_path, extension, signal_number, code):
    """Interrupted while it solves the room sample: one line 'cancelled', the signal's exit code, no output."""
    from blender_setup import make_sample
    source = make_sample("room", tmp_path)
    bake = subprocess.Popen([sys.executable, "-m", "radiosity_addon", "bake", str(source), "-o",
                             str(tmp_path / "out.blend"), "--report", str(tmp_path / "report.json"), "--target",
                             "both", "--quality", "medium"], cwd=ROOT, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_interrupts_as_in_a_terminal)
    while True:  # until the solve has started (the first progress line after export)
        line = bake.stderr.readline()
        if not line or line.startswith("[radiosity]"):
            break
    time.sleep(1.0)
    bake.send_signal(signal_number)
    stderr = bake.communicate(timeout=120)[1]
    assert bake.returncode == code and "cancelled" in stderr.splitlines()[-1], stderr
    assert sorted(path.name for path in tmp_path.iterdir()) == ["room.blend"]


@pytest.mark.parametrize("arguments, message", [
    (["--texels-per-meter", "1e9"], "--texels-per-meter: must be from"),
    (["--texels-per-meter", "nan"], "--texels-per-meter: must be from"),
    (["--texels-per-meter", "inf"], "--texels-per-meter: must be from"),
    (["--resolution", "100000"], "--resolution: must be from"),
    (["--resolution", "8192"], "above the maximum size 4096"),
    (["--resolution", "512", "--texels-per-meter", "40"], "both a texel density"),
    (["--max-size", "1"], "--max-size: must be from"),
    (["--png-exposure", "nan"], "--png-exposure: must be from"),
    (["--quality", "custom", "--element-size", "1e-6"], "--element-size: must be from"),
    (["--quality", "custom", "--gather-samples", "0"], "--gather-samples: must be from"),
    (["--seed", "-1"], "--seed: must be from"),
])
def test_numbers_out_of_range_exit_2_naming_the_argument(tmp_path, extension, arguments, message):
    source = save_scene(tmp_path / "in.blend")
    code, stderr = run_cli(source, "-o", tmp_path / "out.blend", "--target", "lightmap", *arguments)
    assert code == 2 and message in stderr, stderr
    assert not (tmp_path / "out.blend").exists()


def test_a_texel_density_over_the_memory_limit_is_refused_before_unwrapping(tmp_path, extension):
    """10,000 texels per metre on 5 m^2 of surface are 5e8 texels, about 1.5 TB: refused in seconds."""
    source = save_scene(tmp_path / "in.blend")
    started = time.perf_counter()
    code, stderr = run_cli(source, "-o", tmp_path / "out.blend", "--target", "lightmap", "--texels-per-meter",
                           "10000", "--max-memory-gb", "4")
    assert code == 4 and "memory limit is 4 GiB" in stderr, stderr
    assert time.perf_counter() - started < 60


def make_scene(tmp_path, build):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    build()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "in.blend"))
    return tmp_path / "in.blend"


def test_an_object_at_scale_zero_bakes(tmp_path, extension):
    """A roof squashed flat by a zero scale along Z still casts its shadow; the floor under it bakes. A plane at
    scale 0 and a mesh of vertices only have no surface to bake: the bake goes on and the report's warnings name
    each of them."""
    def build():
        grid_plane("Floor", 2.0, 4)
        cube = grid_plane("Flat", 1.0, 2, location=(0, 0, 1.0))
        cube.scale = (1.0, 1.0, 0.0)
        grid_plane("Vanished", 1.0, 2, location=(2.0, 0, 0.5)).scale = (0.0, 0.0, 0.0)
        points = bpy.data.meshes.new("Points")
        points.from_pydata([(0, 0, 0), (1, 0, 0)], [], [])
        bpy.context.collection.objects.link(bpy.data.objects.new("Points", points))
        add_light("POINT", (0.0, 0.0, 2.0), 100.0)
    code, stderr = run_cli(make_scene(tmp_path, build), "-o", tmp_path / "out.blend", "--quality", "draft",
                           "--report", tmp_path / "report.json")
    assert code == 0, stderr
    warnings = json.loads((tmp_path / "report.json").read_text())["warnings"]
    assert any("'Vanished'" in warning and "scale of 0" in warning for warning in warnings), warnings
    assert any("'Points'" in warning and "no faces" in warning for warning in warnings), warnings
    assert not any("'Flat'" in warning or "'Floor'" in warning for warning in warnings), warnings


def test_a_missing_texture_file_names_the_image(tmp_path, extension):
    def build():
        floor = grid_plane("Floor", 2.0, 2)
        material = floor.data.materials[0]
        node = material.node_tree.nodes.new("ShaderNodeTexImage")
        node.image = bpy.data.images.new("Bricks", 4, 4)
        node.image.source, node.image.filepath = "FILE", str(tmp_path / "no such bricks.png")
        material.node_tree.links.new(node.outputs["Color"],
                                     material.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
        add_light("POINT", (0.0, 0.0, 2.0), 100.0)
    code, stderr = run_cli(make_scene(tmp_path, build), "-o", tmp_path / "out.blend", "--quality", "draft")
    assert code == 4 and "image 'Bricks'" in stderr and "no such bricks.png" in stderr, stderr


def test_a_folder_as_input_says_so(tmp_path, extension):
    code, stderr = run_cli(tmp_path, "-o", tmp_path / "out.blend")
    assert code == 3 and "is a folder" in stderr, stderr


def test_unbounded_light_power_names_the_light(tmp_path, extension):
    def build():
        grid_plane("Floor", 2.0, 2)
        add_light("POINT", (0.0, 0.0, 2.0), 1e30).name = "Flare"
    code, stderr = run_cli(make_scene(tmp_path, build), "-o", tmp_path / "out.blend", "--quality", "draft")
    assert code == 4 and "Light 'Flare'" in stderr, stderr


def test_light_beyond_half_floats_is_written_as_32_bit(tmp_path, extension):
    """A 1e9 W lamp 1 m above a floor gives it irradiance / pi of about P / (4 pi^2) = 2.5e7 under the lamp,
    far above the largest half float (65504): the EXR is written in 32-bit floats, with a warning, and reads back
    finite and that bright."""
    from radiosity_baker.core.image_file import read_image

    def build():
        grid_plane("Floor", 2.0, 4)
        add_light("POINT", (0.0, 0.0, 1.0), 1e9)
    code, stderr = run_cli(make_scene(tmp_path, build), "-o", tmp_path / "out.blend", "--report",
                           tmp_path / "report.json", "--target", "lightmap", "--quality", "draft")
    assert code == 0, stderr
    report = json.loads((tmp_path / "report.json").read_text())
    assert any("32-bit floats" in warning for warning in report["warnings"])
    light = read_image(str(tmp_path / "Radiosity_Lightmap.exr"))[..., :3]
    assert np.isfinite(light).all() and light.max() > 0.5 * 1e9 / (4 * np.pi ** 2)


def link_statue(tmp_path):
    """in.blend: a local floor and lamp, and a statue linked from library.blend."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    grid_plane("Statue", 0.5, 1, location=(0.0, 0.0, 0.5))
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "library.blend"))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    grid_plane("Floor", 2.0, 4)
    add_light("POINT", (0.0, 0.0, 2.0), 100.0)
    with bpy.data.libraries.load(str(tmp_path / "library.blend"), link=True) as (source, target):
        target.objects = ["Statue"]
    bpy.context.scene.collection.objects.link(target.objects[0])
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "in.blend"))


@pytest.mark.parametrize("library_missing", [False, True])
def test_a_linked_object_is_left_out_of_the_report(tmp_path, extension, library_missing):
    """An object linked from a library lights the scene but cannot be saved: a warning names it and the report
    lists only the local objects. A library file that is gone is named in the warnings."""
    link_statue(tmp_path)
    if library_missing:
        (tmp_path / "library.blend").unlink()
    code, stderr = run_cli(tmp_path / "in.blend", "-o", tmp_path / "out.blend", "--report", tmp_path / "report.json",
                           "--quality", "draft")
    assert code == 0, stderr
    report = json.loads((tmp_path / "report.json").read_text())
    assert [entry["name"] for entry in report["objects"]] == ["Floor"]
    expected = "library.blend' is missing" if library_missing else "Object 'Statue' is linked from"
    assert any(expected in warning for warning in report["warnings"]), report["warnings"]


def test_make_local_bakes_a_linked_object_into_the_saved_file(tmp_path, extension):
    """With --make-local the linked statue becomes local with its mesh, is baked, and keeps its light in the
    saved file; the library is not touched."""
    link_statue(tmp_path)
    library = hashlib.sha256((tmp_path / "library.blend").read_bytes()).hexdigest()
    code, stderr = run_cli(tmp_path / "in.blend", "-o", tmp_path / "out.blend", "--report", tmp_path / "report.json",
                           "--quality", "draft", "--make-local")
    assert code == 0, stderr
    report = json.loads((tmp_path / "report.json").read_text())
    assert sorted(entry["name"] for entry in report["objects"]) == ["Floor", "Statue"]
    assert any("Object 'Statue' was linked from" in warning for warning in report["warnings"])
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "out.blend"))
    statue = bpy.data.objects["Statue"]
    assert statue.library is None and statue.data.library is None
    assert corner_colors(statue.data, "Radiosity").max() > 0
    assert hashlib.sha256((tmp_path / "library.blend").read_bytes()).hexdigest() == library


def test_a_scene_in_a_read_only_folder_bakes_elsewhere(tmp_path, extension):
    """A .blend in a folder nobody may write to (mode 555; root's permission overrides dropped) bakes into another
    folder, with its lightmap beside the output (the default //), and its own folder keeps its bytes; an output
    into that folder exits 5 naming it, before any work."""
    (tmp_path / "shared").mkdir()
    source = save_scene(tmp_path / "shared" / "in.blend")
    before = digests(source.parent)
    (tmp_path / "mine").mkdir()
    source.parent.chmod(0o555)
    try:
        code, stderr = run_cli(source, "-o", tmp_path / "mine" / "out.blend", *BAKE, honour_permissions=True)
        assert code == 0, stderr
        assert (tmp_path / "mine" / "Radiosity_Lightmap.exr").is_file() and digests(source.parent) == before
        code, stderr = run_cli(source, "-o", source.parent / "out.blend", *BAKE, honour_permissions=True)
        assert code == 5 and str(source.parent / "out.blend") in stderr and "read-only" in stderr, stderr
        assert digests(source.parent) == before
    finally:
        source.parent.chmod(0o755)


def test_a_lightmap_folder_that_does_not_exist_yet_is_created(tmp_path, extension):
    """--lightmap-dir naming folders not made yet: they are made (as Blender makes a render output's), and the
    page lands there; a folder under a file cannot be made, and the bake exits 5 naming it, writing nothing."""
    source = save_scene(tmp_path / "in.blend")
    folder = tmp_path / "maps" / "level 1"
    code, stderr = run_cli(source, "-o", tmp_path / "out.blend", "--quality", "draft", "--target", "lightmap",
                           "--lightmap-dir", folder)
    assert code == 0, stderr
    assert (folder / "Radiosity_Lightmap.exr").is_file()
    (tmp_path / "a file").write_text("")
    code, stderr = run_cli(source, "-o", tmp_path / "again.blend", "--quality", "draft", "--target", "lightmap",
                           "--lightmap-dir", tmp_path / "a file" / "maps")
    assert code == 5 and str(tmp_path / "a file" / "maps") in stderr, stderr
    assert not (tmp_path / "again.blend").exists()


def test_a_damaged_cache_or_one_of_another_version_is_named(tmp_path, extension):
    """--relight from a cache cut in half, from one of another format version, or from a folder, and --cache into
    a folder: each exits with its one line naming the file (4 for what is read, 3 for a folder given as the cache
    to read, 5 for what cannot be written) and writes no output."""
    from radiosity_baker.core.data_file import data_writer
    source = save_scene(tmp_path / "in.blend")
    code, stderr = run_cli(source, "-o", tmp_path / "baked.blend", "--quality", "draft", "--cache",
                           tmp_path / "good.rlcache")
    assert code == 0, stderr
    whole = (tmp_path / "good.rlcache").read_bytes()
    (tmp_path / "cut.rlcache").write_bytes(whole[:len(whole) // 2])
    data_writer({"format": "radiosity-relight", "version": 1}, {}, ())(str(tmp_path / "old.rlcache"))
    (tmp_path / "folder.rlcache").mkdir()
    for name, expected_code, message in [("cut.rlcache", 4, "is not a relighting cache"),
                                         ("old.rlcache", 4, "format version 1"),
                                         ("folder.rlcache", 3, "relighting cache")]:
        code, stderr = run_cli(source, "-o", tmp_path / "relit.blend", "--quality", "draft", "--relight",
                               tmp_path / name)
        assert code == expected_code and name in stderr and message in stderr, stderr
        assert not (tmp_path / "relit.blend").exists()
    code, stderr = run_cli(source, "-o", tmp_path / "again.blend", "--quality", "draft", "--cache",
                           tmp_path / "folder.rlcache")
    assert code == 5 and "folder.rlcache" in stderr, stderr
    assert not (tmp_path / "again.blend").exists()


@pytest.mark.parametrize("placement", ["mirrored", "10 km from the origin"])
def test_a_mirrored_or_far_away_floor_under_a_vertical_sun_reads_its_closed_form(empty_scene, extension, tmp_path,
                                                                                  placement):
    """A 4 x 4 m floor (8 x 8 quads) under a sun straight down (3 W m^-2), black world, nothing else: every corner
    colour and every covered lightmap texel reads E / pi = 3 / pi (the Diffuse bake's units) within 1%, whether
    the floor is mirrored by a negative scale (its triangles wound the other way round) or 10 km from the origin
    (single-precision rays and texels there resolve about a millimetre)."""
    from radiosity_baker.core.image_file import read_image
    from blender_setup import uv_coverage
    far = 10_000.0 if placement.startswith("10 km") else 0.0
    floor = grid_plane("Floor", 4.0, 8, location=(far, -far, 0.0))
    if placement == "mirrored":
        floor.scale = (-1.0, 1.0, 1.0)
    add_light("SUN", (far, -far, 5.0), 3.0, angle=0.0)
    settings = empty_scene.radiosity
    settings.quality, settings.target, settings.lightmap_resolution = "DRAFT", "BOTH", 64
    settings.lightmap_folder = str(tmp_path)
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    np.testing.assert_allclose(corner_colors(floor.data, "Radiosity"), 3.0 / np.pi, rtol=0.01)
    page = read_image(str(tmp_path / "Radiosity_Lightmap.exr")).astype(np.float64)[..., :3]
    covered = uv_coverage([floor], "Lightmap", 64, 64)
    assert covered.sum() > 1000
    np.testing.assert_allclose(page[covered], 3.0 / np.pi, rtol=0.01)


def test_an_ngon_of_500_vertices_bakes_and_a_metaball_casts_its_shadow(empty_scene, extension):
    """A disc made of one 500-vertex face, and a 4 x 4 m floor under a metaball ball (radius 0.6 m, 1.5 m up;
    exported once, though the depsgraph lists it as itself and as its own mesh),
    under a sun straight down (3 W m^-2), black world. Every corner of the n-gon reads E / pi = 3 / pi within 1%;
    the floor's centre, in the ball's shadow, reads under 5% of that (only light reflected off the ball's
    unlit underside and the floor reaches it), and its outer corners 3 / pi within 2%."""
    angles = np.linspace(0.0, 2 * np.pi, 500, endpoint=False)
    disc = bpy.data.meshes.new("Disc")
    disc.from_pydata([(6.0 + np.cos(a), np.sin(a), 0.0) for a in angles], [], [list(range(500))])
    disc_object = bpy.data.objects.new("Disc", disc)
    bpy.context.collection.objects.link(disc_object)
    floor = grid_plane("Floor", 4.0, 8)
    bpy.ops.object.metaball_add(type="BALL", radius=0.6, location=(0.0, 0.0, 1.5))
    add_light("SUN", (0.0, 0.0, 5.0), 3.0, angle=0.0)
    empty_scene.radiosity.quality = "DRAFT"
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    np.testing.assert_allclose(corner_colors(disc, "Radiosity"), 3.0 / np.pi, rtol=0.01)
    colours = corner_colors(floor.data, "Radiosity").mean(axis=1)
    vertex = np.array([loop.vertex_index for loop in floor.data.loops])
    position = np.array([v.co[:2] for v in floor.data.vertices])[vertex]
    centre, rim = np.linalg.norm(position, axis=1) < 1e-6, np.abs(position).max(axis=1) > 1.99
    assert centre.any() and colours[centre].max() < 0.05 * 3.0 / np.pi
    np.testing.assert_allclose(colours[rim], 3.0 / np.pi, rtol=0.02)


def test_curves_text_surfaces_and_metaballs_are_exported_once(empty_scene, extension):
    """The depsgraph lists a curve, text, NURBS surface or metaball object as itself and as an instance of its
    own evaluated mesh; the export holds each one's triangles once (as many as its mesh's loop triangles),
    named by the object alone, so that no surface lies on a copy of itself (which bakes black)."""
    from radiosity_baker.radiosity_addon.export import export_scene
    bpy.ops.object.metaball_add(type="BALL", location=(3, 0, 0))
    bpy.ops.object.text_add(location=(0, 3, 0))
    bpy.context.active_object.data.extrude = 0.1
    bpy.ops.curve.primitive_bezier_circle_add(location=(0, -3, 0))
    bpy.context.active_object.data.bevel_depth = 0.1
    bpy.ops.surface.primitive_nurbs_surface_sphere_add(location=(-3, 0, 0))
    add_light("SUN", (0.0, 0.0, 5.0), 3.0)
    export = export_scene(bpy.context)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for name in ("Mball", "Text", "BézierCircle", "SurfSphere"):
        evaluated = bpy.data.objects[name].evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        mesh.calc_loop_triangles()
        expected = len(mesh.loop_triangles)
        evaluated.to_mesh_clear()
        counts = [exported.triangle_count for exported in export.objects if exported.name == name]
        assert expected > 100 and counts == [expected], name
    assert not any("instance of" in name for name in export.scene.object_names)
    for name, kind in (("Mball", "metaball"), ("Text", "text"), ("BézierCircle", "curve"), ("SurfSphere", "surface")):
        named = [warning for warning in export.warnings if f"'{name}'" in warning]
        assert len(named) == 1 and f"is a {kind} object" in named[0], export.warnings


def test_ten_thousand_small_objects_bake(empty_scene, extension, tmp_path):
    """10,000 objects of one 10 cm quad each (a mesh of its own each; 20 cm apart, 100 x 100), sun straight down
    (3 W m^-2), black world, Draft, both targets. In one plane nothing shades or lights another: every corner
    colour and, through the saved UV map, the lightmap texel under each quad's centre read E / pi = 3 / pi within
    1%, and no two quads' centres share a texel."""
    from radiosity_baker.core.image_file import read_image
    material = bpy.data.materials.new("Grey")
    tiles = []
    for index in range(10_000):
        x, y = index % 100 * 0.2, index // 100 * 0.2
        mesh = bpy.data.meshes.new(f"Tile {index}")
        mesh.from_pydata([(x, y, 0.0), (x + 0.1, y, 0.0), (x + 0.1, y + 0.1, 0.0), (x, y + 0.1, 0.0)], [],
                         [(0, 1, 2, 3)])
        mesh.materials.append(material)
        tiles.append(bpy.data.objects.new(f"Tile {index}", mesh))
        empty_scene.collection.objects.link(tiles[-1])
    add_light("SUN", (0.0, 0.0, 5.0), 3.0, angle=0.0)
    settings = empty_scene.radiosity
    settings.quality, settings.target, settings.lightmap_folder = "DRAFT", "BOTH", str(tmp_path)
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    colours = np.concatenate([corner_colors(tile.data, "Radiosity") for tile in tiles])
    np.testing.assert_allclose(colours, 3.0 / np.pi, rtol=0.01)
    page = read_image(str(tmp_path / "Radiosity_Lightmap.exr")).astype(np.float64)[..., :3]
    centres = np.empty((len(tiles), 2))
    for index, tile in enumerate(tiles):
        uv = np.empty(8, dtype=np.float32)
        tile.data.uv_layers["Lightmap"].data.foreach_get("uv", uv)
        centres[index] = uv.reshape(4, 2).mean(axis=0)
    height, width = page.shape[:2]
    texels = page[(centres[:, 1] * height).astype(int), (centres[:, 0] * width).astype(int)]
    np.testing.assert_allclose(texels, 3.0 / np.pi, rtol=0.01)
    assert len(np.unique((centres * [width, height]).astype(int), axis=0)) == len(tiles)


BLENDER_5_PYTHON = ROOT / ".venv" / "bin" / "python"  # scripts/test.sh's, with bpy 5.2


@pytest.mark.skipif(bpy.app.version[:2] != (4, 2), reason="saves on Blender 4.2 (scripts/test_blender42.sh) a file "
                                                          "for Blender 5.2 to bake")
@pytest.mark.skipif(not BLENDER_5_PYTHON.exists(), reason="needs scripts/test.sh's .venv with Blender 5.2")
def test_a_file_saved_by_blender_4_2_bakes_on_5_2(empty_scene, extension, tmp_path):
    """Saved by 4.2: a 4 x 4 m floor (8 x 8 quads) under a 1 x 1 m roof 1 m up marked Shadow Only, a sun straight
    down (3 W m^-2), black world, and the scene's bake settings (Draft, both targets, a 64-texel lightmap) with
    the add-on's properties. Blender 5.2's command line bakes it with no setting given: it keeps the settings
    (the report lists the floor alone, on a 64 x 64 lightmap, at Draft), the floor's outer corners read E / pi =
    3 / pi within 2%, and its centre, in the roof's shadow, under 5% of that."""
    floor = grid_plane("Floor", 4.0, 8)
    grid_plane("Roof", 1.0, 1, location=(0.0, 0.0, 1.0)).radiosity.mode = "SHADOW_ONLY"
    add_light("SUN", (0.0, 0.0, 5.0), 3.0, angle=0.0)
    settings = empty_scene.radiosity
    settings.quality, settings.target, settings.lightmap_resolution = "DRAFT", "BOTH", 64
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "saved by 4.2.blend"))
    code, stderr = run_cli(tmp_path / "saved by 4.2.blend", "-o", tmp_path / "out.blend", "--report",
                           tmp_path / "report.json", python=BLENDER_5_PYTHON)
    assert code == 0, stderr
    report = json.loads((tmp_path / "report.json").read_text())
    assert [entry["name"] for entry in report["objects"]] == ["Floor"]
    assert report["objects"][0]["resolution"] == [64, 64], report
    assert report["objects"][0]["color_attribute"]
    draft = extension.radiosity_addon.presets.PRESETS["DRAFT"]
    assert report["settings"]["light_samples_per_edge"] == draft.light_samples, report["settings"]
    assert report["settings"]["residual_threshold"] == draft.residual
    read = ("import bpy, json, numpy as np, sys; bpy.ops.wm.open_mainfile(filepath=sys.argv[1]); "
            "mesh = bpy.data.objects['Floor'].data; rgba = np.empty(len(mesh.loops) * 4, dtype=np.float32); "
            "mesh.color_attributes['Radiosity'].data.foreach_get('color', rgba); "
            "print(json.dumps([rgba.reshape(-1, 4)[:, :3].tolist(), "
            "[list(mesh.vertices[loop.vertex_index].co[:2]) for loop in mesh.loops]]))")
    result = subprocess.run([str(BLENDER_5_PYTHON), "-c", read, str(tmp_path / "out.blend")], capture_output=True,
                            text=True, timeout=120)  # a file saved by 5.2 does not open on 4.2
    rgb, position = map(np.array, json.loads(result.stdout.splitlines()[-1]))
    colours = rgb.mean(axis=1) / (3.0 / np.pi)
    outer, centre = np.abs(position).min(axis=1) > 1.99, np.linalg.norm(position, axis=1) < 1e-6
    np.testing.assert_allclose(colours[outer], 1.0, rtol=0.02)
    assert centre.sum() == 4 and colours[centre].max() < 0.05


def scatter_cubes(host, side: float, count: int, cube_size: float):
    """Replace ``host``'s geometry by geometry nodes: a cube of ``cube_size`` m instanced on each point of a
    ``count`` x ``count`` grid ``side`` m wide (instances, not realized)."""
    tree = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    grid, cube = tree.nodes.new("GeometryNodeMeshGrid"), tree.nodes.new("GeometryNodeMeshCube")
    for axis in "XY":
        grid.inputs[f"Size {axis}"].default_value, grid.inputs[f"Vertices {axis}"].default_value = side, count
    cube.inputs["Size"].default_value = (cube_size,) * 3
    scatter = tree.nodes.new("GeometryNodeInstanceOnPoints")
    tree.links.new(grid.outputs["Mesh"], scatter.inputs["Points"])
    tree.links.new(cube.outputs["Mesh"], scatter.inputs["Instance"])
    tree.links.new(scatter.outputs["Instances"], tree.nodes.new("NodeGroupOutput").inputs[0])
    host.modifiers.new("Scatter", "NODES").node_group = tree


def test_geometry_node_instances_cast_their_shadows_and_are_named(empty_scene, extension):
    """Nine 0.6 m cubes instanced by geometry nodes on a 3 x 3 grid 2 m wide, centred 1 m over a 4 x 4 m floor
    (8 x 8 quads), sun straight down (3 W m^-2), black world. The instances cannot hold baked light: the report
    names their object once. They still light the scene: floor corners under a cube get no direct light, only what
    the cube's underside reflects (view factor about 0.2 times its light, itself under the floor's), so they read
    under 0.2 x E / pi; the floor's outer corners, 1.4 m from the nearest cube, read E / pi = 3 / pi within 2%."""
    floor = grid_plane("Floor", 4.0, 8)
    scatter_cubes(grid_plane("Scatter", 2.0, 1, location=(0.0, 0.0, 1.0)), 2.0, 3, 0.6)
    add_light("SUN", (0.0, 0.0, 5.0), 3.0, angle=0.0)
    empty_scene.radiosity.quality, empty_scene.radiosity.target = "DRAFT", "VERTEX_COLORS"
    from radiosity_baker.radiosity_addon.export import export_scene
    warnings = [warning for warning in export_scene(bpy.context).warnings if "'Scatter'" in warning]
    assert len(warnings) == 1 and "9 geometry-node instance(s)" in warnings[0], warnings
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    colours = corner_colors(floor.data, "Radiosity").mean(axis=1) / (3.0 / np.pi)
    vertex = np.array([loop.vertex_index for loop in floor.data.loops])
    position = np.array([v.co[:2] for v in floor.data.vertices])[vertex]
    under = (np.abs(position - np.round(position)).max(axis=1) < 1e-6) & (np.abs(position).max(axis=1) < 1.01)
    outer = np.abs(position).min(axis=1) > 1.99
    assert under.sum() == 9 * 4 and outer.sum() == 4
    assert colours[under].max() < 0.2, colours[under]
    np.testing.assert_allclose(colours[outer], 1.0, rtol=0.02)
