"""Texels of a lightmap: which triangle each texel belongs to, and the surface point it samples.

Rasterisation is conservative: a texel whose centre lies in a triangle takes that triangle; a texel that a
triangle only partly covers (its centre outside every triangle, but within half a texel diagonal of one) takes
the nearest point of the nearest triangle, so chart borders never read black under bilinear filtering.

Sample points sit on the surface and are then checked for lying inside other geometry (a floor texel under a
box standing on it, a wall texel behind a junction): short rays along the surface that hit a back face first move
the point out through that face (the approach of lightmappers such as Bakery), so no light leaks through
contacts and no dark blotches appear beside them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import lengths, tangent_frames, triangle_unit_normals
from .ragged import concatenated_ranges
from .raycast import RayCaster

CONSERVATIVE_REACH_TEXELS = 0.5 * np.sqrt(2.0)
CANDIDATES_PER_CHUNK = 4_000_000
TANGENT_RAYS = 8
INSIDE_BACK_FACES = 5  # of the nine probe rays, those that must meet a back face for a point to be inside
PLANE_NORMAL_STEPS = 1000  # a plane's normal is matched to 1/1000 per component
CONTACT_BEHIND = 1 / 16  # of the contact tolerance: how far behind a point a face may lie and still rest on it


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
    for start, stop in _chunks(counts, CANDIDATES_PER_CHUNK):
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


def _chunks(counts: np.ndarray, budget: int):
    """Triangle ranges whose candidate texels stay under ``budget`` (a huge triangle gets a range of its own)."""
    ends = np.cumsum(counts)
    start = 0
    while start < len(counts):
        base = ends[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, base + budget, side="right")))
        yield start, stop
        start = stop


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


def inset(points: np.ndarray, centroids: np.ndarray, distance_m: float) -> np.ndarray:
    """Points moved ``distance_m`` (at most half way) towards their triangle's centroid: a point on a crease
    (a texel centre on the edge where a floor meets a wall) must not start its rays inside the other surface,
    nor sit in the plane of a neighbouring emitter, where the point-to-polygon factor degenerates."""
    towards = centroids - points
    length = lengths(towards)[..., None]
    return points + towards * np.minimum(distance_m, 0.5 * length) / np.maximum(length, 1e-300)


def push_out_of_geometry(caster: RayCaster, scene_triangles_m: np.ndarray, points: np.ndarray,
                         normals: np.ndarray, reach_m: float, offset_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Move points that lie inside closed geometry out through the nearest back face along the surface.

    Only points enclosed by geometry (``inside_closed_geometry``) move: a point beside an open shell (a
    single-sided wall seen from behind, an arch's soffit) is where it should be, and pushing it through the shell
    would put it in the sunlit space on the other side. Eight rays per enclosed point in the tangent plane,
    ``reach_m`` long (about a texel; a scalar or one length per point), start ``offset_m`` above the surface; the
    nearest one that hits a back face (a face turned away from the ray: the point is behind it) moves the point
    to just past that face. Returns the points and a (m,) mask of those moved.
    """
    out, moved = points.copy(), np.zeros(len(points), dtype=bool)
    enclosed = np.flatnonzero(inside_closed_geometry(caster, scene_triangles_m, points, normals, offset_m))
    origins, directions = tangent_rays(points[enclosed], normals[enclosed], offset_m)
    distance, behind = back_face_hits(caster, scene_triangles_m, origins, directions)
    reach = np.repeat(np.broadcast_to(reach_m, len(points))[enclosed], TANGENT_RAYS)
    distance = np.where(behind & (distance <= reach), distance, np.inf).reshape(-1, TANGENT_RAYS)
    nearest = distance.argmin(axis=1)
    found = np.isfinite(distance.min(axis=1))
    step = distance[found, nearest[found]] + 2 * offset_m
    out[enclosed[found]] += directions.reshape(-1, TANGENT_RAYS, 3)[found, nearest[found]] * step[:, None]
    moved[enclosed[found]] = True
    return out, moved


def inside_closed_geometry(caster: RayCaster, scene_triangles_m: np.ndarray, points: np.ndarray,
                           normals: np.ndarray, offset_m: float) -> np.ndarray:
    """(m,) True where a surface point is buried in closed geometry (a floor under a box standing on it, the
    inside of a closed prop or of an open-bottomed box resting on the floor): seen from ``offset_m`` above it,
    the ray along the normal meets a back face, and the eight rays along the tangent directions all meet a face,
    most of them (with the normal's, ``INSIDE_BACK_FACES`` of the nine) a back face. An open surface above (a
    single-sided table top) leaves tangent rays free, and a surface facing a front face (a gallery's ceiling over
    its floor, between single-sided walls) is not inside, whatever its tangent rays meet. (Not every tangent ray
    need meet a back face: where a box's bottom lies on the floor, a ray meets the two coincident faces at once,
    and Embree reports either.) Only points whose normal ray meets a back face cast the tangent rays."""
    inside = np.zeros(len(points), dtype=bool)
    _, behind = back_face_hits(caster, scene_triangles_m, points + offset_m * normals, normals)
    candidates = np.flatnonzero(behind)
    if len(candidates) == 0:
        return inside
    origins, directions = tangent_rays(points[candidates], normals[candidates], offset_m)
    distance, tangent_behind = back_face_hits(caster, scene_triangles_m, origins, directions)
    all_hit = np.isfinite(distance).reshape(-1, TANGENT_RAYS).all(axis=1)
    backs = 1 + tangent_behind.reshape(-1, TANGENT_RAYS).sum(axis=1)
    inside[candidates] = all_hit & (backs >= INSIDE_BACK_FACES)
    return inside


def face_to_face_contact(scene_triangles_m: np.ndarray, point_triangle: np.ndarray, points: np.ndarray,
                         tolerance_m: float) -> np.ndarray:
    """(m,) True where a surface point lies on a face resting against an opposite-facing face in the same plane
    (the bottom of a box standing on a floor). No light reaches it, and Cycles bakes it black; but a sample point
    lifted off the surface passes through the other face, and one Embree ray cannot tell two coplanar faces
    apart. Planes are matched by quantised normal and offset (``tolerance_m``), one step per plane, not per
    texel; each point is then tested against the triangles of the opposite plane that are not behind it by more
    than CONTACT_BEHIND of the tolerance: two sheets back to back (a decal 3 mm behind a single-sided wall) face
    open space on both sides and stay lit."""
    planes, plane_of, normals = triangle_planes(scene_triangles_m, tolerance_m)
    number = {tuple(plane): index for index, plane in enumerate(planes.tolist())}
    point_plane = plane_of[point_triangle]
    contact = np.zeros(len(points), dtype=bool)
    for plane in np.unique(point_plane):  # one step per plane
        opposite = number.get(tuple((-planes[plane]).tolist()))
        if opposite is not None:
            here = np.flatnonzero(point_plane == plane)
            contact[here] = inside_any_triangle(points[here], normals[point_triangle[here]],
                                                scene_triangles_m[plane_of == opposite], CONTACT_BEHIND * tolerance_m)
    return contact


def triangle_planes(triangles_m: np.ndarray, tolerance_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The planes of (T, 3, 3) triangles, matched by normal (to 1/PLANE_NORMAL_STEPS per component) and offset (to
    ``tolerance_m``): (P, 4) int64 plane keys (negated, the same plane facing the other way), (T,) each
    triangle's plane, and (T, 3) the triangles' unit normals."""
    normals = triangle_unit_normals(triangles_m)
    offsets = np.einsum("tk,tk->t", normals, triangles_m[:, 0])
    keys = np.concatenate([np.round(normals * PLANE_NORMAL_STEPS), np.round(offsets / tolerance_m)[:, None]],
                          axis=1).astype(np.int64)
    planes, plane_of = np.unique(keys, axis=0, return_inverse=True)
    return planes, plane_of.ravel(), normals


def inside_any_triangle(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray, behind_m: float) -> np.ndarray:
    """(p,) whether each point (near the triangles' plane) lies inside any of the (q, 3, 3) triangles whose plane
    is at most ``behind_m`` behind it along its unit normal."""
    inside = np.zeros(len(points), dtype=bool)
    step = max(1, CANDIDATES_PER_CHUNK // max(1, len(triangles)))
    e1, e2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    det = np.where(np.abs(d11 * d22 - d12 * d12) > 1e-300, d11 * d22 - d12 * d12, np.inf)
    for start in range(0, len(points), step):  # chunks of points x triangles
        rel = points[start:start + step, None, :] - triangles[None, :, 0]
        r1, r2 = (rel * e1).sum(-1), (rel * e2).sum(-1)
        u, v = (d22 * r1 - d12 * r2) / det, (d11 * r2 - d12 * r1) / det
        height = np.einsum("pqk,pk->pq", rel, normals[start:start + step])  # > 0: the triangle is behind
        inside[start:start + step] = ((u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9) &
                                      (height <= behind_m)).any(axis=1)
    return inside


def tangent_rays(points: np.ndarray, normals: np.ndarray, offset_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(m * 8, 3) origins ``offset_m`` above the points and unit directions at 45 degree steps in their tangent
    planes."""
    frames = tangent_frames(normals)
    angles = np.arange(TANGENT_RAYS) * 2 * np.pi / TANGENT_RAYS
    local = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    directions = np.einsum("dk,mkj->mdj", local, frames[:, :2]).reshape(-1, 3)
    return np.repeat(points + offset_m * normals, TANGENT_RAYS, axis=0), directions


def back_face_hits(caster: RayCaster, scene_triangles_m: np.ndarray, origins: np.ndarray,
                   directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance to the first hit of each ray (inf for none) and whether that face is turned away from the ray."""
    hit, bary = caster.first_hit(origins, directions)
    found = hit >= 0
    hit_triangles = scene_triangles_m[np.maximum(hit, 0)]
    hit_points = np.einsum("mc,mck->mk", bary, hit_triangles)
    distance = np.where(found, lengths(hit_points - origins), np.inf)
    facing = np.einsum("mk,mk->m", triangle_unit_normals(hit_triangles), directions)
    return distance, found & (facing > 0)


def subtexel_barycentrics(texels: Texels, corner_uv: np.ndarray, samples_per_edge: int) -> np.ndarray:
    """(m, k^2, 3) barycentrics of k x k stratified points over each texel's footprint, folded back into the
    triangle where they fall outside it (mirrored at the edges, as Cycles' bake jitters its samples), so a texel
    holds its footprint's mean rather than one point's value. Texels only partly covered keep their one point."""
    k = samples_per_edge
    cells = (np.stack(np.meshgrid(np.arange(k), np.arange(k), indexing="ij"), -1).reshape(-1, 2) + 0.5) / k - 0.5
    uv = corner_uv[texels.triangle] * [texels.width, texels.height]
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    safe = np.where(np.abs(det) > 1e-12, det, np.inf)[:, None]
    du = (cells[None, :, 0] * e2[:, None, 1] - cells[None, :, 1] * e2[:, None, 0]) / safe
    dv = (e1[:, None, 0] * cells[None, :, 1] - e1[:, None, 1] * cells[None, :, 0]) / safe
    bary = texels.barycentric[:, None, :] + np.stack([-du - dv, du, dv], axis=-1)
    bary = _fold_into_triangle(bary)
    bary[~texels.centre_inside] = texels.barycentric[~texels.centre_inside, None, :]
    return bary


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
