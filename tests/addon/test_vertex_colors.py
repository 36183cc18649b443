"""Vertex colours of linked duplicates and in the vertex domain, against the closed form of a point light of
radius 0: irradiance / pi = P cos(theta) / (4 pi r^2) / pi (docs/references.md). The scenes hold no surface that
sees another, so there is no indirect light and the closed form is the whole answer."""
import bpy
import numpy as np
import pytest

from blender_setup import add_light, corner_colors, grid_plane


def _corner_positions_and_normals(obj):
    mesh = obj.data
    vertex = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", vertex)
    positions = np.array([obj.matrix_world @ mesh.vertices[v].co for v in vertex])
    polygon_normal = np.array([obj.matrix_world.to_3x3() @ p.normal for p in mesh.polygons])
    loop_polygon = np.repeat(np.arange(len(mesh.polygons)), [p.loop_total for p in mesh.polygons])
    order = np.concatenate([np.arange(p.loop_start, p.loop_start + p.loop_total) for p in mesh.polygons])
    normals = np.empty((len(mesh.loops), 3))
    normals[order] = polygon_normal[loop_polygon]
    return positions, normals, vertex


def _point_light(positions, normals, lamp, power_w):
    """Irradiance / pi at each corner from a point light of radius 0 (0 where the face turns away)."""
    offset = np.asarray(lamp, dtype=float) - positions
    distance = np.linalg.norm(offset, axis=1)
    cosine = np.maximum(np.einsum("mk,mk->m", offset, normals) / distance, 0.0)
    return power_w / (4 * np.pi) * cosine / distance ** 2 / np.pi


def _twins(scene):
    """Two 1 m tiles sharing one mesh, each under its own lamp (100 W and 400 W, 0.5 m above its centre)."""
    first = grid_plane("Tile", 1.0, 4, location=(-2.0, 0.0, 0.0))
    second = first.copy()
    second.name, second.location = "Tile twin", (2.0, 0.0, 0.0)
    scene.collection.objects.link(second)
    add_light("POINT", (-2.0, 0.0, 0.5), 100.0, shadow_soft_size=0.0)
    add_light("POINT", (2.0, 0.0, 0.5), 400.0, shadow_soft_size=0.0)
    scene.radiosity.quality = "DRAFT"
    return first, second, [((-2.0, 0.0, 0.5), 100.0), ((2.0, 0.0, 0.5), 400.0)]


def test_linked_duplicates_each_get_their_own_mesh_and_light(empty_scene):
    """Copies Get Own Mesh (the default): the twin gets its own copy of the mesh, as Make Single User does, and
    each tile's corners hold the light of both lamps at its own place within 0.5% (mostly its own lamp's: the
    twins differ 4x); the first keeps the original mesh; Undo in the UI reverses the copy (the operator is one
    undo step)."""
    first, second, lamps = _twins(empty_scene)
    shared = first.data
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    assert first.data == shared and second.data != shared and second.data.users == 1
    for obj in (first, second):
        positions, normals, _ = _corner_positions_and_normals(obj)
        expected = sum(_point_light(positions, normals, *lamp) for lamp in lamps)
        assert corner_colors(obj.data, "Radiosity")[:, 0] == pytest.approx(expected, rel=0.005), obj.name


def test_with_the_option_off_duplicates_keep_one_mesh_and_a_warning(empty_scene, extension):
    """Copies Get Own Mesh off: both tiles show the first one's light, within 0.5% of the closed form, with a
    warning naming the twin, whose corners are not lit at all (their light would be thrown away)."""
    first, second, lamps = _twins(empty_scene)
    empty_scene.radiosity.own_mesh_copies = False
    job = extension.radiosity_addon.job
    work = job.prepare(bpy.context, empty_scene.radiosity.user_settings(), "")
    job.solve(work, lambda fraction, message: None, lambda: False)
    assert set(work.corner_basis) == {"Tile"}
    report = job.write_outputs(work)
    assert first.data == second.data
    assert any("'Tile twin' shares mesh" in warning for warning in report["warnings"])
    positions, normals, _ = _corner_positions_and_normals(first)
    expected = sum(_point_light(positions, normals, *lamp) for lamp in lamps)
    assert corner_colors(second.data, "Radiosity")[:, 0] == pytest.approx(expected, rel=0.005)  # the first's
    assert [entry["name"] for entry in report["objects"]] == ["Tile"]


def test_vertex_domain_holds_the_mean_of_each_vertex_corners(empty_scene):
    """A unit cube under a lamp: in the vertex domain each vertex holds the mean of its three corners' light,
    which is what Cycles bakes into a vertex attribute (measured on a cube: equal to 1e-7)."""
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, 0.0))
    cube = bpy.context.active_object
    lamp = (0.7, 0.4, 1.5)
    add_light("POINT", lamp, 300.0, shadow_soft_size=0.0)
    settings = empty_scene.radiosity
    settings.quality, settings.vertex_domain = "DRAFT", "POINT"
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    attribute = cube.data.color_attributes["Radiosity"]
    assert attribute.domain == "POINT" and len(attribute.data) == len(cube.data.vertices) == 8
    positions, normals, vertex = _corner_positions_and_normals(cube)
    corner = _point_light(positions, normals, lamp, 300.0)
    expected = np.bincount(vertex, corner) / np.bincount(vertex)
    rgba = np.empty(8 * 4, dtype=np.float32)
    attribute.data.foreach_get("color", rgba)
    assert rgba.reshape(8, 4)[:, 0] == pytest.approx(expected, rel=0.005, abs=1e-6)


def test_a_bevelled_cubes_corners_take_the_light_of_its_faces(empty_scene):
    """A Bevel modifier cuts a cube's edges back, so the normal line through an original corner runs just outside
    the rendered surface: those corners used to bake black. Under a sun overhead of strength 3, the top face's
    corners hold 3 / pi (within 1%) and the side faces' none."""
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, 0.0))
    cube = bpy.context.active_object
    cube.modifiers.new("Bevel", "BEVEL").width = 0.05
    add_light("SUN", (0.0, 0.0, 5.0), 3.0)
    empty_scene.radiosity.quality = "DRAFT"
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    _, normals, _ = _corner_positions_and_normals(cube)
    light = corner_colors(cube.data, "Radiosity")[:, 0]
    top, sides = normals[:, 2] > 0.9, np.abs(normals[:, 2]) < 0.1
    assert top.sum() == 4 and light[top] == pytest.approx(3.0 / np.pi, rel=0.01)
    assert np.abs(light[sides]).max() < 0.01
