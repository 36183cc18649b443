"""Adaptive elements for the hierarchical solver: face clusters made finer where a cover or the direct light
changes fast across them.

Adaptive meshing (radiosity paper, section 6; core.adaptive for the classic solvers) on face clusters. Two kinds of
pass make chosen elements again at half the size: their pieces are cut where longer than that, and group only
with pieces of their own size (core.clusters).

1. Cover passes, before the direct light is sampled, one per halving from the element size down to the minimum
   (2 at the presets): an element side some of whose samples lie under a surface nearer than COVER_NEAR_SHARE of
   the element's extent while others see nothing nearer than the extent is made finer. Such a side receives its
   indirect light at one point (core.hierarchical.Receivers), so where the point lies in the open (a roof slab's
   underside, half over a wall top 2 cm below and half overhanging the sunlit ground) the whole side, its covered
   part too, reflects the open part's light onto the surface under it.
2. Adaptive passes, as many as asked, after it: the elements whose direct light varies across their samples (a
   shadow's edge or a lamp's falloff crosses them). Without them, an element the shadow of a sheet hung just in
   front of a sunlit wall crosses sends its mostly sunlit mean to the sheet's back, which reflects it into its
   own shadow.

A pass splits the most uneven elements first, and none below the minimum size. The cover passes together make at
most COVER_GROWTH times the elements, each adaptive pass at most ADAPTIVE_GROWTH times its own (core.memory counts
on those bounds).
"""
from __future__ import annotations

import numpy as np

from .adaptive import LUMINANCE
from .clusters import SMALL_PIECE, FaceClusters, cluster_pieces
from .geometry import longest_edges
from .hierarchical import SIDES, Receivers, sample_direct_irradiance, sample_exposure, side_mean
from .mesh import ElementMesh, node_reflectance
from .progress import Progress, no_progress
from .raycast import RayCaster
from .scene import Scene
from .surface_probes import distance_in_front

ADAPTIVE_GROWTH = 2.0      # an adaptive pass at most doubles the elements
COVER_GROWTH = 1.25        # the cover passes together add at most a quarter of the elements
MOST_CELLS = 8             # a group of small pieces at half the size falls in at most 2 x 2 x 2 grid cells
FLOOR_FRACTION = 0.05      # of the mean direct light over all sides, added to a side's mean in the criterion
COVER_NEAR_SHARE = 0.1     # of an element's extent: a sample with a surface nearer than this in front is covered


def adaptive_elements(mesh: ElementMesh, scene: Scene, caster: RayCaster, offset_m: float, element_size_m: float,
                      passes: int, threshold: float, min_element_size_m: float, light_samples_per_edge: int,
                      seed: int, progress: Progress = no_progress):
    """(clusters, exposed samples (n, 2, SAMPLES), live sides (core.hierarchical.Receivers), the direct light at
    their samples (R, SAMPLES, 3)) after the cover passes and ``passes`` adaptive passes over the mesh's pieces
    (which it cuts)."""
    piece_size = np.full(len(mesh.node_bary), element_size_m)
    cover_passes = int(np.floor(np.log2(element_size_m / min_element_size_m))) if min_element_size_m > 0 else 0
    clusters, exposed_samples, receivers = _elements(mesh, scene, caster, piece_size, offset_m, seed, progress)
    most_elements = COVER_GROWTH * clusters.count
    for _ in range(cover_passes):
        splittable = _splittable(clusters, piece_size, min_element_size_m)
        covered = unevenly_covered(clusters, receivers, exposed_samples, caster, offset_m, splittable)
        chosen = _within_growth(mesh, clusters, piece_size, covered, most_elements - clusters.count)
        if len(chosen) == 0:
            break
        piece_size = _halve(mesh, clusters, piece_size, chosen)
        clusters, exposed_samples, receivers = _elements(mesh, scene, caster, piece_size, offset_m, seed, progress)
    for adaptive_pass in range(passes + 1):
        if adaptive_pass > 0:
            clusters, exposed_samples, receivers = _elements(mesh, scene, caster, piece_size, offset_m, seed,
                                                             progress)
        progress(0.0, f"Direct light on {len(receivers.element)} element sides")
        sample_direct = sample_direct_irradiance(scene, clusters, caster, receivers.element, receivers.side,
                                                 offset_m, light_samples_per_edge, seed)
        if adaptive_pass == passes:
            break
        splittable = _splittable(clusters, piece_size, min_element_size_m)
        uneven = uneven_elements(clusters, receivers, exposed_samples, sample_direct, splittable, threshold)
        chosen = _within_growth(mesh, clusters, piece_size, uneven, (ADAPTIVE_GROWTH - 1.0) * clusters.count)
        if len(chosen) == 0:
            break
        piece_size = _halve(mesh, clusters, piece_size, chosen)
    return clusters, exposed_samples, receivers, sample_direct


def _elements(mesh: ElementMesh, scene: Scene, caster: RayCaster, piece_size: np.ndarray, offset_m: float,
              seed: int, progress: Progress) -> tuple[FaceClusters, np.ndarray, Receivers]:
    """The mesh's leaves clustered at their pieces' sizes, their exposed samples and live sides."""
    leaves = mesh.leaves
    progress(0.0, f"Clustering {len(leaves)} pieces into elements")
    clusters = cluster_pieces(mesh, scene, caster, piece_size[leaves], offset_m,
                              node_reflectance(mesh, scene, leaves))
    exposed_samples = sample_exposure(clusters, mesh, caster, scene, offset_m, seed)
    return clusters, exposed_samples, Receivers.of(clusters, exposed_samples)


def _splittable(clusters: FaceClusters, piece_size: np.ndarray, min_element_size_m: float) -> np.ndarray:
    """(n,) whether an element's pieces at half their size stay at least the minimum element size."""
    splittable = np.zeros(clusters.count, dtype=bool)
    splittable[clusters.piece_element] = piece_size[clusters.piece_node] / 2.0 >= min_element_size_m
    return splittable


def _within_growth(mesh: ElementMesh, clusters: FaceClusters, piece_size: np.ndarray, candidates: np.ndarray,
                   most_new: float) -> np.ndarray:
    """The leading ``candidates`` (element indices, most urgent first) whose split adds at most ``most_new``
    elements."""
    pieces = clusters.piece_node
    most = _elements_after_split(clusters, longest_edges(mesh.corners(pieces)), piece_size[pieces] / 2.0)
    return candidates[np.cumsum(most[candidates] - 1) <= most_new]


def _halve(mesh: ElementMesh, clusters: FaceClusters, piece_size: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """Halve the size of the chosen elements' pieces, cutting in four (mesh.split) those longer than that; the
    pieces' sizes after it, the new pieces' appended."""
    refined = np.zeros(clusters.count, dtype=bool)
    refined[chosen] = True
    pieces = clusters.piece_node[refined[clusters.piece_element]]
    piece_size = piece_size.copy()
    piece_size[pieces] /= 2.0
    cut = pieces[longest_edges(mesh.corners(pieces)) > piece_size[pieces]]
    mesh.split(cut)
    return np.concatenate([piece_size, np.repeat(piece_size[cut], 4)])


def unevenly_covered(clusters: FaceClusters, receivers: Receivers, exposed_samples: np.ndarray, caster: RayCaster,
                     offset_m: float, splittable: np.ndarray) -> np.ndarray:
    """Indices of the ``splittable`` (n,) elements with a side some of whose exposed samples are covered (the
    first surface in front of them, along the side's normal from ``offset_m`` above, is nearer than
    COVER_NEAR_SHARE of the element's extent, its bounding box's diagonal) while others see no surface nearer than
    the extent; the largest extents first."""
    points = clusters.sample_point[receivers.element]
    normals = clusters.sample_normal[receivers.element] * SIDES[receivers.side][:, None, None]
    exposed = exposed_samples[receivers.element, receivers.side] > 0
    extent = np.linalg.norm(clusters.high - clusters.low, axis=1)
    distance = np.full(exposed.shape, np.inf)
    distance[exposed] = distance_in_front(caster, points[exposed], normals[exposed], offset_m)
    side_extent = extent[receivers.element][:, None]
    covered = (exposed & (distance < COVER_NEAR_SHARE * side_extent)).any(axis=1)
    open_ = (exposed & (distance > side_extent)).any(axis=1)
    uneven = np.zeros(clusters.count, dtype=bool)
    uneven[receivers.element[covered & open_]] = True
    chosen = np.flatnonzero(uneven & splittable)
    return chosen[np.argsort(-extent[chosen], kind="stable")]


def uneven_elements(clusters: FaceClusters, receivers: Receivers, exposed_samples: np.ndarray,
                    per_sample: np.ndarray, splittable: np.ndarray, threshold: float) -> np.ndarray:
    """Indices of the ``splittable`` (n,) elements with a side whose direct light (``per_sample`` (R, SAMPLES, 3)
    at its samples) varies over its exposed samples by more than ``threshold`` times its mean plus
    FLOOR_FRACTION of the mean over all sides (core.adaptive's criterion on the element's samples), the most
    uneven (largest variation over that bound) first."""
    level = per_sample @ LUMINANCE
    exposed = exposed_samples[receivers.element, receivers.side] > 0
    spread = np.where(exposed, level, -np.inf).max(axis=1) - np.where(exposed, level, np.inf).min(axis=1)
    mean = side_mean(exposed_samples, receivers.element, receivers.side, level[..., None])[:, 0]
    area = exposed_samples[receivers.element, receivers.side].sum(axis=1)
    floor = FLOOR_FRACTION * float(mean @ area / max(area.sum(), 1e-300))
    unevenness = np.zeros(clusters.count)
    np.maximum.at(unevenness, receivers.element, spread / np.maximum(threshold * (mean + floor), 1e-300))
    unevenness[~splittable] = 0.0
    order = np.argsort(-unevenness, kind="stable")
    return order[unevenness[order] > 1.0]


def _elements_after_split(clusters: FaceClusters, longest_m: np.ndarray, half_m: np.ndarray) -> np.ndarray:
    """(n,) the most elements each element can become at half its size (``half_m`` per piece, ``longest_m`` its
    pieces' longest edges): four per piece cut in four, one per piece long enough to stand alone, and at most
    MOST_CELLS for the small pieces that group."""
    cut = longest_m > half_m
    alone = ~cut & (longest_m >= SMALL_PIECE * half_m)
    grouped = np.bincount(clusters.piece_element, weights=~cut & ~alone, minlength=clusters.count)
    return (np.bincount(clusters.piece_element, weights=4.0 * cut + alone, minlength=clusters.count) +
            np.minimum(grouped, MOST_CELLS))
