"""Near-field link refinement: element-to-element light from patches that are close and not uniformly lit.

Substructuring (Cohen et al. 1986) lets patch j send one radiosity, the area mean of its elements, to every
receiving element: F(e -> j) mean_j(B). That is right when patch j is far from e or evenly lit; it is wrong when
e is close to a patch that holds a shadow edge, because e then sees mostly the near part of the patch. Under a ball
resting on the floor, the floor patch around the contact is half in the ball's shadow, half in the sun, and the
ball's underside sees mostly the shadowed half: with the patch mean it came out too bright (docs/benchmarks.md,
History: "Lightmaps against Cycles", the ball).

Hierarchical radiosity (Hanrahan, Salzman & Aupperle 1991) refines such links to the level of the elements.
Here, once the solve and its adaptive passes are done, every element e and every near, varying patch j exchange
light element by element, as a correction to what the patch already sent:

    dH_e = sum_{k in j} F(e -> k) (B_k - mean_j(B))

with F(e -> k) by ray casting (Lambert's point-to-polygon factor at e's centroid times the visible share of
stratified points on k: formfactor.point_to_triangle_with_visibility, as for the patch rows). The correction
vanishes for an evenly lit patch, so only links whose patch varies need it. "Near": e's centroid lies within
``NEAR_RADII`` bounding radii of the patch's centroid, where the patch subtends a large form factor (a facing disc
at 3 radii: F = 0.1).
"Varying": some exposed element of the patch differs from the patch mean by more than ``VARIATION`` of it.
"""
from __future__ import annotations

import numpy as np

from .errors import BakeCancelled
from .formfactor import point_to_polygon, point_to_triangle_with_visibility, triangle_samples
from .mesh import Elements
from .progress import Progress, never_cancelled, no_progress
from .ragged import concatenated_ranges
from .raycast import RayCaster
from .formfactor_rows import Patches

NEAR_RADII = 3.0
VARIATION = 0.05
TOLERANCE = 0.03
PAIRS_PER_CHUNK = 1 << 16


def near_field_irradiance(caster: RayCaster, elements: Elements, patches: Patches, radiosity: np.ndarray,
                          patch_radiosity: np.ndarray, irradiance: np.ndarray, samples_per_edge: int,
                          offset_m: float, progress: Progress = no_progress,
                          cancelled=never_cancelled) -> np.ndarray:
    """(n, 3) irradiance correction dH_e, W m^-2, for the elements' near links to varying patches.

    ``radiosity`` (n, 3) is each element's B, ``patch_radiosity`` (P, 3) what each patch sent (its mean of B),
    ``irradiance`` (n, 3) what each element received: a link is refined only where its bound on the correction,
    F(e -> j) max_k |B_k - mean_j(B)|, exceeds ``TOLERANCE`` of it (Hanrahan et al.'s BF criterion)."""
    correction = np.zeros((len(elements.node), 3))
    receiver, patch = _refined_links(elements, patches, radiosity, patch_radiosity, irradiance)
    members = _exposed_members(elements, len(patches.area_m2))
    difference = radiosity - patch_radiosity[elements.patch]
    links_per_chunk = max(1, PAIRS_PER_CHUNK // max(1, int(members[2].max(initial=1))))
    for first in range(0, len(receiver), links_per_chunk):
        if cancelled():
            raise BakeCancelled("Bake cancelled while linking near elements.")
        progress(first / len(receiver), f"Near-field links: {len(receiver)} element-patch links refined")
        chunk = slice(first, first + links_per_chunk)
        e, k = _element_pairs(elements, receiver[chunk], patch[chunk], *members)
        factors = _element_form_factors(caster, elements, e, k, samples_per_edge, offset_m)
        for channel in range(3):
            correction[:, channel] += np.bincount(e, weights=factors * difference[k, channel],
                                                  minlength=len(elements.node))
    return correction


def _refined_links(elements: Elements, patches: Patches, radiosity: np.ndarray, patch_radiosity: np.ndarray,
                   irradiance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(receiver element, patch) of every near link to a varying patch whose bound exceeds the tolerance, found
    a block of patches at a time (memory: about PAIRS_PER_CHUNK x 16 candidate links)."""
    deviation = _largest_deviation(elements, len(patches.area_m2), radiosity, patch_radiosity)
    varying = np.flatnonzero(deviation > VARIATION * patch_radiosity.sum(axis=1))
    block = max(1, PAIRS_PER_CHUNK * 16 // max(1, len(elements.node)))
    receivers, patches_linked = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
    for first in range(0, len(varying), block):
        receiver, patch = _near_links(elements, patches, varying[first:first + block])
        bound = point_to_polygon(elements.centroid[receiver], elements.normal[receiver], patches.corners[patch])
        keep = bound * deviation[patch] > TOLERANCE * irradiance[receiver].sum(axis=1)
        receivers.append(receiver[keep])
        patches_linked.append(patch[keep])
    return np.concatenate(receivers), np.concatenate(patches_linked)


def _element_pairs(elements: Elements, receiver: np.ndarray, patch: np.ndarray, order: np.ndarray,
                   start: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(receiver element, source element) pairs of the links: each link's receiver with every exposed element
    of its patch (``order``, ``start``, ``count`` from _exposed_members) in front of the receiver's plane."""
    size = count[patch]
    receiver = np.repeat(receiver, size)
    source = order[np.repeat(start[patch], size) + concatenated_ranges(size)]
    facing = np.einsum("mk,mk->m", elements.centroid[source] - elements.centroid[receiver],
                       elements.normal[receiver]) > 0
    return receiver[facing], source[facing]


def _near_links(elements: Elements, patches: Patches, patch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(element, patch) pairs for the given patches: the element's centroid within NEAR_RADII bounding radii of
    the patch's centroid, in front of the patch, and not on it."""
    radius = np.linalg.norm(patches.corners[patch] - patches.centroid[patch, None, :], axis=2).max(axis=1)
    offset = elements.centroid[:, None, :] - patches.centroid[None, patch, :]
    near = ((np.einsum("nbk,nbk->nb", offset, offset) < (NEAR_RADII * radius) ** 2)
            & (np.einsum("nbk,bk->nb", offset, patches.normal[patch]) > 0)
            & (elements.patch[:, None] != patch[None, :]) & (elements.exposed_m2[:, None] > 0))
    element, column = np.nonzero(near)
    return element, patch[column]


def _largest_deviation(elements: Elements, patch_count: int, radiosity: np.ndarray,
                       patch_radiosity: np.ndarray) -> np.ndarray:
    """(P,) largest |B_k - mean_j(B)| (summed over RGB) among each patch's exposed elements."""
    deviation = np.abs(radiosity - patch_radiosity[elements.patch]).sum(axis=1) * (elements.exposed_m2 > 0)
    largest = np.zeros(patch_count)
    np.maximum.at(largest, elements.patch, deviation)
    return largest


def _exposed_members(elements: Elements, patch_count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exposed elements sorted by patch, and each patch's (P,) start and count in that order."""
    exposed = np.flatnonzero(elements.exposed_m2 > 0)
    order = exposed[np.argsort(elements.patch[exposed], kind="stable")]
    count = np.bincount(elements.patch[order], minlength=patch_count)
    return order, np.cumsum(count) - count, count


def _element_form_factors(caster: RayCaster, elements: Elements, receiver: np.ndarray, source: np.ndarray,
                          samples_per_edge: int, offset_m: float) -> np.ndarray:
    """F(e -> k) for (receiver e, source k) pairs: point-to-polygon at e's centroid x visible share of k."""
    return point_to_triangle_with_visibility(
        caster, elements.centroid[receiver], elements.normal[receiver], elements.corners[source],
        triangle_samples(elements.corners[source], samples_per_edge), elements.normal[source], offset_m)
