"""Lightmap texels against closed forms: rasterisation covers each triangle's area, the furnace and the sunlit
plane give their exact light, and a block standing on a floor leaks no light under it."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from core import BakeSettings, Material, PointLight, Scene, SceneError, SettingsError, SunLight, World, bake
from core.atlas import (AtlasSize, atlas_size, chart_areas, layout_atlas, modifier_uv_problem, pack_blocks,
                        pages_without_overlap, uv_area)
import core.adaptive_elements
import core.clusters
import core.lightmap
from core.bake import ray_offset_m
from core.lightmap import (LightmapSettings, TexelLight, bake_lightmap, dilate, finish_lightmap, light_chunk,
                           light_texels, plan_texels, sample_texels)
from core.errors import BakeCancelled
from core.geometry import tangent_frames, triangle_unit_normals
from core.gather import free_paths_m
from core.raycast import RayCaster
from core.sampling import cosine_hemisphere
from core.seams import bilinear_weights, seam_gap, seam_points
from core.solution_file import load_solution, save_solution
from core.surface_probes import other_face_test, overlap_test
from core.texels import footprint_barycentrics, footprint_inside, footprint_steps, rasterize, subcell_order
from shapes import (box_faces, floor_under_near_sheet, quad, sheet_before_sunlit_wall, soffit_into_open_block,
                    sunlit_arcade)


def as_mesh(triangles):
    positions = triangles.reshape(-1, 3)
    return positions, np.arange(len(positions)).reshape(-1, 3)


def lightmap_of(scene, parts, settings=LightmapSettings(), texels_per_metre=16.0, bake_settings=None, **callbacks):
    solution = bake(scene, bake_settings or BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    layout = layout_atlas([as_mesh(p) for p in parts], list(range(len(parts))),
                          AtlasSize(texels_per_metre, 0, 2, 4096))
    corner_uv = np.concatenate(layout.corner_uv)
    result = bake_lightmap(solution, np.arange(len(scene.triangles)), corner_uv, layout.width, layout.height,
                           settings, **callbacks)
    return result, layout, corner_uv


def test_rasterised_texels_cover_each_triangle_area():
    """Texels whose centre is inside a triangle number its UV area (in texels) within its perimeter's worth."""
    corner_uv = np.array([[[0.1, 0.1], [0.9, 0.2], [0.3, 0.8]]])
    texels = rasterize(corner_uv, 256, 256)
    (ax, ay), (bx, by) = corner_uv[0, 1] - corner_uv[0, 0], corner_uv[0, 2] - corner_uv[0, 0]
    area = 0.5 * abs(ax * by - ay * bx) * 256 ** 2
    inside = texels.centre_inside.sum()
    assert abs(inside - area) < 0.5 * 256 * 2.5  # perimeter ~2.5 UV units -> at most half a texel per edge texel
    assert len(texels.pixel) > inside  # partly covered texels are kept (conservative rasterisation)
    assert len(np.unique(texels.pixel)) == len(texels.pixel)


@pytest.mark.parametrize("max_size, least_pages", [(4096, 1), (40, 2)])
def test_shelf_packing_never_overlaps_and_opens_pages_when_full(max_size, least_pages):
    """Blocks never overlap on a page and every page stays within the maximum size; the 2,414 texels of blocks
    fit one 4096 page and need at least 2 pages of 40 x 40 (1,600 texels each)."""
    sizes = np.array([[30, 10], [10, 30], [25, 25], [5, 5], [40, 8], [20, 30], [30, 20]])
    offsets, page, width, height = pack_blocks(sizes, max_size)
    pages = page.max() + 1
    assert pages >= least_pages and (max_size > 1000) == (pages == 1) and max(width, height) <= max_size
    canvas = np.zeros((pages, height, width), dtype=int)
    for (x, y), (w, h), p in zip(offsets, sizes, page):
        canvas[p, y:y + h, x:x + w] += 1
    assert canvas.max() == 1


def test_objects_on_existing_uv_maps_share_a_page_only_where_their_texels_are_free():
    """First fit by covered texel centres: the left half of the square opens page 0; the whole square overlaps it
    and opens page 1; the right half fits page 0 beside the left one (they touch along u = 0.5); a second whole
    square opens page 2; a quarter in the lower left corner finds it taken on every page and opens page 3."""
    def rectangle(u0, v0, u1, v1):
        return np.array([[[u0, v0], [u1, v0], [u1, v1]], [[u0, v0], [u1, v1], [u0, v1]]], dtype=float)
    uvs = [rectangle(0, 0, 0.5, 1), rectangle(0, 0, 1, 1), rectangle(0.5, 0, 1, 1), rectangle(0, 0, 1, 1),
           rectangle(0, 0, 0.25, 0.25)]
    assert pages_without_overlap(uvs, 16, 16).tolist() == [0, 1, 0, 2, 3]


def test_the_atlas_size_takes_the_density_or_the_resolution_never_both():
    assert atlas_size(0.0, 0, 12.5, 4, 4096) == AtlasSize(12.5, 0, 4, 4096)  # neither: the preset's density
    assert atlas_size(40.0, 0, 12.5, 4, 4096).texels_per_metre == 40.0
    assert atlas_size(0.0, 512, 12.5, 4, 4096).resolution == 512
    with pytest.raises(SettingsError, match="both a texel density"):
        atlas_size(40.0, 512, 12.5, 4, 4096)
    with pytest.raises(SettingsError, match="above the maximum size 256"):
        atlas_size(0.0, 512, 12.5, 4, 256)


def test_existing_uv_pages_give_the_neediest_object_its_density():
    """1 m^2 on a quarter of the square at 64 texels per metre needs 64 x sqrt(1 / 0.25) = 128 texels a side;
    4 m^2 on the whole square needs 128 too; the larger need wins, clipped to the maximum size."""
    size = atlas_size(64.0, 0, 1.0, 4, 4096)
    assert size.existing_uv_side(np.array([1.0, 4.0]), np.array([0.25, 1.0])) == 128
    assert size.existing_uv_side(np.array([1.0, 9.0]), np.array([0.25, 1.0])) == 192
    assert atlas_size(64.0, 0, 1.0, 4, 100).existing_uv_side(np.array([1.0]), np.array([0.25])) == 100
    assert atlas_size(0.0, 300, 1.0, 4, 4096).existing_uv_side(np.array([1.0]), np.array([0.25])) == 300


def test_uv_area_of_the_unit_square_and_of_a_half_texel_triangle():
    square = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=float)
    assert uv_area(square) == pytest.approx(1.0, abs=1e-12)
    assert uv_area(square[:1] * 0.5) == pytest.approx(0.125, abs=1e-12)


def test_charts_are_the_triangles_joined_through_shared_uv_corners():
    """Two unit squares of two triangles each, apart in UV space, and a lone half-texel triangle: three charts of
    areas 1, 1 and 1/8 texel^2, whatever the triangles' order."""
    square = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=float)
    lone = square[:1] * 0.5 + [5.0, 5.0]
    uv = np.concatenate([square, square + [3.0, 0.0], lone])[[4, 1, 2, 0, 3]]
    np.testing.assert_allclose(np.sort(chart_areas(uv)), [0.125, 1.0, 1.0], atol=1e-12)


def test_modifier_uv_problems_are_told_apart_by_uv_area():
    """A quarter square of UVs for 1 m^2 at 0.25 UV per m^2 is what the surface needs: no problem. Two copies
    of it (a Mirror) double the area; a copy shrunk to a tenth (a Wireframe's strips) is under a quarter."""
    quarter = np.array([[[0, 0], [0.5, 0], [0.5, 0.5]], [[0, 0], [0.5, 0.5], [0, 0.5]]], dtype=float)
    assert modifier_uv_problem(quarter, quarter, 1.0, 0.25) is None
    assert "repeat" in modifier_uv_problem(np.concatenate([quarter, quarter + [0.5, 0]]), quarter, 1.0, 0.25)
    assert "squash" in modifier_uv_problem(quarter * np.sqrt(0.1), quarter, 1.0, 0.25)
    assert "do not keep" in modifier_uv_problem(None, quarter, 1.0, 0.25)


def test_a_block_over_the_maximum_size_is_refused():
    with pytest.raises(SettingsError, match="over the maximum atlas size of 32"):
        pack_blocks(np.array([[10, 10], [40, 8]]), 32)


def test_thousands_of_meshes_unwrap_without_xatlas_hanging():
    """xatlas wakes its worker threads to shut down without holding their mutex, so freeing an atlas just after
    generate() can lose the wake-up and join forever. Without SettlingAtlases, 10000 unwraps in a row hang more
    often than not; a hang here fails on the timeout."""
    script = ("import numpy as np; from core.atlas import AtlasSize, layout_atlas; "
              "square = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float), "
              "np.array([[0, 1, 2], [0, 2, 3]])); "
              "print(layout_atlas([square] * 10000, list(range(10000)), AtlasSize(8.0, 0, 1, 4096)).page_count)")
    result = subprocess.run([sys.executable, "-c", script], cwd=Path(__file__).parents[1], capture_output=True,
                            text=True, timeout=120)
    assert result.stdout.split() == ["1"], result.stderr


@pytest.mark.parametrize("indirect", ["gather", "interpolate"])
def test_furnace_lightmap(indirect):
    """Closed cube, every face emitting L with reflectance rho: B = pi L / (1 - rho) everywhere, so every texel
    holds H / pi = L / (1 - rho) (here 2.0 for L = 1, rho = 0.5) within 2%."""
    faces = box_faces((0, 0, 0), (1, 1, 1))
    triangles = np.concatenate(faces)
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("glow", (0.5,) * 3, (1.0,) * 3)])
    result, _, _ = lightmap_of(scene, faces, LightmapSettings(indirect=indirect, gather_samples_per_edge=4))
    values = result.light[result.covered]
    assert values.mean(axis=0) == pytest.approx([2.0] * 3, rel=0.02)
    assert np.abs(values - 2.0).max() < 0.1


def test_mean_free_path_is_cauchys_mean_chord():
    """Inside a closed convex box, cosine-weighted rays from points spread by area travel 4 V / S on the mean
    (Cauchy's formula): 24 / 22 m for a 1 x 2 x 3 m box, within 2% (16,384 rays; the outward rays escape)."""
    triangles = np.concatenate(box_faces((0, 0, 0), (1, 2, 3)))
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("glow", (0.5,) * 3, (1.0,) * 3)])
    caster = RayCaster(triangles)
    assert free_paths_m(scene, caster, 1e-6, 0).mean() == pytest.approx(24 / 22, rel=0.02)


def test_median_free_path_between_parallel_plates_is_root_two_times_the_gap():
    """Between two parallel plates 0.1 m apart and 40 m wide, a cosine-weighted ray from either travels h / cos,
    and cos^2 is uniform on (0, 1), so the median path is sqrt(2) h; within 2% (16,384 rays; those that leave
    past the plates' edges, a few in a thousand, are not counted)."""
    triangles = np.concatenate([quad((-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)),
                                quad((-20, -20, 0.1), (-20, 20, 0.1), (20, 20, 0.1), (20, -20, 0.1))])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("glow", (0.5,) * 3, (1.0,) * 3)])
    caster = RayCaster(triangles)
    assert np.median(free_paths_m(scene, caster, 1e-6, 0)) == pytest.approx(np.sqrt(2) * 0.1, rel=0.02)


@pytest.mark.parametrize("element_size_m, expected", [(0.1, "interpolate"), (0.5, "gather")])
def test_auto_gathers_where_elements_are_coarse_next_to_the_free_path(element_size_m, expected):
    """A 1 m furnace cube, median free path 0.67 m: with 0.1 m elements it spans 6.7 elements and the texels
    are interpolated; with 0.5 m elements, 1.3 (under GATHER_BELOW_ELEMENTS), they are gathered. Either way every
    texel holds the furnace's L / (1 - rho) = 2.0."""
    faces = box_faces((0, 0, 0), (1, 1, 1))
    triangles = np.concatenate(faces)
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("glow", (0.5,) * 3, (1.0,) * 3)])
    result, _, _ = lightmap_of(scene, faces, LightmapSettings(indirect="auto", gather_samples_per_edge=4),
                               bake_settings=BakeSettings(patch_size_m=0.5, element_size_m=element_size_m))
    assert result.indirect == expected
    assert result.light[result.covered].mean(axis=0) == pytest.approx([2.0] * 3, rel=0.02)


def test_sunlit_plane_is_exact_and_dilated():
    """A plane under a sun at 30 degrees from the zenith holds E cos / pi in every texel, padding included."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    sun = SunLight("sun", (0.0, -np.sin(np.radians(30)), -np.cos(np.radians(30))), strength_w_m2=3.0)
    scene = Scene(floor, np.zeros(2, int), [Material("grey", (0.5,) * 3)], lights=[sun])
    result, _, _ = lightmap_of(scene, [floor])
    expected = 3.0 * np.cos(np.radians(30)) / np.pi
    assert result.light[result.covered] == pytest.approx(expected, rel=1e-6)
    grown = dilate(result.light, result.covered, 1)[1]
    assert grown.sum() > result.covered.sum()


def test_texels_and_corners_take_light_by_their_shading_normal():
    """A plane whose corner normals all lean 30 degrees towards a sun 30 degrees from the zenith (custom normals,
    or smooth shading on a curved mesh): every texel and every corner faces the sun through its shading normal and
    holds E / pi = 3 / pi (flat shading would give 3 cos 30 / pi), as Cycles bakes it."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    towards_sun = np.array([0.0, np.sin(np.radians(30)), np.cos(np.radians(30))])
    sun = SunLight("sun", tuple(-towards_sun), strength_w_m2=3.0)
    scene = Scene(floor, np.zeros(2, int), [Material("grey", (0.5,) * 3)], lights=[sun],
                  corner_normals=np.broadcast_to(towards_sun, (2, 3, 3)))
    result, _, _ = lightmap_of(scene, [floor])
    assert result.light[result.covered] == pytest.approx(3.0 / np.pi, rel=1e-6)
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    corners = solution.evaluate(np.repeat([0, 1], 3), np.tile(np.eye(3), (2, 1)), direct_per_point=True)
    assert corners == pytest.approx(3.0 / np.pi, rel=1e-6)


def test_a_page_is_lit_in_steps_with_progress_and_esc_between_them(monkeypatch):
    """Lit 100 texels per step, the sunlit plane still holds E cos / pi in every texel (no step is skipped or
    lit twice); progress rises to 1, and a cancel between steps stops the bake."""
    monkeypatch.setattr(core.lightmap, "TEXELS_PER_CHUNK", 100)
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    sun = SunLight("sun", (0.0, -np.sin(np.radians(30)), -np.cos(np.radians(30))), strength_w_m2=3.0)
    scene = Scene(floor, np.zeros(2, int), [Material("grey", (0.5,) * 3)], lights=[sun])
    fractions = []
    result, _, _ = lightmap_of(scene, [floor], progress=lambda fraction, _: fractions.append(fraction))
    assert result.light[result.covered] == pytest.approx(3.0 * np.cos(np.radians(30)) / np.pi, rel=1e-6)
    assert len(fractions) == -(-result.texel_count // 100) and np.all(np.diff(fractions) > 0) and fractions[-1] == 1
    calls = []
    with pytest.raises(BakeCancelled):
        lightmap_of(scene, [floor], cancelled=lambda: calls.append(1) or len(calls) > 3)


def test_no_light_leaks_under_a_block_on_the_floor():
    """Floor texels under a closed block see no light (the block's inside is dark), and texels just outside it
    are lit like the open floor near the block (no dark blotch from samples inside the block)."""
    floor = quad((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0))
    block = np.concatenate(box_faces((-0.5, -0.5, 0), (0.5, 0.5, 1), inward=False))
    triangles = np.concatenate([floor, block])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    result, layout, corner_uv = lightmap_of(scene, [floor, block], LightmapSettings(indirect="interpolate"))
    texels = rasterize(corner_uv[:2], layout.width, layout.height)
    points = np.einsum("mc,mck->mk", texels.barycentric, floor[texels.triangle])
    light = result.light.reshape(-1, 3)[texels.pixel, 0]
    under = (np.abs(points[:, :2]) < 0.4).all(axis=1)  # more than a texel (1/16 m) inside the block's footprint
    beside = (np.abs(points[:, :2]).max(axis=1) > 0.55) & (np.abs(points[:, :2]).max(axis=1) < 0.65)
    sun_only = 3.0 / np.pi
    assert light[under].max() < 0.02 * sun_only
    assert light[beside].min() > 0.95 * sun_only


def test_texels_under_a_batten_narrower_than_their_reach_read_black():
    """An open-bottomed batten 10 cm wide and 1 cm tall lying on a sunlit floor, at 16 texels per metre: the
    floor under it is inside closed geometry (batten and floor), where Cycles' samples see the batten's inside.
    Every point under it lies within a texel of an edge, so each is pushed out beside the batten; a texel whose
    footprint lies wholly under it still reads black (under 2% of the sun's E / pi), and texels clear of it read
    the sun (over 95%)."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    batten = np.concatenate([face for k, face in enumerate(box_faces((-0.6, -0.05, 0), (0.6, 0.05, 0.01),
                                                                     inward=False)) if k != 4])
    triangles = np.concatenate([floor, batten])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    result, layout, corner_uv = lightmap_of(scene, [floor, batten], LightmapSettings(indirect="interpolate"))
    texels = rasterize(corner_uv[:2], layout.width, layout.height)
    points = np.einsum("mc,mck->mk", texels.barycentric, floor[texels.triangle])
    light = result.light.reshape(-1, 3)[texels.pixel, 0]
    half_diagonal = np.sqrt(0.5) / 16
    along = np.abs(points[:, 0]) < 0.5
    under = along & (np.abs(points[:, 1]) < 0.05 - half_diagonal)
    clear = along & (np.abs(points[:, 1]) > 0.05 + 2 * half_diagonal)
    assert under.sum() >= 10 and result.moved.ravel()[texels.pixel[under]].all()
    sun_only = 3.0 / np.pi
    assert light[under].max() < 0.02 * sun_only
    assert light[clear].min() > 0.95 * sun_only


def test_the_bottom_of_a_box_resting_on_a_floor_bakes_black():
    """A box standing on a single-sided floor under a sky: its bottom face lies on the floor, so no light reaches it
    (Cycles bakes it black), although below the floor there is only sky; its sides see the sky (half of it: 0.2)."""
    floor = quad((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0))
    block = np.concatenate(box_faces((-0.5, -0.5, 0), (0.5, 0.5, 1), inward=False))
    triangles = np.concatenate([floor, block])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  world=World((0.4, 0.4, 0.4)))
    result, layout, corner_uv = lightmap_of(scene, [floor, block], LightmapSettings(indirect="interpolate"))
    texels = rasterize(corner_uv[2:], layout.width, layout.height)
    normal_z = triangle_unit_normals(block[texels.triangle])[:, 2]
    light = result.light.reshape(-1, 3)[texels.pixel, 0]
    assert np.all(light[normal_z < -0.5] == 0.0)
    assert light[np.abs(normal_z) < 0.5].min() > 0.1  # a side sees half the sky (0.2) and the floor
    # Floor texels whose centre is just under the box were pushed out to the floor beside it: they take its light
    # on the share of their footprint outside the box, the darker the further under it (Cycles' samples under the
    # box see its inside), none brighter than the open floor.
    floor_texels = rasterize(corner_uv[:2], layout.width, layout.height)
    pushed = result.moved.ravel()[floor_texels.pixel]
    floor_light = result.light.reshape(-1, 3)[floor_texels.pixel, 0]
    assert pushed.any() and floor_light[pushed].max() <= floor_light[~pushed].max() + 1e-6


def test_sheets_back_to_back_stay_lit():
    """A single-sided sheet facing up and a decal 0.2 mm behind it facing down (as a decal a few millimetres
    behind a single-sided wall in a large level): their planes coincide within the contact tolerance, but each
    faces open sky, so each bakes the sky's radiance (0.4, no surface in view), not the black of a contact."""
    sheet = quad((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0))
    decal = quad((-0.5, -0.5, -2e-4), (-0.5, 0.5, -2e-4), (0.5, 0.5, -2e-4), (0.5, -0.5, -2e-4))
    triangles = np.concatenate([sheet, decal])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  world=World((0.4, 0.4, 0.4)))
    result, layout, corner_uv = lightmap_of(scene, [sheet, decal], LightmapSettings(indirect="interpolate"))
    texels = rasterize(corner_uv, layout.width, layout.height)
    light = result.light.reshape(-1, 3)[texels.pixel, 0]
    assert np.abs(light - 0.4).max() < 0.02 * 0.4


def test_faces_overlapping_in_one_plane_bake_black_and_faces_meeting_at_an_edge_do_not():
    """Floors A (x from -1 to 0.25 m) and B (x from -0.275 to 1 m) of two objects overlap in the plane z = 0, both
    facing up to a sun straight above (3 W/m^2), and floor C meets A along x = -1. Cycles bakes and renders the
    overlap black (every ray from one face meets the other at distance zero: benchmarks/coplanar_render.py), and
    the rest E / pi. A's texels are 1/16 m across x: columns 12 on lie on the overlap (0), columns up to 10 hold
    E / pi, the seam with C included; column 11 has 0.4 of its width on the overlap, which Draft's 3 x 3 points
    per texel measure to within half their spacing (1/6), away from the texels that A's diagonal crosses (those
    hold the share of their part inside their triangle, as in Cycles)."""
    a = quad((-1, -1, 0), (0.25, -1, 0), (0.25, 1, 0), (-1, 1, 0))
    b = quad((-0.275, -1, 0), (1, -1, 0), (1, 1, 0), (-0.275, 1, 0))
    c = quad((-2, -1, 0), (-1, -1, 0), (-1, 1, 0), (-2, 1, 0))
    scene = Scene(np.concatenate([a, b, c]), [0, 0, 1, 1, 2, 2], [Material("grey", (0.5,) * 3)] * 3,
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5, light_samples_per_edge=2))
    columns, rows = 20, 32
    uv = np.stack([(a[..., 0] + 1) / 1.25, (a[..., 1] + 1) / 2], axis=-1)  # A alone fills the page
    share = bake_lightmap(solution, np.array([0, 1]), uv, columns, rows,
                          LightmapSettings(indirect="interpolate")).light[..., 0] / (3.0 / np.pi)
    assert share[:, 12:] == pytest.approx(0.0, abs=1e-9)
    assert share[:, :11] == pytest.approx(1.0, rel=1e-6)
    row_y = (np.arange(rows) + 0.5) / rows * 2 - 1
    away = np.abs(row_y - (-1 + 2 * (1 - 0.28125) / 1.25)) > 0.1  # from where A's diagonal crosses column 11
    assert np.abs(share[away, 11] - 0.6).max() <= 1 / 6


def test_gather_rays_landing_on_faces_overlapping_in_one_plane_see_them_black():
    """Cycles renders the overlap of two faces in one plane black (benchmarks/coplanar_render.py), so a final
    gather ray that lands there must read no light. Floors A (x from -1 to 0.25 m) and B (x from -0.275 to 1 m)
    overlap in the plane z = 0 under a sun straight above (3 W/m^2), reflectance 0.5, nothing else in the scene:
    landing on either from above, a ray reads rho E = 1.5 W/m^2 off the overlap and 0 on it; from below, 0."""
    a = quad((-1, -1, 0), (0.25, -1, 0), (0.25, 1, 0), (-1, 1, 0))
    b = quad((-0.275, -1, 0), (1, -1, 0), (1, 1, 0), (-0.275, 1, 0))
    scene = Scene(np.concatenate([a, b]), [0, 0, 1, 1], [Material("grey", (0.5,) * 3)] * 2,
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5, light_samples_per_edge=2))
    x, y = np.meshgrid(np.linspace(-0.96, 0.96, 33), [-0.5, 0.1, 0.7])  # none on the overlap's edges
    points = np.stack([x.ravel(), y.ravel()], axis=1)
    corners = scene.triangles[:, :, :2]  # every (point, triangle) pair with the point in the triangle
    edge1, edge2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    relative = points[:, None, :] - corners[None, :, 0]
    det = edge1[:, 0] * edge2[:, 1] - edge1[:, 1] * edge2[:, 0]
    u = (relative[..., 0] * edge2[:, 1] - relative[..., 1] * edge2[:, 0]) / det
    v = (edge1[:, 0] * relative[..., 1] - edge1[:, 1] * relative[..., 0]) / det
    point, triangle = np.nonzero((u > 1e-6) & (v > 1e-6) & (u + v < 1 - 1e-6))
    u, v = u[point, triangle], v[point, triangle]
    barycentric = np.stack([1 - u - v, u, v], axis=1)
    overlap = (points[point, 0] > -0.275) & (points[point, 0] < 0.25)
    assert overlap.sum() > 20 and (~overlap).sum() > 20
    for side, expected in ((0, np.where(overlap, 0.0, 1.5)), (1, np.zeros(len(point)))):
        reflected = solution.reflected_radiosity(triangle, barycentric, np.full(len(point), side))
        assert reflected[:, 0] == pytest.approx(expected, abs=1e-9)


def test_overlap_test_agrees_with_the_test_of_whole_planes():
    """core.surface_probes.overlap_test, which tests a point against the overlapping triangles in its cell of its
    own triangle alone, finds the points other_face_test finds, of 8000 random points on: a floor of two
    triangles, a tile lying in its plane inside the first (facing up or down), 16 small tiles on the second (so
    that its overlapping triangles are binned on a grid), a tile 1 cm above the floor (outside the plane
    tolerance) and a wall meeting the floor at its edge. The points on the tiles and under them are covered."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    tile = np.array([[[0.3, -0.6, 0], [0.6, -0.6, 0], [0.6, -0.3, 0]]])  # inside the floor's first triangle
    small = np.array([[[x, y, 0], [x + 0.1, y, 0], [x + 0.1, y + 0.1, 0]]
                      for x in np.linspace(-0.95, -0.05, 8) for y in (0.3, 0.6)])
    raised = tile[:, :, [1, 0, 2]] + np.array([-0.9, 0.0, 0.01])  # facing down, 1 cm up
    wall = quad((-1, -1, 0), (-1, 1, 0), (-1, 1, 1), (-1, -1, 1))
    rng = np.random.default_rng(3)
    for flipped in (False, True):
        placed = tile[:, ::-1] if flipped else tile
        triangles = np.concatenate([floor, placed, raised, wall, small])
        triangle = rng.integers(0, len(triangles), 8000)
        u, v = rng.random((2, 8000, 1))
        u, v = np.where(u + v > 1, 1 - u, u), np.where(u + v > 1, 1 - v, v)
        barycentric = np.concatenate([1 - u - v, u, v], axis=1)
        points = np.einsum("mc,mck->mk", barycentric, triangles[triangle])
        covered = overlap_test(triangles, 0.004)(triangle, barycentric)
        assert covered.tolist() == other_face_test(triangles, 0.004)(triangle, points).tolist()
        under_tile = (points[:, 0] < 0.6) & (points[:, 1] > -0.6) & (points[:, 0] - points[:, 1] > 0.9)
        assert np.all(covered[triangle == 2]) and np.all(covered[triangle == 0] == under_tile[triangle == 0])
        assert covered[triangle == 0].sum() > 5  # 2.25% of its area: 8 points expected
        assert np.all(covered[triangle >= 6]) and 5 < covered[triangle == 1].sum() < 30  # 4%: 15 expected
        assert not covered[(triangle > 2) & (triangle < 6)].any()


def test_of_two_copies_of_a_floor_a_micrometre_apart_the_upper_is_lit_and_the_lower_black():
    """Two copies of a floor, one 1 um above the other (as copies whose vertices differ by round-off lie), under
    a sun straight above (3 W/m^2): the upper copy covers the lower, whose rays all meet it, and holds E / pi; the
    lower holds 0. Both lie in one plane to the contact tolerance."""
    lower = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    upper = lower + np.array([0.0, 0.0, 1e-6])
    scene = Scene(np.concatenate([lower, upper]), [0, 0, 1, 1], [Material("grey", (0.5,) * 3)] * 2,
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5, light_samples_per_edge=2))
    uv = (lower[..., :2] + 1) / 2
    for triangles, expected in (([0, 1], 0.0), ([2, 3], 3.0 / np.pi)):
        light = bake_lightmap(solution, np.array(triangles), uv, 16, 16, LightmapSettings(indirect="interpolate"))
        assert light.light[light.covered][:, 0] == pytest.approx(expected, abs=1e-6)


def test_same_seed_same_lightmap():
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    block = np.concatenate(box_faces((-0.3, -0.3, 0), (0.3, 0.3, 0.6), inward=False))
    triangles = np.concatenate([floor, block])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.3, 0.2, -1.0), strength_w_m2=3.0, angle_rad=0.1)])
    first = lightmap_of(scene, [floor, block], LightmapSettings(gather_samples_per_edge=3))[0].light
    second = lightmap_of(scene, [floor, block], LightmapSettings(gather_samples_per_edge=3))[0].light
    assert np.array_equal(first, second)


def test_texels_planned_during_the_solve_make_the_same_page():
    """The texels planned from the scene alone, on the solve's ray-casting scene while it solves (as the add-on
    does), then lit: the same page, bit for bit, as planning them after the solve, with the automatic indirect
    method settled from the solution; and the solve's ray count leaves out the planning's rays."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    block = np.concatenate(box_faces((-0.3, -0.3, 0), (0.3, 0.3, 0.6), inward=False))
    triangles = np.concatenate([floor, block])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.3, 0.2, -1.0), strength_w_m2=3.0, angle_rad=0.1)])
    settings = BakeSettings(patch_size_m=1.0, element_size_m=0.5, threads=2)
    automatic = LightmapSettings(indirect="auto")
    whole, layout, corner_uv = lightmap_of(scene, [floor, block], automatic, bake_settings=settings)
    alone = bake(scene, settings).rays_cast
    caster = RayCaster(triangles, threads=2)
    planning = caster.with_own_count()
    plan = sample_texels(scene, planning, ray_offset_m(scene), np.arange(len(triangles)), corner_uv, layout.width,
                         layout.height, automatic)
    solution = bake(scene, settings, caster=caster)
    assert plan.settings.indirect == "auto" and planning.rays_cast > 0 and solution.rays_cast == alone
    page = light_texels(solution, plan)
    assert page.indirect == whole.indirect and np.array_equal(page.light, whole.light)


def test_chunks_lit_in_any_order_from_a_saved_solution_make_the_same_page(monkeypatch, tmp_path):
    """The texel stage as independent tasks, as a render farm runs it: the solution written to a file and read
    back (a new ray-casting scene built from it), the page's chunks lit from that copy in reverse order, then put
    together. The page equals the one-process bake (chunks two at a time, core.parallel) bit for bit, gather and
    sub-texel shadow rays included (both are seeded per chunk)."""
    monkeypatch.setattr(core.lightmap, "TEXELS_PER_CHUNK", 300)
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    block = np.concatenate(box_faces((-0.3, -0.3, 0), (0.3, 0.3, 0.6), inward=False))
    triangles = np.concatenate([floor, block])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.3, 0.2, -1.0), strength_w_m2=3.0, angle_rad=0.1)],
                  world=World((0.2, 0.3, 0.4)))
    settings = LightmapSettings(indirect="gather", gather_samples_per_edge=3)
    two_threads = BakeSettings(patch_size_m=1.0, element_size_m=0.5, threads=2)
    whole, layout, corner_uv = lightmap_of(scene, [floor, block], settings, bake_settings=two_threads)
    save_solution(bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5)), str(tmp_path / "solved"))
    solution = load_solution(str(tmp_path / "solved"))
    plan = plan_texels(solution, np.arange(len(triangles)), corner_uv, layout.width, layout.height, settings)
    assert plan.chunk_count >= 3
    light = TexelLight.zeros(plan.texel_count)
    for index in reversed(range(plan.chunk_count)):
        light.put(plan.chunk(index), light_chunk(solution, plan, index))
    assert np.array_equal(finish_lightmap(solution, plan, light).light, whole.light)


def test_a_missing_or_foreign_solution_file_is_named(tmp_path):
    (tmp_path / "foreign").write_bytes(b"not a solution")
    for path in (tmp_path / "missing", tmp_path / "foreign"):
        with pytest.raises(SceneError, match=str(path)):
            load_solution(str(path))


def test_seams_and_contacts_between_touching_cubes_on_a_floor():
    """Two unit cubes side by side on a floor in sunlight. Texels far apart in the atlas that sample the same place
    (a chart border, or where the two cubes' coplanar faces meet) agree to 2% (sunlight is exact there: any jump
    is a seam artefact); the face of one cube that the sun would light but the other cube covers stays dark (no
    leak); floor texels in front of the cubes are as lit as the open floor (no dark blotch from samples inside)."""
    floor = quad((-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0))
    left = np.concatenate(box_faces((-1, -0.5, 0), (0, 0.5, 1), inward=False))
    right = np.concatenate(box_faces((0, -0.5, 0), (1, 0.5, 1), inward=False))
    triangles = np.concatenate([floor, left, right])
    sun = SunLight("sun", (0.3, 0.6, -0.8), strength_w_m2=3.0)
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)], lights=[sun])
    result, layout, corner_uv = lightmap_of(scene, [floor, left, right], LightmapSettings(indirect="interpolate"),
                                            16.0, BakeSettings(patch_size_m=0.5, element_size_m=0.25))
    texels = rasterize(corner_uv, layout.width, layout.height)
    points = np.einsum("mc,mck->mk", texels.barycentric, triangles[texels.triangle])
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])[texels.triangle]
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    light = result.light.reshape(-1, 3)[texels.pixel, 0]
    x, y = texels.pixel % layout.width, texels.pixel // layout.width
    cell = np.round(points / (0.25 / 16.0)).astype(np.int64)  # a quarter texel
    order = np.lexsort(cell.T[::-1])
    same = (np.diff(cell[order], axis=0) == 0).all(axis=1)
    a, b = order[:-1][same], order[1:][same]
    apart = (np.abs(x[a] - x[b]) + np.abs(y[a] - y[b]) > 3) & ((normals[a] * normals[b]).sum(axis=1) > 0.99)
    assert apart.sum() > 20
    assert np.abs(light[a][apart] - light[b][apart]).max() <= 0.02 * np.maximum(light[a][apart], light[b][apart]).max()
    covered_face = (normals[:, 0] < -0.99) & (np.abs(points[:, 0]) < 1e-9) & (np.abs(points[:, 1]) < 0.4) & \
        (points[:, 2] > 0.1) & (points[:, 2] < 0.9)  # the right cube's -x face, against the left cube
    assert covered_face.sum() > 50
    assert light[covered_face].max() < 0.01 * light.max()
    on_floor = np.abs(points[:, 2]) < 1e-9
    in_front = on_floor & (points[:, 1] > -0.65) & (points[:, 1] < -0.55) & (np.abs(points[:, 0]) < 0.8)
    open_floor = on_floor & (points[:, 1] < -2.0)
    assert light[in_front].min() > 0.95 * np.median(light[open_floor])


def test_a_texel_where_a_texture_edge_meets_a_shadow_edge_is_reflectance_weighted():
    """Cycles' Diffuse bake without Color divides the light x colour its samples gather by the colour they
    gather. A 2 x 2 m floor mapped onto 32 x 32 texels, its texture 0.8 left of x_e and 0.05 right of it, a
    shadow-only slab shading x > x_e from a sun overhead (E = 3 W/m^2). Texel (16, 8) has 2/3 of its footprint left
    of x_e (x_e sits 1/6 texel right of its centre, between its sub-texel columns): it holds
    (0.8 x 2/3 x E/pi) / (0.8 x 2/3 + 0.05 x 1/3) = 0.9697 E/pi, not the plain mean 2/3 E/pi (within 0.5%)."""
    from core.texture import ReflectanceTexture
    width = 32
    u_edge = (16.5 + 1 / 6) / width
    x_edge = 2 * u_edge - 1
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    slab = quad((x_edge, -2, 0.5), (3, -2, 0.5), (3, 2, 0.5), (x_edge, 2, 0.5))
    floor_uv = (floor[..., :2] + 1) / 2
    pixels = np.full((1, 96, 3), 0.05)
    pixels[:, :round(u_edge * 96)] = 0.8  # the texture's edge at u_edge exactly (50 of 96 pixels)
    materials = [Material("checker", (0.5,) * 3, texture=ReflectanceTexture(pixels)), Material("slab", (0.5,) * 3)]
    scene = Scene(np.concatenate([floor, slab]), [0, 0, 1, 1], materials, casts_only=[False, False, True, True],
                  triangle_uv=np.concatenate([floor_uv, np.zeros((2, 3, 2))]),
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    result = bake_lightmap(solution, np.array([0, 1]), floor_uv, width, width, LightmapSettings(indirect="interpolate"))
    row = result.light[8, :, 0]  # away from the floor's diagonal, where sub-points fold into one triangle
    lit = 3.0 / np.pi
    assert row[:16] == pytest.approx(lit, rel=1e-6) and np.all(row[17:] == 0.0)
    assert row[16] == pytest.approx(0.8 * 2 / 3 / (0.8 * 2 / 3 + 0.05 / 3) * lit, rel=0.005)


def test_reflectance_at_a_point_reads_its_texture():
    """A textured quad returns the texel under each point's interpolated UV; an untextured one its colour."""
    from core.texture import ReflectanceTexture
    pixels = np.array([[[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]]])  # one row, two texels: u < 0.5 and u >= 0.5
    floor = quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0))
    scene = Scene(np.concatenate([floor, floor + [0, 0, 1]]), [0, 0, 1, 1],
                  [Material("textured", (0.9,) * 3, texture=ReflectanceTexture(pixels)), Material("plain", (0.7,) * 3)],
                  triangle_uv=np.concatenate([floor[..., :2], np.full((2, 3, 2), np.nan)]), world=World((1.0,) * 3))
    bary = np.array([[0.8, 0.1, 0.1], [0.1, 0.8, 0.1], [1 / 3, 1 / 3, 1 / 3]])
    values = scene.reflectance_at(np.array([0, 0, 2]), bary)
    assert values == pytest.approx(np.array([[0.1, 0.2, 0.3], [0.4, 0.5, 0.6], [0.7, 0.7, 0.7]]))


def test_texels_beside_an_open_shell_are_not_pushed_through_it():
    """A floor beside a single-sided wall whose normal faces the sunlit outside, its inside in the shadow of the
    wall and a roof, baked at 30 cm texels. A texel centred d = 12 cm inside the wall meets the wall's back face
    along the floor, but it is not enclosed, so it stays where it is. Cycles jitters a texel's samples over its
    whole footprint (a one-texel box), so such a texel holds the sunlit floor's light times the share of its
    footprint beyond the wall, max(0, 1/2 - d / 0.3 m) = 0.1; ours must not exceed that by more than 5% of the
    sunlit light (pushed through the wall, it held all of it). (12 cm, not 10: our 3 x 3 sub-texel points lie at
    +-10 cm, and a wall exactly there would split them by rounding.) Texels across the floor's diagonal are left
    out: Cycles takes the mean over a texel's part in its own triangle, of which the sunlit strip is a larger
    share."""
    x, texel_m = 0.12, 0.3  # the wall's position: texel centres fall on multiples of 0.3 m, some 12 cm inside it
    floor = quad((-3, -5, 0), (3, -5, 0), (3, 5, 0), (-3, 5, 0))
    wall = quad((x, -5, 0), (x, 5, 0), (x, 5, 2), (x, -5, 2))  # normal +x: the sunlit outside
    roof = quad((-3, -5, 2), (x, -5, 2), (x, 5, 2), (-3, 5, 2))
    triangles = np.concatenate([floor, wall, roof])
    sun = SunLight("sun", (-0.3, 0.0, -1.0), 3.0)  # from the +x side
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("plaster", (0.5,) * 3)], lights=[sun])
    result, layout, corner_uv = lightmap_of(scene, [floor, wall, roof], texels_per_metre=1 / texel_m)
    texels = rasterize(corner_uv[:2], layout.width, layout.height)
    points = np.einsum("mc,mck->mk", texels.barycentric, triangles[texels.triangle])
    light = result.light.reshape(-1, 3)[texels.pixel, 0]
    distance = x - points[:, 0]
    whole = footprint_inside(texels.barycentric, footprint_steps(texels, corner_uv[:2]), 8).all(axis=1)
    beside = texels.centre_inside & whole & (distance > 0.05) & (distance < 0.15)
    sunlit = np.median(light[texels.centre_inside & (distance < -0.5)])
    assert beside.sum() >= 5
    assert (light[beside] <= (np.maximum(0.0, 0.5 - distance[beside] / texel_m) + 0.05) * sunlit).all()


def test_corners_buried_under_walls_take_the_light_of_their_visible_face():
    """A 4 m floor of two triangles whose corners lie inside the closed walls standing on its border (a decimated
    floor, as imported assets have) under a sun straight above: evaluated at its corners, it is not black but
    lit as the visible floor is, H / pi = S / pi from the sun, plus a little light off the walls (within +20%)."""
    floor = quad((0, 0, 0), (4, 0, 0), (4, 4, 0), (0, 4, 0))
    walls = [box_faces(lo, hi, inward=False) for lo, hi in (((-0.3, -0.3, 0), (4.3, 0.3, 1)),
                                                             ((-0.3, 3.7, 0), (4.3, 4.3, 1)),
                                                             ((-0.3, 0.3, 0), (0.3, 3.7, 1)),
                                                             ((3.7, 0.3, 0), (4.3, 3.7, 1)))]
    triangles = np.concatenate([floor] + [face for wall in walls for face in wall])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("plaster", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), 2.0)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    corners = solution.evaluate(np.repeat([0, 1], 3), np.tile(np.eye(3), (2, 1)), direct_per_point=True)
    assert corners[:, 0] == pytest.approx(2.0 / np.pi * 1.1, rel=0.1)


@pytest.mark.parametrize("layout, budget", [("spread", 4_000_000), ("strip", 4_000_000), ("spread", 64)])
def test_the_contact_grid_finds_every_triangle_a_point_lies_in(layout, budget, monkeypatch):
    """triangles_containing bins points on a grid and tests each triangle against the cells its box overlaps; its
    pairs must be those of testing every point against every triangle (the barycentric test of each pair), for tiny and
    huge triangles mixed, points on a whole plane or a thin strip of it, and faces up to ``behind`` behind; also
    when its pairs are taken a few (64) at a time."""
    import core.surface_probes
    from core.surface_probes import triangles_containing
    monkeypatch.setattr(core.surface_probes, "CANDIDATES_PER_CHUNK", budget)
    rng = np.random.default_rng(7)
    count = 3000
    x = rng.uniform(-10, 10, count)
    y = rng.uniform(-10, 10, count) if layout == "spread" else rng.uniform(2.0, 2.02, count)
    points = np.column_stack([x, y, np.zeros(count)])
    normals = np.tile([0.0, 0.0, 1.0], (count, 1))
    centres = rng.uniform(-12, 12, (300, 2))
    sizes = np.where(rng.random(300) < 0.1, 15.0, rng.uniform(0.01, 1.0, 300))
    corners = centres[:, None, :] + sizes[:, None, None] * rng.normal(size=(300, 3, 2))
    depth = rng.choice([0.0, -0.001, -0.01], 300)  # 1 mm behind the points counts, 1 cm behind does not
    triangles = np.concatenate([corners, np.broadcast_to(depth[:, None, None], (300, 3, 1))], axis=2)
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    rel = points[:, None, :2] - corners[None, :, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    u = (rel[..., 0] * e2[:, 1] - rel[..., 1] * e2[:, 0]) / det
    v = (e1[:, 0] * rel[..., 1] - e1[:, 1] * rel[..., 0]) / det
    expected = (u >= 0) & (v >= 0) & (u + v <= 1) & (-depth <= 0.002)
    assert 0.05 < expected.any(axis=1).mean() < 0.95
    found = np.zeros_like(expected)
    for point, triangle in triangles_containing(points, normals, triangles, 0.002):
        found[point, triangle] = True
    assert (found == expected).all()


def test_finer_footprint_points_average_to_the_points_they_split():
    """Each cell of a texel's 3 x 3 footprint grid, split 2 x 2, has its four finer points centred on its own
    point (a texel inside a large triangle, where no point folds back): barycentrics are affine in the texel."""
    corner_uv = np.array([[[0.0, 0.0], [1.0, 0.1], [0.2, 0.9]]])
    texels = rasterize(corner_uv, 16, 16)
    inner = np.flatnonzero(texels.centre_inside & (texels.barycentric > 0.2).all(axis=1))
    steps = footprint_steps(texels, corner_uv)[inner]
    coarse = footprint_barycentrics(texels.barycentric[inner], steps, 3)
    fine = footprint_barycentrics(texels.barycentric[inner], steps, 6)[:, subcell_order(3, 2)]
    assert len(inner) > 10
    assert fine.mean(axis=2) == pytest.approx(coarse, abs=1e-12)
    assert np.ptp(fine, axis=2).max() > 0.01  # the finer points do spread over each cell


def test_a_floor_in_full_sun_holds_its_irradiance_in_every_texel():
    """A lone floor under a sun of 3 W/m^2 straight above, with no shadow anywhere: every texel holds E / pi
    (no texel lit again: a chunk without shadow edges)."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    scene = Scene(floor, [0, 0], [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5, light_samples_per_edge=2))
    result = bake_lightmap(solution, np.array([0, 1]), (floor[..., :2] + 1) / 2, 16, 16,
                           LightmapSettings(indirect="interpolate"))
    assert result.light[result.covered] == pytest.approx(3.0 / np.pi, rel=1e-6)


@pytest.mark.parametrize("light_samples_per_edge", [2, 7], ids=["Draft", "Medium"])
def test_a_sharp_shadow_edge_darkens_each_texel_by_the_share_it_covers(light_samples_per_edge):
    """A floor 2 m across on 32 x 32 texels, under a sun straight above with no angle, and a shadow-only sheet
    2 m up covering x < 0.1 + 0.3 y: Cycles jitters a texel's samples over its whole footprint (a one-texel box),
    so each texel holds E / pi times the share of its footprint beyond the edge (integrated here exactly across
    x, on 256 rows). Texels on a sun's edge are lit again from 9 x 9 points, which measure a straight edge's share
    to within half their spacing (1/18) and, over the 24 texels the slanted edge crosses, to 0.015 RMS (Draft's
    3 x 3 points alone: 0.033 RMS, 0.067 at most; with 6 x 6 points, 0.014 and 0.033; measured with 9 x 9, 0.010 and
    0.017). The same at Medium's rays (7 per edge, 3 x 3 at each of the 3 x 3 points): more rays per point do not
    measure the share a sharp edge covers (before Medium's edge texels were lit again: 0.033 and 0.067).
    Away from the diagonal where the floor's two triangles meet and its outer texels, whose points fold back into
    their triangle."""
    width, slope, x0 = 32, 0.3, 0.1
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    sheet = quad((-3, -3, 2), (x0 - 3 * slope, -3, 2), (x0 + 3 * slope, 3, 2), (-3, 3, 2))
    scene = Scene(np.concatenate([floor, sheet]), [0, 0, 1, 1], [Material("grey", (0.5,) * 3)] * 2,
                  casts_only=[False, False, True, True], lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5,
                                        light_samples_per_edge=light_samples_per_edge))
    floor_uv = (floor[..., :2] + 1) / 2
    share = bake_lightmap(solution, np.array([0, 1]), floor_uv, width, width,
                          LightmapSettings(indirect="interpolate")).light[..., 0] / (3.0 / np.pi)
    texel_m = 2.0 / width
    left = np.arange(width) * texel_m - 1.0  # the texels' lower x (and y) edges, m
    rows = left[:, None] + (np.arange(256) + 0.5) / 256 * texel_m  # (texel row, 256) y across each texel
    beyond = np.clip(left[None, None, :] + texel_m - (x0 + slope * rows[..., None]), 0.0, texel_m)
    expected = beyond.mean(axis=1) / texel_m  # (row y, column x) share of the footprint in the sun
    centre = left + 0.5 * texel_m
    away = (np.abs(centre[None, :] - centre[:, None]) > 0.15) & (np.abs(centre[:, None]) < 0.9)
    edge = away & (expected > 0.0) & (expected < 1.0)
    assert edge.sum() == 24
    error = share[edge] - expected[edge]
    assert np.sqrt(np.mean(error ** 2)) < 0.015 and np.abs(error).max() < 1 / 18
    assert share[away & ~edge] == pytest.approx(expected[away & ~edge], abs=1e-6)


def test_a_texel_across_its_triangles_edge_holds_the_share_of_its_part_inside():
    """Cycles draws a texel's samples over its square again until they land in the texel's own triangle, so a
    texel that crosses the edge between the floor's two triangles holds the sunlit share of its part inside. A
    shadow-only sheet 2 m up covers x < 1.05 y + 0.02, an edge that runs along the floor's diagonal (x = y) within
    a texel; the floor's UV map puts the diagonal a quarter texel off the texel centres. Over the 47 texels within
    two of the diagonal, the share (integrated here on 64 x 64 points of each texel's part inside its triangle)
    must hold to 0.02 RMS and 1/18 at most (half the spacing of a sun's edge texels' 9 x 9 points; measured 0.016
    and 0.052); points folded back across the diagonal instead of left out measured 0.034 RMS and 0.15 at most,
    with 6 x 6 points."""
    width, slope, offset, scale = 32, 1.05, 0.02, 0.9
    shift = np.array([0.05 + 0.25 / width, 0.05])
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))  # triangles x > y, then x < y
    sheet = quad((-4, -3, 2), (-3 * slope + offset, -3, 2), (3 * slope + offset, 3, 2), (-4, 3, 2))
    scene = Scene(np.concatenate([floor, sheet]), [0, 0, 1, 1], [Material("grey", (0.5,) * 3)] * 2,
                  casts_only=[False, False, True, True], lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5, light_samples_per_edge=2))
    share = bake_lightmap(solution, np.array([0, 1]), (floor[..., :2] + 1) / 2 * scale + shift, width, width,
                          LightmapSettings(indirect="interpolate")).light[..., 0] / (3.0 / np.pi)
    to_floor = lambda texel, axis: ((texel / width - shift[axis]) / scale) * 2 - 1  # texel coordinate -> m
    centre = np.arange(width) + 0.5
    across = (np.arange(64) + 0.5) / 64 - 0.5
    x = to_floor(centre[None, :, None, None] + across[None, None, None, :], 0)  # (1, column, 1, 64)
    y = to_floor(centre[:, None, None, None] + across[None, None, :, None], 1)  # (row, 1, 64, 1)
    centre_x, centre_y = to_floor(centre[None, :], 0), to_floor(centre[:, None], 1)
    own = np.where((centre_x > centre_y)[..., None, None], x > y, x < y)
    expected = (own & (x > slope * y + offset)).sum(axis=(2, 3)) / own.sum(axis=(2, 3))
    near = (np.abs(centre_x - centre_y) < 2.0 / (width * scale)) & (np.abs(centre_x) < 0.85) & (np.abs(centre_y) < 0.85)
    error = share[near] - expected[near]
    assert near.sum() == 47 and 0 < expected[near].mean() < 1
    assert np.sqrt(np.mean(error ** 2)) < 0.02 and np.abs(error).max() < 1 / 18


@pytest.mark.parametrize("edge_samples, tolerance", [(core.lightmap.SHARP_EDGE_SAMPLES_PER_EDGE, 0.06), (1, None)])
def test_a_soft_shadow_edge_matches_the_disk_it_hides(monkeypatch, edge_samples, tolerance):
    """A floor under a sun straight above, of angular diameter 0.3 rad, sampled as a uniform disk of slopes of
    radius r = tan(0.15); a black sheet 2 m up covers x < 0. From floor point x the sheet hides the sun's
    directions of slope below -x / 2, so the floor holds (E / pi) (1 - A(-x / 2r)), with A(u) = (pi - acos u +
    u sqrt(1 - u^2)) / pi the share of the unit disk left of u, averaged over each texel's 3 x 3 sub-points. With
    Draft's one shadow ray per sub-point, 9 rays per texel, the 0.6 m penumbra's noise is up to sqrt(0.25 / 9) =
    17% of the full sun (measured 12.7% RMS); texels on a sun's edge are lit again from 3 x 3 points around each
    (81 rays: at most sqrt(0.25 / 81) = 5.6%), except the few whose first nine rays happened to agree with each
    other and their neighbours: within 6% RMS (measured 4.4%), and no bias. Lit again from the same 3 x 3 points
    (1 x 1 around each), the error stays that of 9 rays."""
    monkeypatch.setattr(core.lightmap, "SHARP_EDGE_SAMPLES_PER_EDGE", edge_samples)
    floor = quad((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0))
    sheet = quad((-3, -3, 2), (0, -3, 2), (0, 3, 2), (-3, 3, 2))
    triangles = np.concatenate([floor, sheet])
    scene = Scene(triangles, np.array([0, 0, 1, 1]), [Material("grey", (0.5,) * 3), Material("black", (0.0,) * 3)],
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0, angle_rad=0.3)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5, light_samples_per_edge=2))
    layout = layout_atlas([as_mesh(floor)], [0], AtlasSize(16.0, 0, 2, 4096))
    plan = plan_texels(solution, np.arange(2), np.concatenate(layout.corner_uv), layout.width, layout.height,
                       LightmapSettings(indirect="interpolate"))
    light = TexelLight.zeros(plan.texel_count)
    for index in range(plan.chunk_count):
        light.put(plan.chunk(index), light_chunk(solution, plan, index))
    u = np.clip(-plan.sub_points[..., 0] / (2.0 * np.tan(0.15)), -1.0, 1.0)
    visible = 1.0 - (np.pi - np.arccos(u) + u * np.sqrt(1.0 - u ** 2)) / np.pi
    expected = 3.0 / np.pi * visible.mean(axis=1)
    penumbra = (expected > 0.02 * 3.0 / np.pi) & (expected < 0.98 * 3.0 / np.pi)
    assert penumbra.sum() > 300
    error = np.sqrt(np.mean((light.direct[0, penumbra, 0] - expected[penumbra]) ** 2)) / (3.0 / np.pi)
    if tolerance is None:
        assert error > 0.11    # the test can fail: one ray per point is far off
    else:
        assert error < tolerance
        assert abs(np.mean(light.direct[0, penumbra, 0] - expected[penumbra])) < 0.01 * 3.0 / np.pi


def path_traced_indirect(scene, caster, points, normal, paths_per_point: int, bounces: int, seed: int,
                         offset_m: float) -> np.ndarray:
    """(m,) irradiance at points with a unit normal (one, or (m, 3)) from light the scene's surfaces reflect, by
    path tracing (an independent reference: no elements, no links): cosine-weighted directions, and at each
    surface a path meets, its reflectance x the throughput x the sun's irradiance there (one shadow ray), both
    sides of every surface reflecting. The scene's one light is a sun."""
    sun = scene.lights[0]
    to_sun = -np.asarray(sun.direction, dtype=np.float64) / np.linalg.norm(sun.direction)
    rng = np.random.default_rng(seed)
    count = len(points) * paths_per_point
    normals = np.repeat(np.broadcast_to(np.asarray(normal, dtype=np.float64), points.shape), paths_per_point, axis=0)
    origins = np.repeat(points, paths_per_point, axis=0) + offset_m * normals
    throughput, total = np.ones(count), np.zeros(count)
    for _ in range(bounces):
        local = cosine_hemisphere(rng.random((count, 1, 2)))
        directions = np.einsum("msi,mik->msk", local, tangent_frames(normals))[:, 0]
        hit, barycentric = caster.first_hit(origins, directions)
        throughput = np.where(hit >= 0, throughput, 0.0)
        triangles = scene.triangles[np.maximum(hit, 0)]
        points_hit = np.einsum("mc,mck->mk", barycentric, triangles)
        normals = triangle_unit_normals(triangles)
        normals *= np.where(np.einsum("mk,mk->m", normals, directions) < 0, 1.0, -1.0)[:, None]  # the side met
        origins = points_hit + offset_m * normals
        sunlit = ~caster.occluded(origins, np.repeat(to_sun[None], count, axis=0), np.full(count, np.inf))
        throughput = throughput * scene.reflectance[scene.material_index[np.maximum(hit, 0)], 0]
        total += throughput * sun.strength_w_m2 * np.maximum(normals @ to_sun, 0.0) * sunlit
    return total.reshape(len(points), paths_per_point).mean(axis=1)


@pytest.mark.parametrize("near_elements", [core.lightmap.NEAR_ELEMENTS, 0.0], ids=["gathered again", "element's"])
def test_an_arcade_floor_lit_off_its_ceiling_matches_a_path_traced_reference(monkeypatch, near_elements):
    """A 12 x 4 m arcade floor (reflectance 0.01) under a ceiling 3 m up (0.7) and a black back wall, open on one
    side to a 12 x 8 m ground (0.8) under a sun of 3 W/m^2 straight above: the floor's light all comes off the
    ceiling, which the sunlit ground lights from beside the arcade, strongest by the opening. With 4 m elements
    the ceiling is one element deep, and its one value is not the light of the spots the floor's gather rays meet:
    those within 2 element sizes are gathered again there. At core's default residual (0.01) the solve waits
    for the light between ground and ceiling to settle (core.hierarchical.SETTLED_AREA_SHARE: 5 iterations; it
    stopped after 2, and with the element's value at every hit the floor measured 6.9% dark). The floor's middle
    168 texels, against path tracing from their points (12 bounces, 1,200 paths each): within 3% (measured
    -1.0%; -0.3% to -2.1% over four other seeds of the bake, gather and paths); with the element's value at every
    hit, 4.3% too dark (4.1-4.8% over other seeds at a residual of 0.001)."""
    monkeypatch.setattr(core.lightmap, "NEAR_ELEMENTS", near_elements)
    scene = sunlit_arcade()
    solution = bake(scene, BakeSettings(patch_size_m=4.0, element_size_m=4.0))
    corner_uv = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=np.float64)
    plan = plan_texels(solution, np.array([2, 3]), corner_uv, 48, 16,
                       LightmapSettings(indirect="gather", gather_samples_per_edge=16))
    light = light_texels(solution, plan).light.reshape(-1, 3)[plan.pixel, 0]
    middle = np.flatnonzero((np.abs(plan.points[:, 0]) < 1.5) & (np.abs(plan.points[:, 1] + 2) < 1.7))
    assert len(middle) == 168
    reference = path_traced_indirect(scene, solution.caster, plan.points[middle], (0.0, 0.0, 1.0), 1200, 12, 1,
                                     solution.offset_m).mean() / np.pi
    ours = light[middle].mean()
    if near_elements == 0.0:
        assert ours < 0.97 * reference   # the test can fail: the one-element ceiling is too dark
    else:
        assert ours == pytest.approx(reference, rel=0.03)


@pytest.mark.parametrize("adaptive_passes, cover_growth", [(2, core.adaptive_elements.COVER_GROWTH), (0, 1.0)])
def test_the_wall_behind_a_sheet_hung_close_to_it_is_not_lit_by_the_walls_sunlit_mean(monkeypatch, adaptive_passes,
                                                                                       cover_growth):
    """A single-sided sheet 1.2 m square hangs 3 cm in front of a sunlit wall (both 0.5), over a black ground: the
    wall behind the sheet is in its shadow and gets only what the sheet's back reflects of the little light
    that wall reflects from under the sheet. With 2 m elements, an element the sheet's shadow crosses sends its
    mean, mostly sunlit, to the sheet's back 3 cm away, which sends it back: the wall's 68 texels behind the
    sheet's middle measured 11.3 times their path-traced light (11.1-12.2 over bake and path seeds; a decal's
    glow, issue 14). Two adaptive passes make the elements its shadow crosses finer (core.adaptive_elements):
    1.7 times (1.4-1.8). The failing case has no cover passes either (COVER_GROWTH 1: they alone measured 2.7
    times). Bound: the issue's twice the reference; path tracing from the texels' points (6 bounces, 400 paths
    each)."""
    monkeypatch.setattr(core.adaptive_elements, "COVER_GROWTH", cover_growth)
    scene = sheet_before_sunlit_wall()
    solution = bake(scene, BakeSettings(patch_size_m=2.0, element_size_m=2.0, adaptive_passes=adaptive_passes,
                                        min_element_size_m=0.25, adaptive_threshold=0.3))
    corner_uv = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=np.float64)
    plan = plan_texels(solution, np.array([0, 1]), corner_uv, 60, 30,
                       LightmapSettings(indirect="auto", gather_samples_per_edge=8))
    light = light_texels(solution, plan).light.reshape(-1, 3)[plan.pixel, 0]
    behind = np.flatnonzero((np.abs(plan.points[:, 0]) < 0.45) & (np.abs(plan.points[:, 2] - 1.5) < 0.45))
    assert len(behind) == 68
    reference = path_traced_indirect(scene, solution.caster, plan.points[behind], (0.0, -1.0, 0.0), 400, 6, 1,
                                     solution.offset_m).mean() / np.pi
    ratio = light[behind].mean() / reference
    if adaptive_passes:
        assert ratio < 2.0
    else:
        assert ratio > 5.0   # the test can fail: without adaptive elements the wall glows behind the sheet


@pytest.mark.parametrize("gather_under_elements", [core.lightmap.GATHER_UNDER_ELEMENTS, 0.0],
                         ids=["gathered", "interpolated"])
def test_an_interpolated_wall_behind_a_panel_1_cm_proud_is_dark_behind_it(monkeypatch, gather_under_elements):
    """A wall 4 m x 3 m faces a floor lit by a sun overhead (both 0.5), with a single-sided panel about 1 m square
    hung 1 cm in front of it, its edges off the 0.5 m element grid: behind the panel the wall sees only the panel's
    back and a 1 cm slot (the grey room's walls behind their mouldings, issue 56). Interpolated between the
    elements, the wall behind the panel took the open wall's light (0.149 against path tracing's 0.0003); its
    texels face a surface nearer than an element, so they gather instead (core.lightmap.GATHER_UNDER_ELEMENTS):
    measured 0.0006. Against path tracing from the texels' points (6 bounces, 200 paths each): behind the
    panel within 1% of the open wall's light, beside it within 2%."""
    monkeypatch.setattr(core.lightmap, "GATHER_UNDER_ELEMENTS", gather_under_elements)
    floor = quad((-3, -6, 0), (3, -6, 0), (3, 0, 0), (-3, 0, 0))
    wall = quad((-2, 0, 0), (2, 0, 0), (2, 0, 3), (-2, 0, 3))
    panel = quad((-0.6, -0.01, 0.9), (0.45, -0.01, 0.9), (0.45, -0.01, 1.85), (-0.6, -0.01, 1.85))
    triangles = np.concatenate([floor, wall, panel])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    on_wall = np.array([2, 3])
    xz = scene.triangles[on_wall][..., [0, 2]]
    corner_uv = np.stack([(xz[..., 0] + 2) / 4, xz[..., 1] / 3], axis=-1)
    plan = plan_texels(solution, on_wall, corner_uv, 64, 48, LightmapSettings(indirect="interpolate"))
    light = light_texels(solution, plan).light.reshape(-1, 3)[plan.pixel, 0]
    x, z = plan.points[:, 0], plan.points[:, 2]
    behind = np.flatnonzero((x > -0.5) & (x < 0.35) & (z > 1.0) & (z < 1.75))
    beside = np.flatnonzero((x > 0.7) & (x < 1.5) & (z > 1.0) & (z < 1.75))
    reference = [path_traced_indirect(scene, solution.caster, plan.points[part], (0.0, -1.0, 0.0), 200, 6, 1,
                                      solution.offset_m).mean() / np.pi for part in (behind, beside)]
    assert light[beside].mean() == pytest.approx(reference[1], rel=0.02)
    if gather_under_elements:
        assert abs(light[behind].mean() - reference[0]) < 0.01 * reference[1]
    else:
        assert light[behind].mean() > 0.5 * reference[1]  # the test can fail: interpolated, the wall glows


@pytest.mark.parametrize("receiver_gather", [True, False], ids=["gathered at the elements", "links alone"])
def test_a_white_tube_s_elements_match_path_tracing(monkeypatch, receiver_gather):
    """A white (reflectance 1) tube of 96 flat facets, 0.3 m in radius and 1.2 m long, lying on a grey floor with
    a slot 0.7 rad wide along its top, under a sun. Its inner elements (0.1 m: clusters of about six facets, each
    linked by others as flat squares) against path tracing from their receiver points (40 bounces, 300 paths
    each): solved again by rays at the elements (core.gather.gather_at_receivers), the mean is within 3% (measured
    -1.7%, over 220 elements); the links' solve alone was 8.2% short (the case that can fail)."""
    monkeypatch.setattr(core.gather, "GATHER_BELOW_ELEMENTS", np.inf)  # outputs gather: the tube alone decides
    angle = np.linspace(np.pi - 1.2, 2 * np.pi + 1.2, 97)
    ring = np.stack([0.3 * np.cos(angle), 0.3 * np.sin(angle) + 0.3], axis=1)  # (x, z), concave up
    tube = np.concatenate([quad((x1, -0.6, z1), (x0, -0.6, z0), (x0, 0.6, z0), (x1, 0.6, z1))
                           for (x0, z0), (x1, z1) in zip(ring[:-1], ring[1:])])
    triangles = np.concatenate([quad((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)), tube])
    scene = Scene(triangles, np.r_[[0, 0], np.ones(len(tube), int)],
                  [Material("grey", (0.5,) * 3), Material("white", (1.0,) * 3)],
                  lights=[SunLight("sun", (0.3, 0.2, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=0.4, element_size_m=0.1, residual_threshold=0.001,
                                        receiver_gather=receiver_gather))
    elements = solution.elements
    inner = np.where(np.einsum("mk,mk->m", elements.normal[:, 0], (0, 0, 0.3) - elements.point[:, 0]) > 0, 0, 1)
    every = np.arange(elements.count)
    point, normal = elements.point[every, inner], elements.normal[every, inner]
    picked = np.flatnonzero((np.abs(point[:, 1]) < 0.45) & (point[:, 2] > 0.02) & elements.alive[every, inner] &
                            (np.hypot(point[:, 0], point[:, 2] - 0.3) > 0.29))
    ours = solution.side_indirect_irradiance()[picked, inner[picked]].mean(axis=1)
    reference = path_traced_indirect(scene, solution.caster, point[picked], normal[picked], 300, 40, 1,
                                     solution.offset_m)
    assert len(picked) > 150
    if receiver_gather:
        assert ours.mean() == pytest.approx(reference.mean(), rel=0.03)
    else:
        assert ours.mean() < 0.96 * reference.mean()


def _rail_through_column(half_width: float):
    """A single-sided strip facing down (a rail's underside, 0.2 m wide, 3 m long, 1 m up) through a closed column
    0.3 m deep and 2 x ``half_width`` wide along the strip, all grey (0.5), under a sky of radiance 0.4 and
    nothing below: the scene, the strip and the column."""
    strip = quad((-1.5, -0.1, 1), (-1.5, 0.1, 1), (1.5, 0.1, 1), (1.5, -0.1, 1))
    column = np.concatenate(box_faces((-half_width, -0.15, 0), (half_width, 0.15, 2), inward=False))
    triangles = np.concatenate([strip, column])
    return Scene(triangles, np.zeros(len(triangles), int), [Material("grey", (0.5,) * 3)],
                 world=World((0.4, 0.4, 0.4))), strip, column


def test_a_rail_through_a_column_is_black_inside_it():
    """A single-sided strip facing down (a rail's underside, 0.2 m wide) runs through a closed column 0.3 m across,
    under a sky of radiance 0.4 and nothing below. Inside the column no light reaches the strip (Cycles bakes it
    black). Texels deeper inside the column than a texel (1/16 m), too deep to be pushed out to the strip's
    visible part, are planned as wholly dark (their footprint's dark share is 1) and hold exactly 0; those a
    metre from the column hold the sky, within 2% (the column's view factor from there)."""
    scene, strip, column = _rail_through_column(0.15)
    result, layout, corner_uv = lightmap_of(scene, [strip, column])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    plan = plan_texels(solution, np.arange(2), corner_uv[:2], layout.width, layout.height)
    x = np.einsum("mc,mc->m", plan.barycentric, strip[plan.tri][..., 0])
    buried = (np.abs(x) < 0.05) & ~plan.moved  # the texels along the strip's edges are pushed out of the column
    light = result.light.reshape(-1, 3)[plan.pixel, 0]
    assert triangle_unit_normals(strip)[0, 2] < 0 and np.count_nonzero(buried) >= 2
    assert plan.contact[buried] == pytest.approx(1.0)
    assert light[buried] == pytest.approx(0.0, abs=1e-12)
    assert light[np.abs(x) > 1.2] == pytest.approx(0.4, rel=0.02)


@pytest.mark.parametrize("half_width", [0.1, 0.22])
def test_rail_texels_across_a_column_face_are_dark_by_their_share_inside_it(half_width):
    """The rail of test_a_rail_through_a_column_is_black_inside_it through a column ``half_width`` wide along it,
    at 8 texels per metre, so that texels whose point lies outside the column reach into it. Cycles takes such a
    texel's mean over its footprint, black inside the column: its dark share (``contact``) is the part of its
    footprint inside the column, measured on 16 x 16 points, to the 1/6 a 3 x 3 grid resolves; and no texel holds
    more than the sky's 0.4 (no radiance in the scene exceeds it) on the part outside, to that resolution."""
    scene, strip, column = _rail_through_column(half_width)
    result, layout, corner_uv = lightmap_of(scene, [strip, column], texels_per_metre=8.0)
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    plan = plan_texels(solution, np.arange(2), corner_uv[:2], layout.width, layout.height)
    light = result.light.reshape(-1, 3)[plan.pixel, 0]
    fine = footprint_barycentrics(plan.barycentric, plan.steps, 16)
    fine_x = np.einsum("mqc,mc->mq", fine, strip[plan.tri][..., 0])
    in_triangle = footprint_inside(plan.barycentric, plan.steps, 16)  # points folded back into it are left out
    inside = ((np.abs(fine_x) < half_width) & in_triangle).sum(axis=1) / in_triangle.sum(axis=1)
    across = np.flatnonzero((inside > 0.1) & (inside < 0.9) & ~plan.moved)
    assert len(across) >= 2
    assert plan.contact[across] == pytest.approx(inside[across], abs=1 / 6 + 0.01)
    assert np.all(light[across] <= 0.4 * (1.0 - inside[across] + 1 / 6))


@pytest.mark.parametrize("facing", ["down", "up"])
def test_a_floor_under_a_sheet_nearer_than_the_ray_offset_is_black(facing):
    """A floor 2 m square under a sun straight above (3 W/m^2) with a sheet 1 m square 0.2 to 0.8 ray offsets
    above its middle, facing down (a single-sided shell) or up (shapes.floor_under_near_sheet). Cycles' rays
    start on the floor and meet the sheet, so the floor under it is black; rays that start an offset above the
    floor would pass over the sheet and bring the full sun. Texels wholly under the sheet hold 0 (to 1% of the
    sun's E / pi), those 0.2 m beyond it E / pi = 3 / pi within 1% (the sheet's dark underside at grazing
    angles)."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    scene, offset = floor_under_near_sheet(floor, facing)
    assert ray_offset_m(scene) == pytest.approx(offset) and offset > 0.019
    sheet = scene.triangles[-2:]
    assert abs(triangle_unit_normals(sheet)[0, 0]) > 0.01  # not the floor's plane: the coplanar test cannot see it
    marker = scene.triangles[2:4]
    result, layout, corner_uv = lightmap_of(scene, [floor, marker, sheet])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    plan = plan_texels(solution, np.arange(2), corner_uv[:2], layout.width, layout.height)
    light = result.light.reshape(-1, 3)[plan.pixel, 0]
    x, y = (np.einsum("mc,mc->m", plan.barycentric, floor[plan.tri][..., axis]) for axis in (0, 1))
    under, beyond = np.maximum(np.abs(x), np.abs(y)) < 0.4, np.maximum(np.abs(x), np.abs(y)) > 0.7
    assert np.count_nonzero(under) > 100 and np.count_nonzero(beyond) > 100
    assert light[under] == pytest.approx(0.0, abs=0.01 * 3 / np.pi)
    assert light[beyond] == pytest.approx(3 / np.pi, rel=0.01)


@pytest.mark.parametrize("lift_gap_share, cover_growth", [
    (core.clusters.LIFT_GAP_SHARE, 1.0), (np.inf, core.adaptive_elements.COVER_GROWTH), (np.inf, 1.0)],
    ids=["lift", "cover passes", "neither"])
def test_a_soffit_running_into_an_open_block_is_dark_in_the_slot(monkeypatch, lift_gap_share, cover_growth):
    """A soffit tessellated into 0.25 m squares runs into an open block whose bottom is 15 cm under it
    (shapes.soffit_into_open_block); the ground under a sun lights it from below. With 2 m elements, the element
    over the soffit's first 2 m holds 1.5 m in the open and 0.5 m in the slot: clustered together, the slot's
    gather rays, landing on the block's bottom 15 cm away and gathered again there, met the element's mean, lit
    in the open (a glow 55 times path tracing; the courtyard's arch soffits where the arcades meet, issue 14).
    The clusters' visibility test lifts each piece at most half way to the surface in front of it
    (core.clusters.LIFT_GAP_SHARE), so the slot's pieces no longer see past the block's bottom to the open
    ones' centre and make elements of their own; and without that, the cover passes (core.adaptive_elements)
    make the element finer, as its samples in the slot see the block's bottom 15 cm above and the others see
    nothing within its extent. Against path tracing from the texels' points (6 bounces, 200
    paths each): the slot's texels of that element within 1% of the open soffit's light (measured -0.5% over
    three seeds: the slot's own light, 0.6% of the open soffit's, comes out an eighth of it; +30% lifted to the
    full quarter element), the open ones' within 2% (measured -0.1% to +0.5%)."""
    monkeypatch.setattr(core.clusters, "LIFT_GAP_SHARE", lift_gap_share)
    monkeypatch.setattr(core.adaptive_elements, "COVER_GROWTH", cover_growth)
    scene = soffit_into_open_block(0.15)
    solution = bake(scene, BakeSettings(patch_size_m=2.0, element_size_m=2.0))
    soffit = np.flatnonzero(scene.material_index == 1)
    xy = scene.triangles[soffit, :, :2]
    corner_uv = np.stack([(xy[..., 0] + 2) / 4, (xy[..., 1] + 1) / 2], axis=-1)
    plan = plan_texels(solution, soffit, corner_uv, 64, 32, LightmapSettings(indirect="auto"))
    light = light_texels(solution, plan).light.reshape(-1, 3)[plan.pixel, 0]
    x, across = plan.points[:, 0], np.abs(plan.points[:, 1]) < 0.8
    slot, open_ = np.flatnonzero((x > -0.45) & (x < -0.05) & across), np.flatnonzero((x < -0.6) & across)
    reference = [path_traced_indirect(scene, solution.caster, plan.points[part], (0.0, 0.0, -1.0), 200, 6, 1,
                                      solution.offset_m).mean() / np.pi for part in (slot, open_)]
    assert light[open_].mean() == pytest.approx(reference[1], rel=0.02)
    if np.isfinite(lift_gap_share) or cover_growth > 1.0:
        assert abs(light[slot].mean() - reference[0]) < 0.01 * reference[1]
    else:
        assert light[slot].mean() > 0.1 * reference[1]   # the test can fail: the slot glows with the open mean


@pytest.mark.parametrize("sliver_grid", [core.lightmap.SLIVER_GRID, 1], ids=["finer grid", "gather grid"])
def test_a_wall_of_slivers_through_a_sunlit_floor_gathers_over_each_sliver(monkeypatch, sliver_grid):
    """A wall facing -x, 1 m wide, made of vertical strips 1 cm wide each cut along its diagonal (slivers 1 m
    long, as a decimated or boolean-cut asset has), reaches 0.35 m below a floor (reflectance 0.5) under a sun
    straight above (3 W/m^2, world black). Texels 0.1 m square: the row across the floor's edge has its lower
    half in the dark below the floor. Each texel's triangle covers a sliver of it, mostly no point of the gather's
    6 x 6 grid (the courtyard's arch soffits and column feet, issue 14), and Cycles' samples spread over that
    sliver (drawn again until they fall in the triangle). Against path tracing from points spread over each
    texel's height (3 bounces, 20,000 paths per texel): every texel of that row within 15% of its reference
    (measured +3% to +6%); with the points from the gather's grid alone, texels holding none of its points
    gathered from one point folded into the sliver, and the row came out 43% to 74% too bright."""
    monkeypatch.setattr(core.lightmap, "SLIVER_GRID", sliver_grid)
    floor = quad((-3, -2, 0), (0, -2, 0), (0, 2, 0), (-3, 2, 0))
    edges = np.linspace(-0.5, 0.5, 101)
    wall = np.concatenate([quad((0, y1, -0.35), (0, y0, -0.35), (0, y0, 0.65), (0, y1, 0.65))
                           for y0, y1 in zip(edges[:-1], edges[1:])])
    scene = Scene(np.concatenate([floor, wall]), [0, 0] + [1] * len(wall), [Material("grey", (0.5,) * 3)] * 2,
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
    solution = bake(scene, BakeSettings(patch_size_m=0.5, element_size_m=0.25))
    triangles = np.arange(2, len(scene.triangles))
    yz = scene.triangles[triangles][..., 1:]
    corner_uv = np.stack([yz[..., 0] + 0.5, yz[..., 1] + 0.35], axis=-1)
    plan = plan_texels(solution, triangles, corner_uv, 10, 10, LightmapSettings(indirect="gather"))
    light = light_texels(solution, plan).light.reshape(-1, 3)[plan.pixel, 0]
    row = np.flatnonzero(np.abs(plan.points[:, 2]) < 0.05)
    assert len(row) == 10
    z = np.linspace(-0.045, 0.045, 10)
    reference = np.array([path_traced_indirect(
        scene, solution.caster, np.stack([np.full(10, -0.0), np.full(10, plan.points[i, 1]), z], axis=1),
        (-1.0, 0.0, 0.0), 2000, 3, 2, solution.offset_m).mean() / np.pi for i in row])
    error = np.abs(light[row] / reference - 1)
    if sliver_grid > 1:
        assert error.max() < 0.15
    else:
        assert error.max() > 0.3   # the test can fail: one point per texel


def test_only_edges_shaded_smooth_across_are_seams():
    """Two triangles bent 20 degrees about their shared edge, drawn apart in the page. With each face's own normal
    at its corners (flat shading: the sides are lit apart, and a renderer shows them apart) the edge is no seam;
    with the two faces' mean normal at the edge's ends (smooth shading) it is, with SEAM_POINTS_PER_TEXEL points
    per texel of its drawing: 2 x 8."""
    bend = np.radians(20.0)
    triangles = np.array([[(0, 0, 0), (1, 0, 0), (0.5, -1, 0)],
                          [(1, 0, 0), (0, 0, 0), (0.5, np.cos(bend), np.sin(bend))]], dtype=float)
    corner_texels = np.array([[(2, 10), (10, 10), (6, 2)], [(30, 20), (22, 20), (26, 28)]], dtype=float)
    flat = np.repeat(triangle_unit_normals(triangles)[:, None], 3, axis=1)
    assert len(seam_points(triangles, flat, corner_texels)[0]) == 0
    smooth = flat.copy()
    mean = flat[0, 0] + flat[1, 0]
    smooth[0, :2] = smooth[1, :2] = mean / np.linalg.norm(mean)
    one, other = seam_points(triangles, smooth, corner_texels)
    assert len(one) == 16
    np.testing.assert_allclose(one[[0, -1]], [(2.25, 10), (9.75, 10)])
    np.testing.assert_allclose(other[[0, -1]], [(22.25, 20), (29.75, 20)])  # the same points


def test_stitching_keeps_a_smooth_light_across_a_uv_seam():
    """A floor lit by a point light 0.3 m above it, unwrapped as two triangles of two meshes, so that its diagonal
    is a seam drawn at two places. Read bilinearly at points along the seam, after stitching (core.seams), the
    two sides differ by under 0.1% of the page's mean level and hold E / pi = P cos / (4 pi^2 r^2) there within
    3% (texel-sized steps of a steep gradient)."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    light = PointLight("lamp", (0.3, -0.3, 0.3), power_w=100.0, soft_falloff=False)
    scene = Scene(floor, np.zeros(2, int), [Material("grey", (0.5,) * 3)], lights=[light])  # nothing to reflect
    result, layout, corner_uv = lightmap_of(scene, [floor[:1], floor[1:]], texels_per_metre=12.0)
    one, other = seam_points(floor, scene.corner_normals, corner_uv * [layout.width, layout.height])
    assert len(one) > 20
    assert seam_gap(result.light, one, other).mean() < 1e-3 * result.light[result.covered].mean()
    at = (np.arange(len(one)) + 0.5) / len(one)  # one seam, its points from its lower end (-1, -1, 0) on
    points = floor[0][0] + at[:, None] * (floor[0][2] - floor[0][0])
    index, weight = bilinear_weights(one, layout.width, layout.height)
    reads = np.einsum("kc,kcd->kd", weight, result.light.reshape(-1, 3)[index])
    delta = np.array(light.position) - points
    expected = 100.0 / (4 * np.pi) * delta[:, 2] / np.linalg.norm(delta, axis=1) ** 3 / np.pi
    np.testing.assert_allclose(reads[:, 0], expected, rtol=0.03)


def test_the_two_sides_of_a_uv_seam_agree_where_the_gather_is_noisy(monkeypatch):
    """The arcade floor (its light all gathered off the ceiling: noisy texels) unwrapped as two triangles of two
    meshes, 4 texels per metre. Along the seam, the bilinear reads of the two sides differ by over 2% of the
    page's mean as lit (measured: 30%, each side reading its own texels half a texel from the seam, and their
    gathers' noise) and under 0.5% once stitched (measured 0.16%), and the stitched reads of both sides lie
    between the two sides' own."""
    scene = sunlit_arcade()
    solution = bake(scene, BakeSettings(patch_size_m=4.0, element_size_m=4.0))
    layout = layout_atlas([as_mesh(scene.triangles[2:3]), as_mesh(scene.triangles[3:4])], [0, 1],
                          AtlasSize(4.0, 0, 2, 4096))
    corner_uv = np.concatenate(layout.corner_uv)
    settings = LightmapSettings(indirect="gather", gather_samples_per_edge=4)
    one, other = seam_points(scene.triangles[2:4], scene.corner_normals[2:4],
                             corner_uv * [layout.width, layout.height])
    assert len(one) > 20
    reads = {}
    for stitched in (False, True):
        if not stitched:
            monkeypatch.setattr(core.lightmap, "stitch_seams", lambda image, covered, a, b: image)
        else:
            monkeypatch.undo()
        result = bake_lightmap(solution, np.array([2, 3]), corner_uv, layout.width, layout.height, settings)
        level = result.light[result.covered].mean()
        reads[stitched] = [np.einsum("kc,kcd->kd", weight, result.light.reshape(-1, 3)[index]) / level
                           for index, weight in (bilinear_weights(side, layout.width, layout.height)
                                                 for side in (one, other))]
    gap = {stitched: np.abs(a - b).mean() for stitched, (a, b) in reads.items()}
    assert gap[False] > 0.02
    assert gap[True] < 0.005
    sides = sorted(side.mean() for side in reads[False])
    assert sides[0] < reads[True][0].mean() < sides[1] and sides[0] < reads[True][1].mean() < sides[1]
