"""Patches and elements: subdivision, point location, welding, grouping by key, and determinism of a whole bake."""
import numpy as np
import pytest

from core import BakeSettings, Material, PointLight, Scene, SceneError, SunLight, bake
from core.geometry import triangle_areas, uniform_subdivision
from core.mesh import build_mesh, elements_of, locate_uniform, weld_vertices
from core.ragged import row_groups
from core.texture import ReflectanceTexture
from shapes import box_faces, quad


@pytest.mark.parametrize("k", [1, 2, 3, 7])
def test_uniform_subdivision_tiles_the_triangle(k):
    cells = uniform_subdivision(k)
    assert cells.shape == (k * k, 3, 3)
    area = triangle_areas(np.concatenate([cells[..., 1:], np.zeros((k * k, 3, 1))], axis=2))
    assert area == pytest.approx(0.5 / k ** 2)
    assert np.allclose(cells.sum(axis=2), 1.0)


@pytest.mark.parametrize("k", [1, 2, 5])
def test_locate_uniform_finds_the_cell_holding_each_point_and_its_barycentrics(k):
    rng = np.random.default_rng(1)
    bary = rng.dirichlet((1, 1, 1), size=2000)
    cell, local = locate_uniform(np.full(2000, k), bary)
    cells = uniform_subdivision(k)[cell]
    solved = np.linalg.solve(np.swapaxes(cells, 1, 2), bary[..., None])[..., 0]
    assert (solved > -1e-9).all()
    assert local == pytest.approx(solved, abs=1e-12)


def one_quad_scene():
    return Scene(quad((0, 0, 0), (2, 0, 0), (2, 1, 0), (0, 1, 0)), np.zeros(2, int), [Material("m")],
                 lights=[PointLight("Lamp", (1, 0.5, 1), 10.0)])


def test_element_and_patch_sizes_follow_the_targets():
    mesh = build_mesh(one_quad_scene(), patch_size_m=0.5, element_size_m=0.125)
    elements = elements_of(mesh, one_quad_scene())
    edges = np.linalg.norm(elements.corners - np.roll(elements.corners, 1, axis=1), axis=2)
    assert edges.max() <= 0.125 * 1.0001
    assert elements.area_m2.sum() == pytest.approx(2.0)
    assert mesh.patch_count == 2 * 5 ** 2  # the diagonal (2.24 m) sets k = 5 patches per edge


def test_located_leaf_contains_the_point_after_splits():
    scene = one_quad_scene()
    mesh = build_mesh(scene, patch_size_m=0.5, element_size_m=0.25)
    mesh.split(mesh.leaves[::3])
    mesh.split(mesh.leaves[::5])
    rng = np.random.default_rng(2)
    triangle = rng.integers(0, 2, 500)
    bary = rng.dirichlet((1, 1, 1), size=500)
    node, local = mesh.locate(triangle, bary)
    assert (mesh.node_children[node, 0] < 0).all()
    point = np.einsum("mc,mck->mk", bary, mesh.triangles[triangle])
    assert np.einsum("mc,mck->mk", local, mesh.corners(node)) == pytest.approx(point)


def test_shared_edges_share_vertices():
    """The two triangles of a quad get the same subdivision, so their elements weld into one grid."""
    scene = Scene(quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)), np.zeros(2, int), [Material("m")],
                  lights=[PointLight("Lamp", (0.5, 0.5, 1), 10.0)])
    mesh = build_mesh(scene, patch_size_m=0.5, element_size_m=0.5)  # k = 3 from the 1.41 m diagonal
    vertices, _ = weld_vertices(mesh, mesh.leaves, 1e-6)
    assert len(vertices) == 4 ** 2


def test_evaluate_reproduces_a_uniform_field_and_nodal_values_are_continuous():
    triangles = np.concatenate(box_faces())
    scene = Scene(triangles, np.zeros(12, int), [Material("m", (0.5,) * 3, (1 / np.pi,) * 3)])
    solution = bake(scene, BakeSettings(patch_size_m=0.5, element_size_m=0.25, residual_threshold=1e-4))
    rng = np.random.default_rng(3)
    triangle, bary = rng.integers(0, 12, 300), rng.dirichlet((1, 1, 1), 300)
    light = solution.evaluate(triangle, bary)
    assert light == pytest.approx(2.0 / np.pi, rel=0.005)  # furnace: H = B = E / (1 - rho) = 2; light = H / pi


def test_same_seed_gives_identical_results():
    def run():
        scene = Scene(np.concatenate(box_faces((0, 0, 0), (2, 2, 2))[:5]), np.zeros(10, int), [Material("m")],
                      lights=[PointLight("Lamp", (1, 1, 1.5), 100.0, radius_m=0.2)])
        return bake(scene, BakeSettings(patch_size_m=0.5, element_size_m=0.25, adaptive_passes=1)).element_light()
    assert np.array_equal(run(), run())


def test_textured_floor_elements_reflect_their_own_squares():
    """A 2 x 2 checker (0.1 / 0.7) on a floor whose UVs span it once: elements inside a square reflect that
    square's value exactly, not the image mean 0.4."""
    pixels = np.array([[0.1, 0.7], [0.7, 0.1]])[..., None].repeat(3, axis=2)
    floor = quad((0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0))
    uv = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=float)
    material = Material("checker", (0.4, 0.4, 0.4), texture=ReflectanceTexture(pixels))
    scene = Scene(floor, np.zeros(2, int), [material], lights=[SunLight("sun", (0, 0, -1), 1.0)], triangle_uv=uv)
    mesh = build_mesh(scene, 0.5, 0.25)
    elements = elements_of(mesh, scene)
    x, y = elements.centroid[:, 0], elements.centroid[:, 1]
    inside = (np.abs(x - 1.0) > 0.2) & (np.abs(y - 1.0) > 0.2)  # away from the squares' borders
    expected = np.where((x < 1.0) == (y < 1.0), 0.1, 0.7)
    assert elements.reflectance[inside, 0] == pytest.approx(expected[inside])


def test_texture_with_reflectance_one_is_refused():
    bad = Material("glowing paint", (0.5,) * 3, texture=ReflectanceTexture(np.full((2, 2, 3), 1.2)))
    with pytest.raises(SceneError, match="glowing paint"):
        Scene(quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)), np.zeros(2, int), [bad],
              lights=[SunLight("sun", (0, 0, -1), 1.0)])


@pytest.mark.parametrize("columns", [1, 3, 9])
def test_row_groups_number_rows_as_numpy_unique_does(columns):
    """core.ragged.row_groups against np.unique over rows: the same group per row, numbered in the same order,
    and the same first row of each group, on keys with negatives and many repeats (and on none)."""
    keys = np.random.default_rng(columns).integers(-3, 4, (5000, columns))
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    group, first_row = row_groups(keys)
    assert np.array_equal(group, inverse.ravel()) and np.array_equal(first_row, first)
    assert [len(part) for part in row_groups(keys[:0])] == [0, 0]
