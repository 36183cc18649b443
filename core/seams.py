"""UV seams of a lightmap page, stitched so that both sides read alike where a renderer reads them.

An edge between two faces of one surface that lies on two charts (a seam) is drawn twice in the page. A renderer
reads the texture bilinearly, so at a point of that edge it mixes the texels around each of the two drawings,
which were lit at different points and dilated into the padding apart: the two sides then differ, and the seam
shows as a line. As in lightmappers that fix seams (Bakery's Fix Seams; the least-squares stitching of
"Lightmap seams" by Sloan and others), the texels around the seams are moved as little as possible so that the two
bilinear reads agree at points along every seam:

    minimise  sum_k (a_k . x - b_k . x)^2  +  sum_j w_j (x_j - x0_j)^2

with a_k and b_k the bilinear weights of seam point k on either side, x0 the page's texels, and w_j the weight
that keeps texel j: STITCH_KEEP_WEIGHT for texels a triangle covers, STITCH_PADDING_WEIGHT for the padding that
dilation filled (free to move: the renderer reads it only at chart borders). The normal equations are solved by
conjugate gradients, all channels at once; the solution is linear in x0, so that light groups still sum to the
page.
"""
from __future__ import annotations

import numpy as np

SEAM_SHADING_COSINE = np.cos(np.radians(2.0))  # corner normals further apart than this meet at a shading crease
SEAM_POINTS_PER_TEXEL = 2      # seam points per texel of the edge's longer drawing
SEAM_POINTS_MAX = 64           # per edge
POSITION_DIGITS = 6            # an edge's ends are matched by their positions rounded to a micrometre
STITCH_KEEP_WEIGHT = 0.01
STITCH_PADDING_WEIGHT = 1e-4
STITCH_ITERATIONS = 200
STITCH_TOLERANCE = 1e-6        # of the right-hand side's norm: where conjugate gradients stop


def seam_points(triangles_m: np.ndarray, corner_normals: np.ndarray,
                corner_texels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) and (k, 2): the page positions, in texels (texel (x, y) has its centre at (x + 0.5, y + 0.5)), of
    points along every seam as drawn on one side and on the other, for (t, 3, 3) triangles with (t, 3, 3) unit
    shading normals at their corners and (t, 3, 2) corner positions in texels. A seam is an edge whose two ends
    two triangles share (by position), drawn at other places by each, and shaded smooth across: at each end the
    two triangles' corner normals lie within SEAM_SHADING_COSINE (a flat-shaded or sharp edge is a shading crease,
    whose sides a renderer shows apart, as Cycles bakes them); its points lie at the middles of
    SEAM_POINTS_PER_TEXEL steps per texel of its longer drawing (at least one, at most SEAM_POINTS_MAX)."""
    empty = np.zeros((0, 2))
    if len(triangles_m) < 2:
        return empty, empty
    start, end = np.array([0, 1, 2]), np.array([1, 2, 0])
    p, q = triangles_m[:, start].reshape(-1, 3), triangles_m[:, end].reshape(-1, 3)
    uv_p, uv_q = corner_texels[:, start].reshape(-1, 2), corner_texels[:, end].reshape(-1, 2)
    n_p, n_q = corner_normals[:, start].reshape(-1, 3), corner_normals[:, end].reshape(-1, 3)
    p_key, q_key = np.round(p, POSITION_DIGITS), np.round(q, POSITION_DIGITS)
    swap = _lexicographically_greater(p_key, q_key)  # each edge from its lower end, whichever way it runs
    low, high = np.where(swap[:, None], q_key, p_key), np.where(swap[:, None], p_key, q_key)
    uv_low, uv_high = np.where(swap[:, None], uv_q, uv_p), np.where(swap[:, None], uv_p, uv_q)
    n_low, n_high = np.where(swap[:, None], n_q, n_p), np.where(swap[:, None], n_p, n_q)
    _, edge, count = np.unique(np.concatenate([low, high], axis=1), axis=0, return_inverse=True,
                               return_counts=True)
    edge = edge.ravel()
    shared = np.flatnonzero(count[edge] == 2)
    order = shared[np.argsort(edge[shared], kind="stable")]
    one, other = order[0::2], order[1::2]
    drawn_apart = np.maximum(np.abs(uv_low[one] - uv_low[other]).max(axis=1),
                             np.abs(uv_high[one] - uv_high[other]).max(axis=1)) > 1e-3
    smooth = ((np.einsum("ij,ij->i", n_low[one], n_low[other]) >= SEAM_SHADING_COSINE) &
              (np.einsum("ij,ij->i", n_high[one], n_high[other]) >= SEAM_SHADING_COSINE))
    seam = drawn_apart & smooth
    one, other = one[seam], other[seam]
    drawn = np.maximum(np.linalg.norm(uv_high[one] - uv_low[one], axis=1),
                       np.linalg.norm(uv_high[other] - uv_low[other], axis=1))
    steps = np.clip(np.ceil(drawn * SEAM_POINTS_PER_TEXEL), 1, SEAM_POINTS_MAX).astype(np.int64)
    which = np.repeat(np.arange(len(one)), steps)
    first = np.cumsum(steps) - steps
    t = ((np.arange(len(which)) - first[which]) + 0.5) / steps[which]
    along = lambda rows: uv_low[rows][which] + t[:, None] * (uv_high[rows][which] - uv_low[rows][which])
    return along(one), along(other)


def _lexicographically_greater(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) whether each row of a comes after the row of b in lexicographic order (x, then y, then z)."""
    greater = np.zeros(len(a), dtype=bool)
    decided = np.zeros(len(a), dtype=bool)
    for axis in range(a.shape[1]):
        differs = ~decided & (a[:, axis] != b[:, axis])
        greater[differs] = a[differs, axis] > b[differs, axis]
        decided |= differs
    return greater


def bilinear_weights(position_texels: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(k, 4) flat texel indices and (k, 4) weights with which a bilinear read at (k, 2) page positions in texels
    mixes the texel centres around it (clamped at the page's border)."""
    x = np.clip(position_texels[:, 0] - 0.5, 0.0, width - 1.0)
    y = np.clip(position_texels[:, 1] - 0.5, 0.0, height - 1.0)
    x0 = np.minimum(np.floor(x).astype(np.int64), max(width - 2, 0))
    y0 = np.minimum(np.floor(y).astype(np.int64), max(height - 2, 0))
    fx, fy = np.clip(x - x0, 0.0, 1.0), np.clip(y - y0, 0.0, 1.0)
    x1, y1 = np.minimum(x0 + 1, width - 1), np.minimum(y0 + 1, height - 1)
    index = np.stack([y0 * width + x0, y0 * width + x1, y1 * width + x0, y1 * width + x1], axis=1)
    weight = np.stack([(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy], axis=1)
    return index, weight


def seam_gap(image: np.ndarray, one: np.ndarray, other: np.ndarray) -> np.ndarray:
    """(k,) the mean over channels of |bilinear read on one side - on the other| at the seam points."""
    height, width = image.shape[:2]
    flat = image.reshape(-1, image.shape[2])
    reads = []
    for side in (one, other):
        index, weight = bilinear_weights(side, width, height)
        reads.append(np.einsum("kc,kcd->kd", weight, flat[index]))
    return np.abs(reads[0] - reads[1]).mean(axis=1)


def stitch_seams(image: np.ndarray, covered: np.ndarray, one: np.ndarray, other: np.ndarray) -> np.ndarray:
    """(height, width, c) the page with the texels around its seams moved so that the bilinear reads at the seam
    points ``one`` and ``other`` ((k, 2) in texels, ``seam_points``) agree (the module docstring's least squares);
    ``covered``: (height, width) the texels a triangle covers."""
    if len(one) == 0:
        return image
    height, width, channels = image.shape
    index_one, weight_one = bilinear_weights(one, width, height)
    index_other, weight_other = bilinear_weights(other, width, height)
    columns, local = np.unique(np.concatenate([index_one, index_other], axis=1), return_inverse=True)
    local = local.reshape(len(one), 8)
    weight = np.concatenate([weight_one, -weight_other], axis=1)
    keep = np.where(covered.ravel()[columns], STITCH_KEEP_WEIGHT, STITCH_PADDING_WEIGHT)[:, None]
    flat = image.reshape(-1, channels).astype(np.float64)
    start = flat[columns]

    def normal_matrix(x: np.ndarray) -> np.ndarray:  # (A^T A + W) x, A the seam rows' weights
        residual = np.einsum("kc,kcd->kd", weight, x[local])
        out = keep * x
        for channel in range(channels):
            out[:, channel] += np.bincount(local.ravel(), weights=(weight * residual[:, None, channel]).ravel(),
                                           minlength=len(columns))
        return out

    x = start.copy()
    rhs = keep * start
    residual = rhs - normal_matrix(x)
    direction = residual.copy()
    squared = (residual ** 2).sum(axis=0)
    stop = STITCH_TOLERANCE ** 2 * (rhs ** 2).sum(axis=0)
    for _ in range(STITCH_ITERATIONS):
        if np.all(squared <= stop):
            break
        product = normal_matrix(direction)
        step = squared / np.maximum((direction * product).sum(axis=0), 1e-300)
        x += step * direction
        residual -= step * product
        new_squared = (residual ** 2).sum(axis=0)
        direction = residual + (new_squared / np.maximum(squared, 1e-300)) * direction
        squared = new_squared
    out = flat.copy()
    out[columns] = x
    return out.reshape(image.shape).astype(image.dtype)
