"""Patches (shooters) and elements (receivers): the two-level hierarchy of Cohen et al. 1986 (substructuring).

Every receiving scene triangle is cut uniformly into ``k x k`` patch triangles (``k`` from its longest edge and the
patch size). Each patch is the root of a tree of 4-way midpoint splits; the leaves of these trees are the elements.
The initial elements sit ``depth`` splits below their patch, so their size is the patch size / 2^depth; adaptive
meshing splits leaves further. Every node stores its corners as barycentric coordinates in its scene triangle, so
locating the element under any surface point is arithmetic, not a search.

Vertices are welded per object by position, so elements on both sides of a shared edge share their vertices wherever
the subdivisions line up; where they do not (T-vertices), the extra vertex lies on the neighbour's edge, so the
element mesh has no geometric cracks.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .geometry import triangle_areas, triangle_unit_normals, uniform_subdivision
from .ragged import row_groups
from .raycast import RayCaster
from .scene import MAX_REFLECTANCE, Scene
from .surface_probes import inside_closed_geometry

# Children of a 4-way split of (a, b, c), as barycentric combinations of the parent's corners:
# three corner triangles, then the middle one (ab, bc, ca).
CHILDREN = np.array([
    [[1, 0, 0], [.5, .5, 0], [.5, 0, .5]],
    [[.5, .5, 0], [0, 1, 0], [0, .5, .5]],
    [[.5, 0, .5], [0, .5, .5], [0, 0, 1]],
    [[.5, .5, 0], [0, .5, .5], [.5, 0, .5]],
])


def locate_uniform(k: np.ndarray, barycentric: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index into ``uniform_subdivision(k)`` of the sub-triangle holding each point (vectorised over points), and
    the point's barycentrics within it. With U, V = k u, k v on the grid, cell (i, j) "up" has corners (i, j),
    (i+1, j), (i, j+1), so the point is U - i, V - j along its edges; "down" has (i+1, j), (i+1, j+1), (i, j+1),
    so it is U + V - i - j - 1 and i + 1 - U along them."""
    u, v = barycentric[:, 1] * k, barycentric[:, 2] * k
    i = np.clip(np.floor(u), 0, k - 1).astype(np.int64)
    j = np.clip(np.floor(v), 0, k - 1 - i).astype(np.int64)
    is_down = (u - i + v - j > 1.0) & (i + j <= k - 2)
    # Row-major order of (i, j) pairs with i + j <= k - 1 (up) or <= k - 2 (down), as in uniform_subdivision.
    up_index = i * k - i * (i - 1) // 2 + j
    down_index = k * (k + 1) // 2 + i * (k - 1) - i * (i - 1) // 2 + j
    second = np.where(is_down, u + v - i - j - 1, u - i)
    third = np.where(is_down, i + 1 - u, v - j)
    local = np.clip(np.stack([1.0 - second - third, second, third], axis=1), 0.0, 1.0)
    return np.where(is_down, down_index, up_index), local


def _child_and_local(barycentric: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which child of a 4-way split holds each point, and the point's barycentrics in that child."""
    l0, l1, l2 = barycentric.T
    child = np.full(len(barycentric), 3)
    child[l2 > 0.5] = 2
    child[l1 > 0.5] = 1
    child[l0 > 0.5] = 0
    local = np.stack([
        np.stack([2 * l0 - 1, 2 * l1, 2 * l2], -1),
        np.stack([2 * l0, 2 * l1 - 1, 2 * l2], -1),
        np.stack([2 * l0, 2 * l1, 2 * l2 - 1], -1),
        np.stack([1 - 2 * l2, 1 - 2 * l0, 1 - 2 * l1], -1),
    ])[child, np.arange(len(child))]
    return child, np.clip(local, 0.0, 1.0)


@dataclass
class ElementMesh:
    """The patch/element hierarchy over a scene's receiving triangles.

    triangles:       (T, 3, 3) world-space corners of the receiving scene triangles, m.
    triangle_scene:  (T,) index of each into ``Scene.triangles``.
    triangle_k:      (T,) patches per edge of each triangle.
    node_bary:       (N, 3, 3) barycentric corners of every node (patches first, then their descendants).
    node_triangle:   (N,) receiving triangle of each node;  node_patch: (N,) its patch (patches are nodes 0..P-1).
    node_children:   (N, 4) child nodes, -1 for leaves.
    """

    triangles: np.ndarray
    triangle_scene: np.ndarray
    triangle_object: np.ndarray
    triangle_k: np.ndarray
    triangle_first_patch: np.ndarray
    node_bary: np.ndarray
    node_triangle: np.ndarray
    node_patch: np.ndarray
    node_children: np.ndarray

    @property
    def patch_count(self) -> int:
        return len(self.triangle_k) and int(self.triangle_first_patch[-1] + self.triangle_k[-1] ** 2)

    @property
    def leaves(self) -> np.ndarray:
        """Node indices of the current elements."""
        return np.flatnonzero(self.node_children[:, 0] < 0)

    def scene_to_mesh(self, scene_triangle_count: int) -> np.ndarray:
        """(scene triangles,) the mesh triangle of each scene triangle, -1 for those not meshed (not solved)."""
        index = np.full(scene_triangle_count, -1)
        index[self.triangle_scene] = np.arange(len(self.triangle_scene))
        return index

    def corners(self, nodes: np.ndarray) -> np.ndarray:
        """(len(nodes), 3, 3) world-space corners, m."""
        return np.einsum("nij,njk->nik", self.node_bary[nodes], self.triangles[self.node_triangle[nodes]])

    def split(self, nodes: np.ndarray) -> np.ndarray:
        """4-way midpoint split of the given leaves; returns the (4 len(nodes),) new leaves."""
        nodes = np.asarray(nodes, dtype=np.int64)
        first = len(self.node_bary)
        children = first + np.arange(4 * len(nodes)).reshape(-1, 4)
        self.node_bary = np.concatenate([self.node_bary, np.einsum("cij,njk->ncik", CHILDREN,
                                                                   self.node_bary[nodes]).reshape(-1, 3, 3)])
        self.node_triangle = np.concatenate([self.node_triangle, np.repeat(self.node_triangle[nodes], 4)])
        self.node_patch = np.concatenate([self.node_patch, np.repeat(self.node_patch[nodes], 4)])
        self.node_children = np.concatenate([self.node_children, np.full((4 * len(nodes), 4), -1)])
        self.node_children[nodes] = children
        return children.ravel()

    def locate(self, triangle: np.ndarray, barycentric: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Leaf node under each point given by its receiving triangle and barycentrics in it, and the
        point's barycentrics within that leaf."""
        triangle = np.asarray(triangle, dtype=np.int64)
        local = np.asarray(barycentric, dtype=np.float64)
        k = self.triangle_k[triangle]
        cell, local = locate_uniform(k, local)
        node = self.triangle_first_patch[triangle] + cell
        while True:
            inner = self.node_children[node, 0] >= 0
            if not inner.any():
                return node, local
            child, child_local = _child_and_local(local[inner])
            node[inner] = self.node_children[node[inner], child]
            local[inner] = child_local


def uniform_subdivision_batch(k: np.ndarray, cell: np.ndarray) -> np.ndarray:
    """(n, 3, 3) barycentric corners of cell ``cell[i]`` of ``uniform_subdivision(k[i])``."""
    out = np.empty((len(k), 3, 3))
    for value in np.unique(k):
        rows = k == value
        out[rows] = uniform_subdivision(int(value))[cell[rows]]
    return out


def build_mesh(scene: Scene, patch_size_m: float, element_size_m: float,
               triangles: np.ndarray | None = None) -> ElementMesh:
    """Patches of about ``patch_size_m`` and elements of about ``element_size_m`` on the given scene triangles
    (default: every receiving one)."""
    receivers = np.flatnonzero(~scene.casts_only) if triangles is None else np.asarray(triangles, dtype=np.int64)
    triangles = scene.triangles[receivers]
    edges = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2)
    k = np.maximum(1, np.ceil(edges.max(axis=1) / patch_size_m - 1e-9)).astype(np.int64)
    first_patch = np.concatenate([[0], np.cumsum(k ** 2)[:-1]])
    patch_triangle = np.repeat(np.arange(len(k)), k ** 2)
    cell = np.arange(len(patch_triangle)) - first_patch[patch_triangle]
    mesh = ElementMesh(
        triangles=triangles, triangle_scene=receivers, triangle_object=scene.object_index[receivers],
        triangle_k=k, triangle_first_patch=first_patch,
        node_bary=uniform_subdivision_batch(k[patch_triangle], cell), node_triangle=patch_triangle,
        node_patch=np.arange(len(patch_triangle)), node_children=np.full((len(patch_triangle), 4), -1))
    # Split each patch until its elements reach the element size: a patch on a small triangle (smaller than
    # patch_size_m) gets fewer splits, so dense meshes do not get elements far below the size asked for.
    patch_edge = edges.max(axis=1) / k
    depth = np.round(np.log2(np.maximum(patch_edge / element_size_m, 1.0))).astype(np.int64)
    for level in range(int(depth.max(initial=0))):
        leaves = mesh.leaves
        mesh.split(leaves[depth[mesh.node_triangle[leaves]] > level])
    return mesh


@dataclass
class Elements:
    """Flat per-element arrays for the solver (one row per leaf of an :class:`ElementMesh`).

    node: (n,) mesh node;  patch: (n,) patch index;  centroid, normal: (n, 3);  area_m2: (n,);
    reflectance, emitted_exitance: (n, 3) (exitance = pi x emitted radiance, W m^-2);
    exposed_m2: (n,) the area through which the element exchanges light with the scene: its area, or 0 when it is
    buried inside closed geometry (see ``bury``).
    """

    node: np.ndarray
    patch: np.ndarray
    corners: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray
    area_m2: np.ndarray
    reflectance: np.ndarray
    emitted_exitance: np.ndarray
    exposed_m2: np.ndarray


def elements_of(mesh: ElementMesh, scene: Scene, nodes: np.ndarray | None = None) -> Elements:
    """Gather the per-element arrays of the given nodes (default: all current leaves)."""
    nodes = mesh.leaves if nodes is None else np.asarray(nodes, dtype=np.int64)
    corners = mesh.corners(nodes)
    scene_triangle = mesh.triangle_scene[mesh.node_triangle[nodes]]
    material = scene.material_index[scene_triangle]
    area_m2 = triangle_areas(corners)
    return Elements(
        node=nodes, patch=mesh.node_patch[nodes], corners=corners, centroid=corners.mean(axis=1),
        normal=triangle_unit_normals(mesh.triangles[mesh.node_triangle[nodes]]), area_m2=area_m2,
        reflectance=np.minimum(node_reflectance(mesh, scene, nodes), MAX_REFLECTANCE),
        emitted_exitance=np.pi * scene.emitted_radiance[material], exposed_m2=area_m2.copy())


def bury(elements: Elements, caster: RayCaster, scene: Scene, offset_m: float) -> Elements:
    """The elements with ``exposed_m2`` 0 where the centroid lies inside closed geometry (floor under a box).

    Such an element neither sees nor is seen, so it must not dilute its patch's mean radiosity: a patch half under
    a box would otherwise shoot half its light into the box's bottom face, and the room would come out darker
    (Cohen et al. 1986's patch mean assumes the whole patch radiates)."""
    buried = inside_closed_geometry(caster, scene.triangles, elements.centroid, elements.normal, offset_m)
    return replace(elements, exposed_m2=np.where(buried, 0.0, elements.area_m2))


def node_reflectance(mesh: ElementMesh, scene: Scene, nodes: np.ndarray) -> np.ndarray:
    """(n, 3) reflectance of mesh nodes: the material's, or its texture's mean over each node's UV footprint
    (where the triangle has finite UVs)."""
    scene_triangle = mesh.triangle_scene[mesh.node_triangle[nodes]]
    reflectance = scene.reflectance[scene.material_index[scene_triangle]]
    for texture, rows in scene.textured_rows(scene_triangle):
        corner_uv = np.einsum("nij,njk->nik", mesh.node_bary[nodes[rows]], scene.triangle_uv[scene_triangle[rows]])
        reflectance[rows] = texture.footprint_mean(corner_uv)
    return reflectance


def weld_vertices(mesh: ElementMesh, nodes: np.ndarray, tolerance_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Shared vertices of the given elements, welded per object by position.

    Returns (V, 3) positions and (n, 3) vertex indices per element corner.
    """
    corners = mesh.corners(nodes).reshape(-1, 3)
    obj = np.repeat(mesh.triangle_object[mesh.node_triangle[nodes]], 3)
    key = np.concatenate([obj[:, None], np.round(corners / tolerance_m).astype(np.int64)], axis=1)
    inverse, first = row_groups(key)
    return corners[first], inverse.reshape(-1, 3)
