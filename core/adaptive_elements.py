"""Adaptive elements for the hierarchical solver: face clusters made finer where the direct light changes fast.

Adaptive meshing (radiosity paper, section 6; core.adaptive for the classic solvers) on face clusters: after the
elements' direct light is sampled, each pass makes the elements whose direct light varies across their samples (a
shadow's edge or a lamp's falloff crosses them) again at half the size: their pieces are cut where longer than
that, and group only with pieces of their own size (core.clusters). Without it, an element the shadow of a sheet
hung just in front of a sunlit wall crosses sends its mostly sunlit mean to the sheet's back, which reflects it
into its own shadow. A pass splits the most uneven elements first, only as many as keep the element count within
``ADAPTIVE_GROWTH`` times the pass's (core.memory counts on that bound), and none below the minimum size.
"""
from __future__ import annotations

import numpy as np

from .adaptive import LUMINANCE
from .clusters import SMALL_PIECE, FaceClusters, cluster_pieces
from .geometry import longest_edges
from .hierarchical import Receivers, sample_direct_irradiance, sample_exposure, side_mean
from .mesh import ElementMesh, node_reflectance
from .progress import Progress, no_progress
from .raycast import RayCaster
from .scene import Scene

ADAPTIVE_GROWTH = 2.0      # an adaptive pass at most doubles the elements
MOST_CELLS = 8             # a group of small pieces at half the size falls in at most 2 x 2 x 2 grid cells
FLOOR_FRACTION = 0.05      # of the mean direct light over all sides, added to a side's mean in the criterion


def adaptive_elements(mesh: ElementMesh, scene: Scene, caster: RayCaster, offset_m: float, element_size_m: float,
                      passes: int, threshold: float, min_element_size_m: float, light_samples_per_edge: int,
                      seed: int, progress: Progress = no_progress):
    """(clusters, exposed samples (n, 2, SAMPLES), live sides (core.hierarchical.Receivers), the direct light at
    their samples (R, SAMPLES, 3)) after ``passes`` adaptive passes over the mesh's pieces (which it cuts)."""
    piece_size = np.full(len(mesh.node_bary), element_size_m)
    for adaptive_pass in range(passes + 1):
        leaves = mesh.leaves
        progress(0.0, f"Clustering {len(leaves)} pieces into elements")
        clusters = cluster_pieces(mesh, scene, caster, piece_size[leaves], offset_m,
                                  node_reflectance(mesh, scene, leaves))
        exposed_samples = sample_exposure(clusters, mesh, caster, scene, offset_m, seed)
        receivers = Receivers.of(clusters, exposed_samples)
        progress(0.0, f"Direct light on {len(receivers.element)} element sides")
        sample_direct = sample_direct_irradiance(scene, clusters, caster, receivers.element, receivers.side,
                                                 offset_m, light_samples_per_edge, seed)
        if adaptive_pass == passes:
            break
        pieces = clusters.piece_node
        longest = longest_edges(mesh.corners(pieces))
        half = piece_size[pieces] / 2.0
        splittable = np.zeros(clusters.count, dtype=bool)
        splittable[clusters.piece_element] = half >= min_element_size_m
        uneven = uneven_elements(clusters, receivers, exposed_samples, sample_direct, splittable, threshold)
        most = _elements_after_split(clusters, longest, half)
        chosen = uneven[np.cumsum(most[uneven] - 1) <= (ADAPTIVE_GROWTH - 1.0) * clusters.count]
        if len(chosen) == 0:
            break
        refined = np.zeros(clusters.count, dtype=bool)
        refined[chosen] = True
        pieces, longest = pieces[refined[clusters.piece_element]], longest[refined[clusters.piece_element]]
        piece_size[pieces] /= 2.0
        cut = pieces[longest > piece_size[pieces]]
        mesh.split(cut)
        piece_size = np.concatenate([piece_size, np.repeat(piece_size[cut], 4)])
    return clusters, exposed_samples, receivers, sample_direct


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
