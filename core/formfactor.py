"""Form factors: the exact point-to-polygon kernel, hemicube delta form factors, and visibility by shadow rays.

- ``point_to_polygon``: Lambert's contour formula (Howell; Cohen & Wallace 1993, eq. 4.20),
  F = 1/(2 pi) |sum_i beta_i n . unit(v_i x v_i+1)|, after clipping the polygon to the receiver's upper half-space.
- ``hemicube_delta_form_factors``: Cohen & Greenberg 1985: top face dF = dA / (pi (x^2 + y^2 + 1)^2),
  side faces dF = z dA / (pi (y^2 + z^2 + 1)^2); one Embree ray per pixel centre replaces the z-buffer.
- ``visible_fraction``: share of stratified points on a triangle visible from each receiver point
  (Wallace et al. 1989: ray-traced visibility between a receiver point and a source).
- ``point_to_triangle_with_visibility``: the two together, the ray-cast form factor of patches and elements.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .geometry import lengths, tangent_frames, triangle_sample_barycentrics
from .raycast import RayCaster

_TINY = 1e-300
COPLANAR = 1e-9  # a polygon vertex this share of its size from the receiver's plane lies in it (round-off)


def clip_to_upper_half_space(points: np.ndarray, normals: np.ndarray, polygons: np.ndarray) -> np.ndarray:
    """Clip (m, V, 3) polygons to the half-space n . (x - p) > 0 of each receiver point.

    Returns (m, 2V, 3) vertices relative to the points; dropped vertices repeat their predecessor, so the
    extra edges have zero length and add nothing to a contour integral.
    """
    rel = polygons - points[:, None, :]
    height = np.einsum("mvk,mk->mv", rel, normals)
    nxt_rel, nxt_h = np.roll(rel, -1, axis=1), np.roll(height, -1, axis=1)
    inside = height > 0
    crosses = (height > 0) != (nxt_h > 0)
    t = np.where(crosses, height / np.where(crosses, height - nxt_h, 1.0), 0.0)
    crossing = rel + t[..., None] * (nxt_rel - rel)
    # Interleave: vertex i (if inside), then the crossing on edge i -> i+1 (if any).
    candidates = np.stack([rel, crossing], axis=2).reshape(len(rel), 2 * rel.shape[1], 3)
    valid = np.stack([inside, crosses], axis=2).reshape(len(rel), 2 * rel.shape[1])
    slots = np.arange(valid.shape[1])
    last_valid = np.maximum.accumulate(np.where(valid, slots, -1), axis=1)
    wrap = np.where(valid.any(axis=1), np.where(valid, slots, -1).max(axis=1), 0)
    source = np.where(last_valid < 0, wrap[:, None], last_valid)
    clipped = np.take_along_axis(candidates, source[..., None], axis=1)
    clipped[~valid.any(axis=1)] = 0.0
    return clipped


def point_to_polygon(points: np.ndarray, normals: np.ndarray, polygons: np.ndarray) -> np.ndarray:
    """Unoccluded form factor from differential areas (m, 3) with unit normals to (m, V, 3) polygons.

    Polygons wholly above the receiver's plane go straight to the contour sum; only those crossing it are
    clipped first; those wholly below get 0, and so do those in the receiver's plane to round-off (COPLANAR of
    their size): a face duplicated onto another would otherwise fill its hemisphere (F = 1 from a height of
    1e-17 m) and the classic solvers' sums would diverge.
    """
    height = np.einsum("mvk,mk->mv", polygons - points[:, None, :], normals)
    size = lengths(polygons - np.roll(polygons, 1, axis=1)).max(axis=1, keepdims=True)
    height = np.where(np.abs(height) <= COPLANAR * size, 0.0, height)
    above, below = (height > 0).all(axis=1), (height <= 0).all(axis=1)
    factors = np.zeros(len(points))
    factors[above] = _contour_sum(polygons[above] - points[above, None, :], normals[above])
    crossing = ~above & ~below
    factors[crossing] = _contour_sum(
        clip_to_upper_half_space(points[crossing], normals[crossing], polygons[crossing]), normals[crossing])
    return factors


def _contour_sum(rel: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Lambert's contour sum for polygons given relative to the receiver point: 1/(2 pi) |sum beta_i n.c_i|."""
    x, y, z = rel[..., 0], rel[..., 1], rel[..., 2]
    inv = 1.0 / np.maximum(np.sqrt(x * x + y * y + z * z), _TINY)
    x, y, z = x * inv, y * inv, z * inv
    x2, y2, z2 = np.roll(x, -1, axis=1), np.roll(y, -1, axis=1), np.roll(z, -1, axis=1)
    cx, cy, cz = y * z2 - z * y2, z * x2 - x * z2, x * y2 - y * x2
    sin_beta = np.sqrt(cx * cx + cy * cy + cz * cz)
    beta = np.arctan2(sin_beta, x * x2 + y * y2 + z * z2)
    projected = cx * normals[:, :1] + cy * normals[:, 1:2] + cz * normals[:, 2:3]
    return np.abs(np.einsum("mv->m", beta * projected / np.maximum(sin_beta, _TINY))) / (2.0 * np.pi)


def visible_fraction(caster: RayCaster, points: np.ndarray, normals: np.ndarray, targets: np.ndarray,
                     target_normals: np.ndarray, offset_m: float, target_offset_m: float,
                     lift=None) -> np.ndarray:
    """Visible share of a source seen from each receiver point, by shadow rays to stratified source points.

    points, normals: (m, 3) receivers; targets: (m, s, 3) points on each source with (m, 3) source normals.
    Each sample is weighted by the unoccluded kernel cos(theta_r) cos(theta_s) / r^2, so a fully visible or
    fully hidden source is exact and a partly hidden one is weighted as the point-to-area integral.
    Receivers are lifted by ``offset_m`` along their normal and targets by ``target_offset_m`` towards the
    receiver, so no surface shadows itself. ``lift`` (core.terminator.ShadowLift, optional) starts grazing rays
    from smooth-shaded receivers on their smooth surface.
    """
    facing = np.sign(np.einsum("msk,mk->ms", points[:, None, :] - targets, target_normals))
    targets = targets + (target_offset_m * facing)[..., None] * target_normals[:, None, :]
    origins = np.broadcast_to((points + offset_m * normals)[:, None, :], targets.shape)
    if lift is not None:
        delta = targets - origins
        origins = lift.origins(origins, delta / np.maximum(lengths(delta), _TINY)[..., None])
    delta = targets - origins
    distance = np.maximum(lengths(delta), _TINY)
    direction = delta / distance[..., None]
    if targets.shape[1] == 1:  # one sample: its weight cancels
        return 1.0 - caster.occluded(origins.reshape(-1, 3), direction.reshape(-1, 3), distance.ravel())
    cos_receiver = np.maximum(np.einsum("msk,mk->ms", direction, normals), 0.0)
    cos_source = np.abs(np.einsum("msk,mk->ms", direction, target_normals))
    weight = cos_receiver * cos_source / distance ** 2
    weight = np.where(np.einsum("ms->m", weight)[:, None] > 0, weight, 1.0)
    blocked = caster.occluded(origins.reshape(-1, 3), direction.reshape(-1, 3), distance.ravel())
    visible = weight * ~blocked.reshape(weight.shape)
    return np.einsum("ms->m", visible) / np.einsum("ms->m", weight)


def point_to_triangle_with_visibility(caster: RayCaster, points: np.ndarray, normals: np.ndarray,
                                      corners: np.ndarray, samples: np.ndarray, source_normals: np.ndarray,
                                      offset_m: float, lift=None) -> np.ndarray:
    """(m,) F(point -> triangle): Lambert's contour formula times the visible share of the triangle's stratified
    ``samples`` (m, s, 3); shadow rays only where the formula is positive. ``lift``: as in visible_fraction."""
    factors = point_to_polygon(points, normals, corners)
    seen = np.flatnonzero(factors > 0)
    factors[seen] *= visible_fraction(caster, points[seen], normals[seen], samples[seen], source_normals[seen],
                                      offset_m, offset_m, None if lift is None else lift[seen])
    return factors


def triangle_samples(triangles: np.ndarray, samples_per_edge: int) -> np.ndarray:
    """(m, s^2, 3) stratified points on (m, 3, 3) triangles."""
    return np.einsum("sj,mjk->msk", triangle_sample_barycentrics(samples_per_edge), triangles)


@lru_cache(maxsize=8)
def hemicube_delta_form_factors(resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel directions (p, 3) in the local frame (z = normal) and delta form factors (p,) of a hemicube.

    The top face has resolution x resolution pixels; each side face resolution x resolution/2.
    The delta form factors sum to 1 up to the discretisation (Cohen & Greenberg 1985).
    """
    step = 2.0 / resolution
    centres = -1.0 + step * (np.arange(resolution) + 0.5)
    x, y = np.meshgrid(centres, centres, indexing="ij")
    top_dirs = np.stack([x, y, np.ones_like(x)], -1).reshape(-1, 3)
    top_df = (step * step / (np.pi * (x * x + y * y + 1.0) ** 2)).ravel()
    s, z = np.meshgrid(centres, centres[centres > 0], indexing="ij")
    side_df = (z * step * step / (np.pi * (s * s + z * z + 1.0) ** 2)).ravel()
    s, z = s.ravel(), z.ravel()
    one = np.ones_like(s)
    sides = [np.stack(v, -1) for v in ((one, s, z), (-one, s, z), (s, one, z), (s, -one, z))]
    directions = np.concatenate([top_dirs] + sides)
    weights = np.concatenate([top_df] + [side_df] * 4)
    return directions / lengths(directions)[:, None], weights


def hemicube_item_buffer(caster: RayCaster, origins: np.ndarray, normals: np.ndarray, resolution: int,
                         offset_m: float, rotation: np.ndarray | None = None):
    """What each hemicube pixel sees from each origin: scene triangle ((m, p), -1 for none), barycentrics
    ((m, p, 3)) and the pixels' delta form factors ((p,)).

    ``rotation`` (m,) turns each hemicube about its normal (radians), which decorrelates aliasing between
    neighbouring hemicubes.
    """
    directions, weights = hemicube_delta_form_factors(resolution)
    frames = tangent_frames(normals)
    if rotation is not None:
        c, s = np.cos(rotation)[:, None], np.sin(rotation)[:, None]
        t, b = frames[:, 0], frames[:, 1]
        frames = np.stack([c * t + s * b, -s * t + c * b, frames[:, 2]], axis=1)
    world = np.einsum("pk,mkj->mpj", directions, frames).reshape(-1, 3)
    start = np.repeat(origins + offset_m * normals, len(directions), axis=0)
    hit, bary = caster.first_hit(start, world)
    return hit.reshape(len(origins), -1), bary.reshape(len(origins), -1, 3), weights
