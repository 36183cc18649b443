"""Face clusters: the receiving elements of the hierarchical solver, whatever the input's triangle count.

The receiving triangles are first cut into pieces no longer than the element size (core.mesh.build_mesh: a big
floor triangle becomes a grid of pieces, a small one stays whole). Pieces are then grouped into elements, as face
cluster radiosity groups faces (Willmott, Heckbert & Garland 1999):

- pieces at least half the element size long and of at least the area of a right triangle with such legs stay
  elements of their own (a big wall's grid of pieces), and so do the pieces of emitting surfaces: a one-piece
  element takes Lambert's exact factor (core.links), which a point beside a light needs (a point-sampled cluster
  of a light's pieces lit the rim of a ceiling's opening, 0.5 mm from the light, at twice the light's radiance),
  and no element spreads a light's emission over the surface around it;
- smaller pieces, and slivers (a 3 m strip of moulding 2 cm wide, cut into pieces no longer than the element
  size, would otherwise make dozens of elements of a few square centimetres each), group by a grid cell of the
  element size and a bin of their normal direction (24 bins: a cube face and a quadrant of it), so an element is
  about as large as the element size and turns one way;
- then split wherever a piece cannot see its cluster's centre (a ray between the two, lifted off the surface by
  a quarter of the element size, but at most half way to the surface in front of it, is blocked): no element
  straddles a wall, so no element averages the sunlit ground outside with the floor inside, nor a soffit in the
  open with its part running into a block a few centimetres under another surface (lifted past that surface,
  the pieces there saw the centre).

A million small triangles thus make as many elements as a few large ones covering the same surface. Each element
keeps ``SAMPLES`` points stratified by area over its pieces (for form factors and probes), the area-weighted
centroid, normal, reflectance and emission of its pieces.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .geometry import longest_edges, triangle_areas, triangle_unit_normals
from .mesh import CHILDREN, ElementMesh
from .ragged import row_groups
from .raycast import RayCaster
from .scene import Scene
from .surface_probes import distance_in_front

SAMPLES = 4                 # area-stratified sample points per element
NORMAL_BINS_PER_AXIS = 2    # 6 cube faces x 2 x 2 normal-direction bins
VISIBILITY_ROUNDS = 3       # re-clustering rounds for pieces that cannot see their cluster's centre
LIFT_FRACTION = 0.25        # of the element size: how far the visibility test lifts points off the surface
LIFT_GAP_SHARE = 0.5        # of the distance to the surface in front of a piece: the most the test lifts it
SMALL_PIECE = 0.5           # pieces shorter than this share of the element size, or of less area than a right
                            # triangle with legs that long (slivers), are clustered


@dataclass
class FaceClusters:
    """Elements made of mesh pieces.

    piece_node: (P,) mesh node of each piece (the mesh's leaves); piece_element: (P,) its element.
    Per element (n): area_m2, centroid (n, 3), unit normal (n, 3), low and high (n, 3) corners of its bounding box,
    reflectance and emitted_exitance (n, 3; exitance = pi x radiance, W m^-2), sample_point and sample_normal
    (n, SAMPLES, 3: area-stratified points on its pieces and their faces' normals), sample_piece (n, SAMPLES) the
    piece each lies on, and for elements made of one piece its corners (n, 3, 3; NaN otherwise), for exact
    point-to-polygon form factors.
    """

    piece_node: np.ndarray
    piece_element: np.ndarray
    area_m2: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray
    low: np.ndarray
    high: np.ndarray
    reflectance: np.ndarray
    emitted_exitance: np.ndarray
    sample_point: np.ndarray
    sample_normal: np.ndarray
    sample_piece: np.ndarray
    polygon: np.ndarray

    @property
    def count(self) -> int:
        return len(self.area_m2)


def normal_bins(normals: np.ndarray) -> np.ndarray:
    """(m,) direction bin of unit normals: the cube face of the dominant axis and its sign, then a grid of
    NORMAL_BINS_PER_AXIS^2 cells over the other two components divided by the dominant one."""
    axis = np.argmax(np.abs(normals), axis=1)
    rows = np.arange(len(normals))
    major = normals[rows, axis]
    others = np.stack([normals[rows, (axis + 1) % 3], normals[rows, (axis + 2) % 3]], axis=1) / \
        np.where(np.abs(major) > 0, np.abs(major), 1.0)[:, None]
    cells = np.clip(np.floor((others + 1.0) * 0.5 * NORMAL_BINS_PER_AXIS), 0, NORMAL_BINS_PER_AXIS - 1).astype(int)
    face = 2 * axis + (major > 0)
    return (face * NORMAL_BINS_PER_AXIS + cells[:, 0]) * NORMAL_BINS_PER_AXIS + cells[:, 1]


def stands_alone(longest_edge_m: np.ndarray, area_m2: np.ndarray, element_size_m) -> np.ndarray:
    """Which pieces (their longest edges and areas) are elements of their own at the element size: those at
    least SMALL_PIECE of it long and of at least the area of a right triangle with legs that long."""
    least = SMALL_PIECE * np.asarray(element_size_m)
    return (longest_edge_m >= least) & (area_m2 >= 0.5 * least ** 2)


def cluster_pieces(mesh: ElementMesh, scene: Scene, caster: RayCaster, element_size_m, offset_m: float,
                   piece_reflectance: np.ndarray, nodes: np.ndarray | None = None) -> FaceClusters:
    """Group the mesh's leaves (or the given nodes) into elements of about ``element_size_m`` (see the module
    docstring; one size, or one per piece where adaptive elements made some finer: pieces group only with
    pieces of their own size); ``piece_reflectance`` (P, 3) is each piece's mean reflectance (textures averaged
    over it)."""
    nodes = mesh.leaves if nodes is None else np.asarray(nodes, dtype=np.int64)
    size = np.broadcast_to(np.asarray(element_size_m, dtype=np.float64), (len(nodes),))
    corners = mesh.corners(nodes)
    area = triangle_areas(corners)
    normal = triangle_unit_normals(mesh.triangles[mesh.node_triangle[nodes]])
    centroid = corners.mean(axis=1)
    origin = centroid.min(axis=0) if len(centroid) else np.zeros(3)
    cell = np.floor((centroid - origin) / size[:, None]).astype(np.int64)
    emits = scene.emissive[mesh.triangle_scene[mesh.node_triangle[nodes]]]
    alone = np.where(stands_alone(longest_edges(corners), area, size) | emits, np.arange(len(nodes)), -1)
    level = np.round(np.log2(size.max() / size)).astype(np.int64) if len(size) else np.zeros(0, np.int64)
    key = np.concatenate([cell, normal_bins(normal)[:, None], alone[:, None], level[:, None]], axis=1)
    element, _ = row_groups(key)
    in_front = distance_in_front(caster, centroid, normal, offset_m)
    lift = np.minimum(LIFT_FRACTION * size, LIFT_GAP_SHARE * in_front)
    for round_number in range(VISIBILITY_ROUNDS):
        blocked = _blocked_from_centre(caster, element, centroid, normal, area, lift, offset_m)
        if not blocked.any():
            break
        element, _ = row_groups(np.stack([element, blocked], axis=1))
    clusters = _clusters(nodes, element, corners, area, normal, centroid, piece_reflectance)
    return replace(clusters, emitted_exitance=emitted_exitance(clusters, mesh, scene))


def emitted_exitance(clusters: FaceClusters, mesh: ElementMesh, scene: Scene) -> np.ndarray:
    """(n, 3) emitted exitance pi L of each element, W m^-2: the area-weighted mean of its pieces' materials' in
    ``scene`` (a light group's share of the light, core.scene.Scene.lit_by, on the elements of the whole scene)."""
    nodes = clusters.piece_node
    exitance = np.pi * scene.emitted_radiance[scene.material_index[mesh.triangle_scene[mesh.node_triangle[nodes]]]]
    area = triangle_areas(mesh.corners(nodes))
    total = np.maximum(np.bincount(clusters.piece_element, weights=area, minlength=clusters.count), 1e-300)
    return np.stack([np.bincount(clusters.piece_element, weights=area * exitance[:, k], minlength=clusters.count)
                     for k in range(3)], axis=1) / total[:, None]


def _blocked_from_centre(caster: RayCaster, element: np.ndarray, centroid: np.ndarray, normal: np.ndarray,
                         area: np.ndarray, lift_m: np.ndarray, offset_m: float) -> np.ndarray:
    """(P,) True for pieces from whose lifted centroid the lifted centre piece of their cluster (the piece nearest
    the cluster's area centroid) is hidden."""
    count = element.max() + 1
    weight = np.maximum(area, 1e-300)
    mean = np.stack([np.bincount(element, weights=weight * centroid[:, k], minlength=count) for k in range(3)], 1)
    mean /= np.bincount(element, weights=weight, minlength=count)[:, None]
    distance = np.linalg.norm(centroid - mean[element], axis=1)
    order = np.lexsort((distance, element))
    first = order[np.r_[True, element[order][1:] != element[order][:-1]]]
    centre = np.empty(count, dtype=np.int64)
    centre[element[first]] = first
    target = centroid[centre[element]] + lift_m[centre[element], None] * normal[centre[element]]
    start = centroid + lift_m[:, None] * normal
    delta = target - start
    length = np.linalg.norm(delta, axis=1)
    test = np.flatnonzero(length > offset_m)
    blocked = np.zeros(len(element), dtype=bool)
    blocked[test] = caster.occluded(start[test], delta[test] / length[test, None], length[test] - offset_m)
    return blocked


def _clusters(nodes, element, corners, area, normal, centroid, reflectance) -> FaceClusters:
    """The elements' geometry and reflectance; no emission yet (``emitted_exitance``)."""
    count = int(element.max()) + 1 if len(element) else 0
    total = np.bincount(element, weights=area, minlength=count)
    safe = np.maximum(total, 1e-300)[:, None]
    mean = lambda values: np.stack([np.bincount(element, weights=area * values[:, k], minlength=count)
                                    for k in range(values.shape[1])], axis=1) / safe
    element_centroid = mean(centroid)
    summed_normal = mean(normal)
    element_normal = summed_normal / np.maximum(np.linalg.norm(summed_normal, axis=1, keepdims=True), 1e-300)
    order = np.argsort(element, kind="stable")
    first = np.flatnonzero(np.r_[True, element[order][1:] != element[order][:-1]])
    low = np.minimum.reduceat(corners.min(axis=1)[order], first)
    high = np.maximum.reduceat(corners.max(axis=1)[order], first)
    pieces = np.bincount(element, minlength=count)
    polygon = np.full((count, 3, 3), np.nan)
    single = np.flatnonzero(pieces[element] == 1)
    polygon[element[single]] = corners[single]
    point, point_normal, piece = _stratified_samples(element, corners, area, normal, count)
    return FaceClusters(nodes, element, total, element_centroid, element_normal, low, high, mean(reflectance),
                        np.zeros((count, 3)), point, point_normal, piece, polygon)


# A point in each of the four triangles of a 2 x 2 cut of a triangle (core.mesh.CHILDREN), as barycentric weights of
# its corners: near the centroid of each quarter, but not on it, so that the samples of a grid-aligned mesh do not
# fall exactly on the planes of other grid-aligned faces (a floor sample on the face of a box standing on it).
_QUARTERS = np.einsum("c,qck->qk", np.array([0.40, 0.33, 0.27]), CHILDREN)


def _stratified_samples(element, corners, area, normal, count) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(n, SAMPLES, 3) points and normals and (n, SAMPLES) pieces: each piece is cut into four equal quarters, and
    sample k of an element lies in the quarter that holds the element's area quantile (k + 1/2) / SAMPLES, pieces
    taken in order."""
    order = np.argsort(element, kind="stable")
    quarter_area = np.repeat(area[order] / 4.0, 4)
    quarter_piece = np.repeat(order, 4)
    quarter_index = np.tile(np.arange(4), len(order))
    cumulative = np.cumsum(quarter_area)
    total = np.bincount(element, weights=area, minlength=count)
    start = np.concatenate([[0.0], np.cumsum(total)[:-1]])
    targets = start[:, None] + total[:, None] * (np.arange(SAMPLES) + 0.5) / SAMPLES
    pick = np.minimum(np.searchsorted(cumulative, targets.ravel(), side="right"), len(cumulative) - 1)
    piece, quarter = quarter_piece[pick], quarter_index[pick]
    points = np.einsum("mc,mck->mk", _QUARTERS[quarter], corners[piece]).reshape(count, SAMPLES, 3)
    return points, normal[piece].reshape(count, SAMPLES, 3), piece.reshape(count, SAMPLES)
