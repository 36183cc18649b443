"""Direct light of each light type against its closed form (docs/references.md, Blender's conventions)."""
import numpy as np
import pytest

from core.analytic_lights import area_light_area_m2, direct_irradiance, sampled_irradiance, spot_mask
from core.raycast import RayCaster
from core.scene import AreaLight, Material, PointLight, Scene, SpotLight, SunLight, World
from shapes import box_faces, quad

UP = np.array([0.0, 0.0, 1.0])


def plane_scene(lights, world=World(), occluder=False):
    """A 20 m floor at z = 0 (and optionally a 1 m square roof at z = 1 over the origin, facing down)."""
    triangles = [quad((-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0))]
    if occluder:
        triangles.append(quad((-0.5, -0.5, 1), (-0.5, 0.5, 1), (0.5, 0.5, 1), (0.5, -0.5, 1)))
    triangles = np.concatenate(triangles)
    return Scene(triangles, np.zeros(len(triangles), int), [Material("floor")], lights=lights, world=world)


def irradiance_at(scene, points, samples_per_edge=4):
    points = np.asarray(points, dtype=np.float64)
    caster = RayCaster(scene.triangles)
    return direct_irradiance(scene, caster, points, np.tile(UP, (len(points), 1)), 1e-5, samples_per_edge, seed=3)


FLOOR_POINTS = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.0], [-2.0, 3.0, 0.0]])


@pytest.mark.parametrize("radius", [0.0, 0.1])
def test_point_light_inverse_square_cosine(radius):
    """E = P cos(theta) / (4 pi r^2); 100 W at 1 m gives 7.958 W/m^2 (Cycles bakes 2.533 = E / pi)."""
    light = PointLight("bulb", (0.0, 0.0, 1.0), power_w=100.0, color=(1.0, 0.5, 0.25), radius_m=radius,
                       soft_falloff=False)
    measured = irradiance_at(plane_scene([light]), FLOOR_POINTS)
    offset = np.array(light.position) - FLOOR_POINTS
    r = np.linalg.norm(offset, axis=1)
    expected = 100.0 * (offset[:, 2] / r) / (4 * np.pi * r ** 2)
    assert measured == pytest.approx(expected[:, None] * [1.0, 0.5, 0.25], rel=1e-9)
    assert measured[0, 0] / np.pi == pytest.approx(2.533, abs=1e-3)


def test_soft_falloff_of_a_sized_point_light():
    """Blender's soft falloff: E = I cos(theta) / (r^2 + R^2)."""
    light = PointLight("bulb", (0.0, 0.0, 1.0), power_w=100.0, radius_m=0.25)
    measured = irradiance_at(plane_scene([light]), FLOOR_POINTS)[:, 0]
    offset = np.array(light.position) - FLOOR_POINTS
    r = np.linalg.norm(offset, axis=1)
    assert measured == pytest.approx(100.0 * (offset[:, 2] / r) / (4 * np.pi * (r ** 2 + 0.25 ** 2)), rel=1e-9)


def test_point_light_shadow():
    light = PointLight("bulb", (0.0, 0.0, 2.0), power_w=100.0)
    measured = irradiance_at(plane_scene([light], occluder=True), [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    assert measured[0] == pytest.approx(0.0, abs=1e-12)
    assert measured[1, 0] > 0


def test_sized_point_light_gives_a_penumbra():
    """Under the edge of the occluder the sized light is half hidden."""
    light = PointLight("bulb", (0.0, 0.0, 2.0), power_w=100.0, radius_m=0.2)
    edge = np.array([[1.0, 0.0, 0.0]])  # the occluder's edge x = 0.5 at z = 1 projects to x = 1 from z = 2
    unshadowed = irradiance_at(plane_scene([light]), edge, samples_per_edge=8)
    shadowed = irradiance_at(plane_scene([light], occluder=True), edge, samples_per_edge=8)
    assert shadowed[0, 0] / unshadowed[0, 0] == pytest.approx(0.5, abs=0.1)


def test_sun_strength_times_cosine():
    direction = np.array([1.0, 0.0, -1.0])
    light = SunLight("sun", tuple(direction), strength_w_m2=3.0, angle_rad=np.radians(0.5))
    measured = irradiance_at(plane_scene([light]), FLOOR_POINTS)
    assert measured == pytest.approx(3.0 * np.cos(np.radians(45.0)), rel=1e-9)


def test_sun_is_blocked_by_the_occluder():
    light = SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)
    measured = irradiance_at(plane_scene([light], occluder=True), [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    assert measured[:, 0] == pytest.approx([0.0, 3.0])


def test_spot_light_cone():
    """Inside the cone like a point light of the same power; outside dark; the blend region follows
    Cycles' smoothstep."""
    light = SpotLight("spot", (0.0, 0.0, 2.0), (0.0, 0.0, -1.0), power_w=100.0, spot_size_rad=np.radians(60),
                      spot_blend=0.5)
    points = np.array([[0.0, 0.0, 0.0], [0.9, 0.0, 0.0], [3.0, 0.0, 0.0]])
    measured = irradiance_at(plane_scene([light]), points)[:, 0]
    offset = np.array(light.position) - points
    r = np.linalg.norm(offset, axis=1)
    point_light = 100.0 * (offset[:, 2] / r) / (4 * np.pi * r ** 2)
    cos_axis = offset[:, 2] / r
    cos_half = np.cos(np.radians(30))
    t = np.clip((cos_axis - cos_half) / ((1 - cos_half) * 0.5), 0, 1)
    assert measured == pytest.approx(point_light * t * t * (3 - 2 * t), rel=1e-9)
    assert measured[0] == pytest.approx(point_light[0])
    assert 0 < measured[1] < point_light[1]
    assert measured[2] == 0.0
    assert spot_mask(np.array([1.0, cos_half - 1e-6]), np.radians(60), 0.0).tolist() == [1.0, 0.0]


@pytest.mark.parametrize("shape, size, size_y, form_factor", [
    ("SQUARE", 1.0, None, 0.239456),  # Howell: differential area to a centred parallel unit square at distance 1
    ("DISK", 2.0, None, 0.5),  # differential area to a coaxial disk of radius = height
    ("RECTANGLE", 1.0, 1.0, 0.239456),
    ("ELLIPSE", 2.0, 2.0, 0.5),
])
def test_area_light_closed_form(shape, size, size_y, form_factor):
    """E = pi L F with L = P / (pi A) (measured against a Cycles bake, docs/units.md): below a light 1 m up."""
    light = AreaLight("panel", (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), power_w=50.0, shape=shape, size_m=size,
                      size_y_m=size_y)
    measured = irradiance_at(plane_scene([light]), [[0.0, 0.0, 0.0]])[0, 0]
    radiance = 50.0 / (np.pi * area_light_area_m2(light))
    assert measured == pytest.approx(np.pi * radiance * form_factor, rel=2e-3)


def test_area_light_emits_from_one_side_only():
    light = AreaLight("panel", (0.0, 0.0, 1.0), (0.0, 0.0, 1.0), power_w=50.0)  # faces up, away from the floor
    assert irradiance_at(plane_scene([light]), FLOOR_POINTS).max() == 0.0


def test_area_light_soft_shadow_is_between_zero_and_full():
    light = AreaLight("panel", (0.0, 0.0, 2.0), (0.0, 0.0, -1.0), power_w=50.0, size_m=1.0)
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [4.0, 0.0, 0.0]])
    free = irradiance_at(plane_scene([light]), points, samples_per_edge=8)[:, 0]
    shadowed = irradiance_at(plane_scene([light], occluder=True), points, samples_per_edge=8)[:, 0]
    assert shadowed[0] == 0.0
    assert 0.2 * free[1] < shadowed[1] < 0.8 * free[1]
    assert shadowed[2] == pytest.approx(free[2])


def test_world_light_on_an_open_plane_is_pi_times_radiance():
    scene = plane_scene([], world=World((0.5, 0.25, 1.0)))
    measured = irradiance_at(scene, FLOOR_POINTS)
    assert measured == pytest.approx(np.pi * np.array([0.5, 0.25, 1.0])[None].repeat(3, 0), rel=1e-9)


def test_world_light_under_a_roof_is_reduced_by_its_cosine_weighted_solid_angle():
    """Under a 1 m square roof 1 m up, the roof hides F = 0.239456 of the cosine-weighted sky."""
    scene = plane_scene([], world=World((1.0, 1.0, 1.0)), occluder=True)
    measured = irradiance_at(scene, [[0.0, 0.0, 0.0]], samples_per_edge=32)[0, 0]
    assert measured == pytest.approx(np.pi * (1 - 0.239456), rel=0.01)


@pytest.mark.parametrize("light", [
    SunLight("sun", (0.0, 0.0, 1.0), strength_w_m2=3.0, angle_rad=0.1),
    PointLight("bulb", (0.0, 0.0, -1.0), power_w=100.0, radius_m=0.1),
    SpotLight("spot", (0.0, 0.0, -1.0), (0.0, 0.0, -1.0), power_w=100.0, spot_size_rad=1.0, spot_blend=0.1),
    AreaLight("panel", (0.0, 0.0, -1.0), (0.0, 0.0, -1.0), power_w=100.0, shape="SQUARE", size_m=0.5)])
def test_light_behind_every_point_gives_zero(light):
    """No point faces the light (all of it is behind the floor): zero, and no shadow rays to cast."""
    assert irradiance_at(plane_scene([light]), FLOOR_POINTS) == pytest.approx(0.0)


def octagonal_prism_smooth():
    """A smooth-shaded 8-sided prism (radius 1, height 2, axis z): flat facets whose corner normals point
    radially, as Blender's Shade Smooth gives a low-poly cylinder."""
    angles = 2 * np.pi * np.arange(9) / 8
    rim = lambda a, z: (np.cos(a), np.sin(a), z)
    radial = lambda a: (np.cos(a), np.sin(a), 0.0)
    triangles = np.concatenate([quad(rim(a, -1), rim(b, -1), rim(b, 1), rim(a, 1))
                                for a, b in zip(angles[:-1], angles[1:])])
    normals = np.array([[[radial(a), radial(b), radial(b)], [radial(a), radial(b), radial(a)]]
                        for a, b in zip(angles[:-1], angles[1:])]).reshape(-1, 3, 3)
    return triangles, normals


def random_prism_points(scene, prism_triangles, count):
    """(triangle, barycentric, point, shading normal) at ``count`` uniform random points on the prism's faces."""
    rng = np.random.default_rng(1)
    triangle = rng.integers(0, prism_triangles, count)
    uv = rng.random((count, 2))
    uv = np.where(uv.sum(axis=1, keepdims=True) > 1, 1 - uv, uv)
    barycentric = np.column_stack([1 - uv.sum(axis=1), uv])
    points = np.einsum("mc,mck->mk", barycentric, scene.triangles[triangle])
    return triangle, barycentric, points, scene.shading_normals(triangle, barycentric)


def test_a_smooth_low_poly_cylinder_is_lit_like_the_cylinder_its_normals_describe():
    """Sunlight across the axis of a smooth-shaded octagonal prism: every point gets E = S max(0, n_s . l), n_s
    its interpolated shading normal, as on a true cylinder (exact to rounding, 4000 random points). Shadow rays
    from the flat facets would hit the neighbouring facet near the terminator (the test checks that they do, up
    to 0.28 S off); started on the smooth surface the corner normals imply (core.terminator, as Cycles does)
    they do not."""
    from core.terminator import ShadowLift
    triangles, normals = octagonal_prism_smooth()
    direction = np.array([-1.0, -0.3, 0.0]) / np.linalg.norm([-1.0, -0.3, 0.0])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey")],
                  lights=[SunLight("sun", tuple(direction), strength_w_m2=3.0)], corner_normals=normals)
    triangle, barycentric, points, shading = random_prism_points(scene, len(triangles), 4000)
    expected = 3.0 * np.maximum(shading @ -direction, 0.0)
    caster = RayCaster(scene.triangles)
    flat = direct_irradiance(scene, caster, points, shading, 1e-5, 1, seed=0)[:, 0]
    lift = ShadowLift.at(scene, triangle, barycentric, shading)
    smooth = direct_irradiance(scene, caster, points, shading, 1e-5, 1, seed=0, lift=lift)[:, 0]
    assert np.abs(flat - expected).max() > 0.25 * 3.0
    assert smooth == pytest.approx(expected, abs=1e-9)


def test_a_smooth_low_poly_cylinder_lit_by_an_emissive_panel_gets_the_panel_s_closed_form():
    """The same prism facing a 6 x 6 m emissive panel (radiance 1) 15 m away, black world: every point gets
    E = pi L F(point -> panel) with its shading normal (Lambert's contour formula), within 1e-5 of the largest
    value, when shadow rays towards the panel's patches start on the smooth surface; from the flat facets some
    points near the terminator are more than 1% short."""
    from core import BakeSettings, bake
    from core.formfactor import point_to_polygon
    from core.terminator import ShadowLift
    triangles, normals = octagonal_prism_smooth()
    panel = quad((-15, -3, -3), (-15, 3, -3), (-15, 3, 3), (-15, -3, 3))
    scene = Scene(np.concatenate([triangles, panel]), np.r_[np.zeros(len(triangles), int), [1, 1]],
                  [Material("grey"), Material("glow", (0.0,) * 3, (1.0,) * 3)],
                  corner_normals=np.concatenate([normals, np.broadcast_to([1.0, 0.0, 0.0], (2, 3, 3))]))
    direct = bake(scene, BakeSettings(patch_size_m=2.0, element_size_m=1.0, adaptive_passes=0)).direct
    triangle, barycentric, points, shading = random_prism_points(scene, len(triangles), 3000)
    outline = np.broadcast_to([panel[0, 0], panel[0, 1], panel[0, 2], panel[1, 2]], (3000, 4, 3)).copy()
    expected = np.pi * point_to_polygon(points, shading, outline)
    smooth = direct.irradiance(points, shading, lift=ShadowLift.at(scene, triangle, barycentric, shading))[:, 0]
    flat = direct.irradiance(points, shading)[:, 0]
    assert np.abs(smooth - expected).max() < 1e-5 * expected.max()
    assert np.abs(flat - expected).max() > 0.01 * expected.max()


def test_a_point_half_a_millimetre_over_a_finely_cut_emitter_gets_its_closed_form():
    """A 13 x 10.5 cm emissive panel (radiance 1) cut into 32 triangles, facing up, and points facing down 0.5 mm
    over it on a line across its edge (a ceiling's rim over a light hung under its opening): E = pi L F(point ->
    rectangle) by the closed form (Howell B-3), within 1e-4 of pi L. Measured: 4e-16; off by 0.99 pi L (and
    491 x the closed form beside the edge) when the panel's pieces made point-sampled elements."""
    from core import BakeSettings, bake
    from test_nearfield import rectangle_factor
    x, y = np.linspace(0.0, 0.13, 5), np.linspace(0.0, 0.105, 5)
    panel = np.concatenate([quad((x[i], y[j], 0), (x[i + 1], y[j], 0), (x[i + 1], y[j + 1], 0), (x[i], y[j + 1], 0))
                            for i in range(4) for j in range(4)])
    floor = quad((-1, -1, -0.5), (-1, 1, -0.5), (1, 1, -0.5), (1, -1, -0.5))  # something to solve, facing down
    scene = Scene(np.concatenate([panel, floor]), np.r_[np.ones(len(panel), int), [0, 0]],
                  [Material("grey"), Material("glow", (0.0,) * 3, (1.0,) * 3)])
    direct = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.25, adaptive_passes=0)).direct
    points = np.stack([np.linspace(0.12, 0.14, 41), np.full(41, 0.05), np.full(41, 0.0005)], axis=1)
    down = np.broadcast_to([0.0, 0.0, -1.0], points.shape).copy()
    expected = np.pi * rectangle_factor(points, 0.0, 0.13, 0.0, 0.105)
    np.testing.assert_allclose(direct.irradiance(points, down)[:, 0], expected, atol=1e-4 * np.pi)


@pytest.mark.parametrize("exact_lights", [0, 2])
def test_sampled_lights_are_unbiased(exact_lights):
    """Four lights of different kinds, colours and strengths over a floor, a block casting their shadows: the
    mean over 40,000 floor points of the sampled estimate (a shadow ray to each of the ``exact_lights`` brightest
    lights at a point, and one to one of the others chosen by importance, divided by the chance of choosing it)
    equals the mean of every light's own shadow ray, within 2% per channel (its sampling error there is under
    0.5%). Without the division it would come out at about a quarter. With every light tested (exact_lights 4)
    no choice is left: each point's estimate is every light's own shadow ray."""
    floor = quad((-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0))
    block = np.concatenate(box_faces((-1, -1, 0), (1, 1, 2), inward=False))
    triangles = np.concatenate([floor, block])
    lights = [SunLight("sun", (0.3, 0.2, -1.0), 2.0, color=(1.0, 0.9, 0.7)),
              PointLight("lamp", (3.0, 0.0, 1.5), 400.0, color=(0.2, 0.4, 1.0), radius_m=0.1),
              SpotLight("spot", (-3.0, -3.0, 3.0), (0.5, 0.5, -1.0), 800.0, 1.0, color=(1.0, 0.3, 0.2)),
              AreaLight("panel", (0.0, 3.5, 2.5), (0.0, 0.0, -1.0), 300.0, size_m=1.0)]
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)], lights=lights,
                  world=World((0.1, 0.1, 0.1)))
    caster = RayCaster(scene.triangles)
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform(-5, 5, 40_000), rng.uniform(-5, 5, 40_000), np.zeros(40_000)])
    points = points[np.abs(points[:, :2]).max(axis=1) > 1.0]  # not under the block
    normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    every = direct_irradiance(scene, caster, points, normals, 1e-4, 1, 5)
    sampled = sampled_irradiance(scene, caster, points, normals, 1e-4, 5, exact_lights=exact_lights)
    assert sampled.mean(axis=0) == pytest.approx(every.mean(axis=0), rel=0.02)
    every_tested = sampled_irradiance(scene, caster, points, normals, 1e-4, 5, exact_lights=len(lights))
    assert np.abs(every_tested - every).max() < 1e-9 * every.max()


def test_a_room_s_corners_get_the_lamp_s_light_where_they_are():
    """Vertices where walls meet the floor lie in the floor's plane; they are lit where they are, not moved as if
    buried (the probe rays grazed the floor and met it from behind: walls' bottom corners came out 7-10% too
    bright, one 38%). A 60 W lamp in a 2 m room of near-black single quads (as Blender's rotated planes make
    them: triangulated so, and off by float32 round-off) gives every corner irradiance / pi =
    (P / 4 pi) cos(theta) / (pi d^2) (references.md), within 0.5%."""
    from core import BakeSettings, bake
    corners = [((-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1)), ((-1, 1, 1), (1, 1, 1), (1, -1, 1), (-1, -1, 1)),
               ((-1, -1, 1), (-1, -1, -1), (-1, 1, -1), (-1, 1, 1)), ((1, -1, -1), (1, -1, 1), (1, 1, 1), (1, 1, -1)),
               ((-1, 1, -1), (1, 1, -1), (1, 1, 1), (-1, 1, 1)), ((-1, -1, 1), (1, -1, 1), (1, -1, -1), (-1, -1, -1))]
    triangles = np.concatenate([quad(*face) for face in corners])  # floor, ceiling, -x, +x, +y, -y
    # Each wall tilted out by 1e-7 m at the floor and in at the ceiling, as float32 rotations leave them.
    walls, bottom = np.arange(4, 12), triangles[..., 2] == -1
    outward = -np.cross(triangles[walls, 1] - triangles[walls, 0], triangles[walls, 2] - triangles[walls, 0]) / 4
    triangles[walls] += 1e-7 * np.where(bottom[walls, :, None], 1.0, -1.0) * outward[:, None, :]
    lamp = np.array([-0.3, -0.2, 0.7])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("Black", (1e-6,) * 3)],
                  lights=[PointLight("Lamp", tuple(lamp), 60.0)])
    solution = bake(scene, BakeSettings(element_size_m=0.5, patch_size_m=0.5))
    triangle = np.repeat(np.arange(len(triangles)), 3)
    light = solution.evaluate(triangle, np.tile(np.eye(3), (len(triangles), 1)), direct_per_point=True)[:, 0]
    to_lamp = lamp - triangles.reshape(-1, 3)
    normal = np.repeat(np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]), 3, axis=0)
    cosine = np.einsum("mk,mk->m", normal, to_lamp) / (np.linalg.norm(normal, axis=1) *
                                                        np.linalg.norm(to_lamp, axis=1))
    expected = 60.0 / (4 * np.pi) * cosine / (np.pi * np.einsum("mk,mk->m", to_lamp, to_lamp))
    assert light == pytest.approx(expected, rel=0.005)
