"""Texels of a lightmap: which triangle each texel belongs to, and the surface point it samples.

Rasterisation is conservative: a texel whose centre lies in a triangle takes that triangle; a texel that a
triangle only partly covers (its centre outside every triangle, but within half a texel diagonal of one) takes
the nearest point of the nearest triangle, so chart borders never read black under bilinear filtering.
Sample points sit on the surface (core.surface_probes then checks them against other geometry).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import inset, lengths, triangle_unit_normals
from .ragged import budget_ranges, concatenated_ranges

CONSERVATIVE_REACH_TEXELS = 0.5 * np.sqrt(2.0)
CANDIDATES_PER_CHUNK = 4_000_000


@dataclass
class Texels:
    """Covered texels of a ``width`` x ``height`` image (row 0 at the bottom, as Blender stores pixels).

    pixel: (m,) flat index y * width + x; triangle: (m,) index into the rasterised triangles; barycentric: (m, 3)
    of the sample point in that triangle; centre_inside: (m,) the texel centre lies in the triangle (else the
    point is the triangle's nearest point to the centre).
    """

    pixel: np.ndarray
    triangle: np.ndarray
    barycentric: np.ndarray
    centre_inside: np.ndarray
    width: int
    height: int


def rasterize(corner_uv: np.ndarray, width: int, height: int) -> Texels:
    """Conservative rasterisation of (t, 3, 2) UV triangles (UV in [0, 1]) into texels."""
    corners = corner_uv * [width, height] - 0.5  # texel centres at integer coordinates
    lower = np.ceil(corners.min(axis=1) - 0.5 - 1e-9).astype(np.int64)
    upper = np.floor(corners.max(axis=1) + 0.5 + 1e-9).astype(np.int64)
    lower, upper = np.maximum(lower, 0), np.minimum(upper, [width - 1, height - 1])
    extent = np.maximum(upper - lower + 1, 0)
    counts = extent[:, 0] * extent[:, 1]
    parts = []
    for start, stop in budget_ranges(counts, CANDIDATES_PER_CHUNK):
        parts.append(_candidates(corners, lower, extent, counts, start, stop, width))
    if not parts:
        empty = np.zeros(0, dtype=np.int64)
        return Texels(empty, empty, np.zeros((0, 3)), np.zeros(0, dtype=bool), width, height)
    pixel, triangle, bary, distance = (np.concatenate(p) for p in zip(*parts))
    # One triangle per texel: centre inside first (distance 0), then the nearest; ties to the lowest triangle.
    order = np.lexsort((triangle, distance, pixel))
    first = np.ones(len(order), dtype=bool)
    first[1:] = pixel[order][1:] != pixel[order][:-1]
    keep = order[first]
    return Texels(pixel[keep], triangle[keep], bary[keep], distance[keep] == 0.0, width, height)


def _candidates(corners, lower, extent, counts, start, stop, width):
    """Texels in each triangle's bounding box (grown by half a texel) with their nearest point and distance."""
    triangle = np.repeat(np.arange(start, stop), counts[start:stop])
    within = concatenated_ranges(counts[start:stop])
    span = extent[triangle, 0]
    x = lower[triangle, 0] + within % np.maximum(span, 1)
    y = lower[triangle, 1] + within // np.maximum(span, 1)
    point = np.stack([x, y], axis=1).astype(np.float64)
    bary, distance = _nearest_point(point, corners[triangle])
    near = distance <= CONSERVATIVE_REACH_TEXELS
    return y[near] * width + x[near], triangle[near], bary[near], distance[near]


def _nearest_point(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Barycentrics of the nearest point of each 2D triangle to each point, and the distance (0 inside)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    e1, e2, rel = b - a, c - a, points - a
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    safe = np.where(np.abs(det) > 1e-12, det, 1.0)
    u = (rel[:, 0] * e2[:, 1] - rel[:, 1] * e2[:, 0]) / safe
    v = (e1[:, 0] * rel[:, 1] - e1[:, 1] * rel[:, 0]) / safe
    bary = np.stack([1.0 - u - v, u, v], axis=1)
    inside = (np.abs(det) > 1e-12) & (bary >= -1e-9).all(axis=1)
    distance = np.full(len(points), np.inf)
    best = np.zeros_like(bary)
    for i, j in ((0, 1), (1, 2), (2, 0)):  # three edges, vectorised over all points
        start, edge = triangles[:, i], triangles[:, j] - triangles[:, i]
        length2 = np.einsum("mk,mk->m", edge, edge)
        t = np.clip(np.einsum("mk,mk->m", points - start, edge) / np.maximum(length2, 1e-300), 0.0, 1.0)
        gap = lengths(start + t[:, None] * edge - points)
        closer = gap < distance
        distance[closer] = gap[closer]
        best[closer] = 0.0
        best[closer, i], best[closer, j] = 1.0 - t[closer], t[closer]
    distance[inside] = 0.0
    best[inside] = np.clip(bary[inside], 0.0, 1.0)
    return best / best.sum(axis=1, keepdims=True), distance


def sample_points(triangles_m: np.ndarray, texels: Texels, inset_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(m, 3) world points and unit normals of the texels in their (t, 3, 3) world triangles, moved ``inset_m``
    towards the triangle's centroid (see ``inset``)."""
    corners = triangles_m[texels.triangle]
    points = np.einsum("mc,mck->mk", texels.barycentric, corners)
    return inset(points, corners.mean(axis=1), inset_m), triangle_unit_normals(corners)


def footprint_steps(texels: Texels, corner_uv: np.ndarray) -> np.ndarray:
    """(m, 2, 3) change of each texel's barycentrics per texel step along the image's x and y (the inverse of its
    triangle's UV map); zero where the texel keeps its one point (its centre outside the triangle) or the UV
    triangle is degenerate."""
    uv = corner_uv[texels.triangle] * [texels.width, texels.height]
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    safe = np.where(np.abs(det) > 1e-12, det, np.inf)
    du = np.stack([e2[:, 1], -e2[:, 0]], axis=1) / safe[:, None]  # (m, 2): d(second barycentric) per x, y step
    dv = np.stack([-e1[:, 1], e1[:, 0]], axis=1) / safe[:, None]
    steps = np.stack([-du - dv, du, dv], axis=-1)
    steps[~texels.centre_inside] = 0.0
    return steps


def footprint_barycentrics(barycentric: np.ndarray, steps: np.ndarray, samples_per_edge: int) -> np.ndarray:
    """(m, k^2, 3) barycentrics of k x k stratified points over each texel's footprint (its (m, 3) centre
    barycentrics and (m, 2, 3) ``footprint_steps``), folded back into the triangle where they fall outside it
    (mirrored at the edges), so that each is a point of the surface; ``footprint_inside`` tells which count in the
    texel's mean (the footprint's part inside the triangle, as Cycles takes it), so that a texel holds its
    footprint's mean rather than one point's value. Texels only partly covered (steps zero) keep their one point.
    Point i * k + j lies in column i, row j of the texel's k x k cells (``subcell_order`` splits them further)."""
    return _fold_into_triangle(footprint_unfolded(barycentric, steps, samples_per_edge))


def footprint_inside(barycentric: np.ndarray, steps: np.ndarray, samples_per_edge: int) -> np.ndarray:
    """(m, k^2) whether each point of ``footprint_barycentrics`` lies in the texel's triangle before folding.
    Cycles draws a texel's samples over its square again until they fall in its triangle (bake_jitter_barycentric
    in its kernel, Blender 3.6 on), so a texel that crosses its triangle's edge holds the mean over the part
    inside."""
    return (footprint_unfolded(barycentric, steps, samples_per_edge) >= 0.0).all(axis=-1)


def subcell_order(samples_per_edge: int, split: int) -> np.ndarray:
    """(k^2, s^2) the points of a (k s) x (k s) ``footprint_barycentrics`` grid that fall in each cell of the
    k x k grid, so that the finer grid's values average back onto the coarser one's points."""
    column, row = np.divmod(np.arange((samples_per_edge * split) ** 2), samples_per_edge * split)
    cell = (column // split) * samples_per_edge + row // split
    return np.argsort(cell, kind="stable").reshape(samples_per_edge ** 2, split ** 2)


def footprint_unfolded(barycentric: np.ndarray, steps: np.ndarray, samples_per_edge: int) -> np.ndarray:
    """(m, k^2, 3) barycentrics of the k x k points over each texel's footprint, outside the triangle (a
    negative barycentric) or not."""
    return barycentric[:, None, :] + np.einsum("qa,mak->mqk", _cell_offsets(samples_per_edge), steps)


def _cell_offsets(samples_per_edge: int) -> np.ndarray:
    """(k^2, 2) centres of a k x k grid over the unit texel, as offsets (x, y) from its centre, column by
    column."""
    k = samples_per_edge
    column, row = np.divmod(np.arange(k * k), k)
    return (np.stack([column, row], axis=1) + 0.5) / k - 0.5


def _fold_into_triangle(bary: np.ndarray) -> np.ndarray:
    """Mirror barycentrics that went negative back across that edge (then clamp what is still outside)."""
    for axis in range(3):
        negative = bary[..., axis] < 0
        excess = np.where(negative, -bary[..., axis], 0.0)
        bary[..., axis] += 2 * excess
        others = [a for a in range(3) if a != axis]
        for other in others:
            bary[..., other] -= excess
    bary = np.clip(bary, 0.0, None)
    return bary / bary.sum(axis=-1, keepdims=True)
