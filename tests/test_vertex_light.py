"""Light at mesh corners (core.vertex_light) against closed forms (docs/references.md)."""
import numpy as np
import pytest

from core import BakeSettings, Material, Scene, SunLight, bake
from core.vertex_light import corner_light, projected_points
from shapes import box_faces, floor_under_near_sheet, quad

STRENGTH = 3.0


@pytest.mark.parametrize("method", ["interpolate", "gather", "auto"])
def test_furnace_corners(method):
    """Closed cube, every face emitting L = 1 with reflectance 0.5: the light is L / (1 - rho) = 2.0 everywhere,
    also at the cube's concave corners, where three faces meet (within 2%: the gather's noise and the emitters'
    sampling)."""
    triangles = np.concatenate(box_faces((0, 0, 0), (1, 1, 1)))
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("glow", (0.5,) * 3, (1.0,) * 3)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.25))
    light = corner_light(solution, np.repeat(np.arange(len(triangles)), 3), np.tile(np.eye(3), (len(triangles), 1)),
                         method, 16)
    assert light.mean(axis=0) == pytest.approx([2.0] * 3, rel=0.02)
    assert np.abs(light - 2.0).max() < 0.1


def test_corners_of_one_vertex_share_their_rays():
    """The six triangle corners at a flat floor's centre vertex hold one value, and it equals the value of that
    point evaluated alone (the rays are shared, not averaged)."""
    floor = np.concatenate([quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)) + offset
                            for offset in ([0, 0, 0], [-1, 0, 0], [0, -1, 0], [-1, -1, 0])])
    walls = np.concatenate(box_faces((-1, -1, 0), (1, 1, 1))[:4] + [box_faces((-1, -1, 0), (1, 1, 1))[5]])
    triangles = np.concatenate([floor, walls])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.3, 0.2, -1.0), strength_w_m2=STRENGTH)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    at_origin = np.flatnonzero(np.all(np.abs(floor) < 1e-12, axis=2))  # (triangle * 3 + corner) at (0, 0, 0)
    barycentric = np.eye(3)[at_origin % 3]
    light = corner_light(solution, at_origin // 3, barycentric, "gather", 16)
    assert len(at_origin) >= 4 and np.ptp(light, axis=0).max() == 0.0
    alone = corner_light(solution, at_origin[:1] // 3, barycentric[:1], "gather", 16)
    assert light[0] == pytest.approx(alone[0], rel=1e-12)


@pytest.mark.parametrize("method", ["interpolate", "gather", "auto"])
def test_corners_on_a_face_overlapping_in_their_plane_are_black_and_the_others_lit(method):
    """Floors A (x from -1 to 0.25 m) and B (x from -0.25 to 1 m) overlap in the plane z = 0, both facing up to a
    sun straight above of strength S. Cycles gives the overlap no light (every ray from one face meets the other
    at distance zero: benchmarks/coplanar_render.py): A's corners at x = 0.25 lie on B and hold 0, those at x = -1
    (beside C, which meets A along that edge) S / pi."""
    a = quad((-1, -1, 0), (0.25, -1, 0), (0.25, 1, 0), (-1, 1, 0))
    b = quad((-0.25, -1, 0), (1, -1, 0), (1, 1, 0), (-0.25, 1, 0))
    c = quad((-2, -1, 0), (-1, -1, 0), (-1, 1, 0), (-2, 1, 0))
    scene = Scene(np.concatenate([a, b, c]), [0, 0, 1, 1, 2, 2], [Material("grey", (0.5,) * 3)] * 3,
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=STRENGTH)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    light = corner_light(solution, np.repeat([0, 1], 3), np.tile(np.eye(3), (2, 1)), method, 8)[:, 0]
    x = a.reshape(-1, 3)[:, 0]
    assert light[x > 0] == pytest.approx(0.0, abs=1e-12)
    assert light[x < 0] == pytest.approx(STRENGTH / np.pi, rel=1e-6)


@pytest.mark.parametrize("method", ["interpolate", "gather", "auto"])
@pytest.mark.parametrize("facing", ["down", "up"])
def test_corners_under_a_sheet_nearer_than_the_ray_offset_are_black(facing, method):
    """A floor of 0.25 m quads 2 m square under a sun straight above (3 W/m^2) with a sheet 1 m square 0.2 to
    0.8 ray offsets above its middle (shapes.floor_under_near_sheet). Cycles' rays start at the corner and meet
    the sheet, so the corners under it are black; those 0.25 m or more beyond its edge hold E / pi = 3 / pi
    within 1% (the sheet's dark underside at grazing angles)."""
    steps = np.arange(-1.0, 1.0, 0.25)
    floor = np.concatenate([quad((x, y, 0), (x + 0.25, y, 0), (x + 0.25, y + 0.25, 0), (x, y + 0.25, 0))
                            for x in steps for y in steps])
    scene, _ = floor_under_near_sheet(floor, facing)
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    triangle = np.repeat(np.arange(len(floor)), 3)
    light = corner_light(solution, triangle, np.tile(np.eye(3), (len(floor), 1)), method, 8)[:, 0]
    distance = np.abs(floor.reshape(-1, 3)[:, :2]).max(axis=1)  # from the middle, along the floor's axes
    under, beyond = distance < 0.3, distance > 0.7
    assert np.count_nonzero(under) >= 24 and np.count_nonzero(beyond) >= 100
    assert light[under] == pytest.approx(0.0, abs=0.01 * 3 / np.pi)
    assert light[beyond] == pytest.approx(3 / np.pi, rel=0.01)


def _projected(solution, points, normals, centroids, method):
    """Light (irradiance / pi) at corners projected onto the scene's first two triangles within 0.1 m, as the
    add-on lights a modified mesh's corners (projected_points, then corner_light); 0 where none is found."""
    hit, bary = projected_points(solution, np.arange(2), points, normals, centroids, 0.1)
    light = np.zeros((len(points), 3))
    found = np.flatnonzero(hit >= 0)
    light[found] = corner_light(solution, hit[found], bary[found], method, 16)
    return light


@pytest.mark.parametrize("method", ["interpolate", "gather"])
def test_corners_above_and_below_the_floor_take_its_light_and_those_beside_it_stay_black(method):
    """Corners off the solved surface (a mesh whose modifiers changed its topology) take the light of the nearest
    surface point along their normal: a lone floor under a sun overhead of strength S holds S / pi everywhere
    (irradiance / pi; nothing else in the scene, so no indirect light)."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    scene = Scene(floor, np.zeros(2, int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=STRENGTH)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    points = np.array([[0.2, 0.3, 0.01], [-0.5, 0.1, -0.02], [0.9, -0.9, 0.0], [3.0, 0.0, 0.0]])
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    light = _projected(solution, points, normals, points, method)
    assert light[:3] == pytest.approx(STRENGTH / np.pi, rel=1e-3)
    assert light[3] == pytest.approx(0.0, abs=1e-12)  # its normal line misses the floor


def test_a_corner_beside_a_cut_back_edge_is_moved_into_its_face():
    """A corner 1 cm beyond the floor's edge (as a Bevel cuts a cube's edge back) whose normal line misses the
    floor is tried a little way towards its face's centroid, and takes the floor's light, S / pi."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    scene = Scene(floor, np.zeros(2, int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=STRENGTH)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    corner, centroid = np.array([[1.01, 1.01, 0.0]]), np.array([[0.0, 0.0, 0.0]])
    up = np.array([[0.0, 0.0, 1.0]])
    on_edge = _projected(solution, corner, up, corner, "interpolate")
    assert on_edge[0, 0] == 0.0
    light = _projected(solution, corner, up, centroid, "interpolate")
    assert light[0] == pytest.approx(STRENGTH / np.pi, rel=1e-3)


def test_near_share_is_half_at_a_walls_foot_and_none_on_open_ground():
    """Cosine-weighted rays from a point at the foot of a wall: the wall's plane halves the hemisphere, so half of
    them meet it at once (16 stratified rays: within 1/8); from the middle of a floor, far from the wall, none."""
    from core.vertex_light import near_share
    floor = quad((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0))
    wall = quad((2, -2, 0), (2, 2, 0), (2, 2, 2), (2, -2, 2))[:, ::-1]  # facing -x, into the room
    triangles = np.concatenate([floor, wall])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.3, 0.2, -1.0), strength_w_m2=STRENGTH)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.25))
    points = np.array([[2.0 - 1e-3, 0.3, 0.0], [-1.0, 0.0, 0.0]])
    share = near_share(solution, points, np.tile([0.0, 0.0, 1.0], (2, 1)), seed=0)
    assert share[0] == pytest.approx(0.5, abs=0.125) and share[1] == 0.0
