"""Triangle maths shared by every stage: areas, normals, tangent frames, uniform subdivisions and insets."""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .ragged import row_groups


def lengths(vectors: np.ndarray) -> np.ndarray:
    """Euclidean lengths along the last axis (einsum: numpy's sum over a length-3 axis is many times slower)."""
    return np.sqrt(np.einsum("...k,...k->...", vectors, vectors))


def triangle_areas(triangles: np.ndarray) -> np.ndarray:
    """Areas of (..., 3, 3) triangles, m^2."""
    cross = np.cross(triangles[..., 1, :] - triangles[..., 0, :], triangles[..., 2, :] - triangles[..., 0, :])
    return 0.5 * lengths(cross)


def longest_edges(triangles: np.ndarray) -> np.ndarray:
    """(m,) the longest edge of each of (m, 3, 3) triangles."""
    return np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)


def triangle_unit_normals(triangles: np.ndarray) -> np.ndarray:
    """Unit normals of (..., 3, 3) triangles (right-handed winding); zero for degenerate ones."""
    normal = np.cross(triangles[..., 1, :] - triangles[..., 0, :], triangles[..., 2, :] - triangles[..., 0, :])
    return normal / np.maximum(lengths(normal)[..., None], 1e-300)


def tangent_frames(normals: np.ndarray) -> np.ndarray:
    """(m, 3, 3) orthonormal frames whose rows are tangent, bitangent and the unit normal."""
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    tangent = np.cross(helper, normals)
    tangent /= lengths(tangent)[:, None]
    return np.stack([tangent, np.cross(normals, tangent), normals], axis=1)


@lru_cache(maxsize=64)
def uniform_subdivision(k: int) -> np.ndarray:
    """(k^2, 3, 3) barycentric corners of a triangle cut into k x k similar triangles.

    With u, v the 2nd and 3rd barycentrics on a grid of step 1/k: the k(k+1)/2 "up" triangles
    (i, j), (i+1, j), (i, j+1) come first (i + j <= k - 1), then the k(k-1)/2 "down" triangles.
    """
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    up = (i + j <= k - 1)
    down = (i + j <= k - 2)
    iu, ju, idn, jdn = i[up], j[up], i[down], j[down]
    uv = np.concatenate([
        np.stack([np.stack([iu, ju], -1), np.stack([iu + 1, ju], -1), np.stack([iu, ju + 1], -1)], 1),
        np.stack([np.stack([idn + 1, jdn], -1), np.stack([idn + 1, jdn + 1], -1), np.stack([idn, jdn + 1], -1)], 1),
    ]) / k
    return np.concatenate([1.0 - uv.sum(-1, keepdims=True), uv], axis=-1)


@lru_cache(maxsize=8)
def triangle_sample_barycentrics(samples_per_edge: int) -> np.ndarray:
    """(s^2, 3) stratified barycentric points: the centroids of a uniform s x s subdivision."""
    return uniform_subdivision(samples_per_edge).mean(axis=1)


def duplicate_sides(triangles: np.ndarray, tolerance_m: float) -> np.ndarray:
    """(T, 2) True where a side (0 front, 1 back) of a triangle repeats a side of another triangle with the same
    corners (within ``tolerance_m``) that faces the same way. Of each such set only one side counts: a front before
    a back, then the lowest index. A two-sided sheet modelled as two copies with opposite windings thus reflects
    once from each side (as in Cycles, whose ray meets one of the two), and a face duplicated by mistake reflects
    once."""
    count = len(triangles)
    corners = np.round(triangles / tolerance_m).astype(np.int64)
    order = np.lexsort((corners[..., 2], corners[..., 1], corners[..., 0]), axis=-1)  # the same for every copy
    canonical = np.take_along_axis(corners, order[..., None], axis=1).reshape(count, 9)
    group, _ = row_groups(canonical)
    first = np.full(group.max(initial=-1) + 1, count)
    np.minimum.at(first, group, np.arange(count))
    normals = triangle_unit_normals(triangles)
    opposite = (np.einsum("tk,tk->t", normals, normals[first[group]]) < 0).astype(np.int64)
    side = np.tile([0, 1], count)
    triangle = np.repeat(np.arange(count), 2)
    facing = opposite[triangle] ^ side  # 0: along the group's first triangle's normal, 1: against it
    ranked = np.lexsort((triangle, side, facing, group[triangle]))
    same_place = (group[triangle][ranked][1:] == group[triangle][ranked][:-1]) & \
        (facing[ranked][1:] == facing[ranked][:-1])
    duplicate = np.zeros(2 * count, dtype=bool)
    duplicate[ranked[1:][same_place]] = True
    return duplicate.reshape(count, 2)


def direction_classes(normals: np.ndarray) -> np.ndarray:
    """(...,) which of six classes a unit normal falls in: 2 x its dominant axis, + 1 if that component is
    negative (+x, -x, +y, -y, +z, -z)."""
    axis = np.argmax(np.abs(normals), axis=-1)
    negative = np.take_along_axis(normals, axis[..., None], axis=-1)[..., 0] < 0
    return 2 * axis + negative


def inset(points: np.ndarray, centroids: np.ndarray, distance_m: float) -> np.ndarray:
    """Points moved ``distance_m`` (at most half way) towards their triangle's centroid: a point on a crease
    (a texel centre on the edge where a floor meets a wall) must not start its rays inside the other surface,
    nor sit in the plane of a neighbouring emitter, where the point-to-polygon factor degenerates."""
    towards = centroids - points
    length = lengths(towards)[..., None]
    return points + towards * np.minimum(distance_m, 0.5 * length) / np.maximum(length, 1e-300)
