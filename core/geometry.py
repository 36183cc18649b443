"""Triangle maths shared by every stage: areas, normals, tangent frames and uniform subdivisions."""
from __future__ import annotations

from functools import lru_cache

import numpy as np


def triangle_areas(triangles: np.ndarray) -> np.ndarray:
    """Areas of (..., 3, 3) triangles, m^2."""
    cross = np.cross(triangles[..., 1, :] - triangles[..., 0, :], triangles[..., 2, :] - triangles[..., 0, :])
    return 0.5 * np.linalg.norm(cross, axis=-1)


def triangle_unit_normals(triangles: np.ndarray) -> np.ndarray:
    """Unit normals of (..., 3, 3) triangles (right-handed winding); zero for degenerate ones."""
    normal = np.cross(triangles[..., 1, :] - triangles[..., 0, :], triangles[..., 2, :] - triangles[..., 0, :])
    return normal / np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-300)


def tangent_frames(normals: np.ndarray) -> np.ndarray:
    """(m, 3, 3) orthonormal frames whose rows are tangent, bitangent and the unit normal."""
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    tangent = np.cross(helper, normals)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
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
