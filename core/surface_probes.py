"""Probes of a surface point's surroundings by short rays and plane tests: is it buried in closed geometry, does
its face rest on another, and where is the nearest free point.

Lightmap texels, vertex colours and elements sample the surface at points; a point inside other geometry (a floor
texel under a box standing on it, a wall texel behind a junction) must not take the light of where it is. Short
rays along the surface that hit a back face first move the point out through that face (the approach of
lightmappers such as Bakery), so no light leaks through contacts and no dark blotches appear beside them.
"""
from __future__ import annotations

import numpy as np

from .geometry import inset, lengths, tangent_frames, triangle_unit_normals
from .ragged import budget_ranges, concatenated_ranges, row_groups
from .raycast import RayCaster

CANDIDATES_PER_CHUNK = 4_000_000
POINTS_PER_CELL = 8  # triangles_containing's grid
GRID_CELLS_PER_AXIS = 2048  # at most, so that a long thin row of points does not make a huge grid
TANGENT_RAYS = 8
TANGENT_ANGLES = np.arange(TANGENT_RAYS) * 2 * np.pi / TANGENT_RAYS  # 45 degree steps in the tangent plane
INSIDE_BACK_FACES = 5  # of the nine probe rays, those that must meet a back face for a point to be inside
BURIED_REACHES = 4  # an enclosed point no ray gets out of is buried if all its tangent rays meet a face this near
COVER_ROUND_OFF = 1 / 16  # of covered_within's depth: a face nearer the point than this is its own plane's
PLANE_NORMAL_STEPS = 1000  # a plane's normal is matched to 1/1000 per component
CONTACT_BEHIND = 1 / 16  # of the contact tolerance: how far behind a point a face may lie and still rest on it
COINCIDENT_BEHIND = 1e-10  # of the contact tolerance: round-off in a point's position, far under a copy's
SMALL_PLANE_TRIANGLES = 8  # other_face_test tests the points of planes with at most this many triangles pairwise
OVERLAP_INSET = 0.01  # of the way from a triangle's corner to its centroid: off the edges it shares
OVERLAP_PARTNERS_PER_CELL = 2  # overlap_test's grid over a triangle: so many overlapping faces to a cell
UNCOVER_STEPS = (0.25, 0.5, 0.75, 1.0)  # of the way from a buried point towards a target on its triangle
UNCOVER_BISECTIONS = 6  # then halvings of the last step: the free point found lies within 1/256 of the way


def push_out_of_geometry(caster: RayCaster, scene_triangles_m: np.ndarray, points: np.ndarray,
                         normals: np.ndarray, reach_m: float,
                         offset_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Move points that lie inside closed geometry out through the nearest back face along the surface.

    Only points enclosed by geometry (``inside_closed_geometry``) move: a point beside an open shell (a
    single-sided wall seen from behind, an arch's soffit) is where it should be, and pushing it through the shell
    would put it in the sunlit space on the other side. Eight rays per enclosed point in the tangent plane,
    ``reach_m`` long (about a texel; a scalar or one length per point), start ``offset_m`` above the surface; the
    nearest one that hits a back face (a face turned away from the ray: the point is behind it) moves the point
    to just past that face. Returns the points, a (m,) mask of those moved, and one of those buried: enclosed, not
    moved, and every tangent ray meets a face within BURIED_REACHES reaches (a rail's underside in the middle of a
    column it runs through; a point beside open shells, whose rays run on to distant single-sided faces, is not).
    """
    out, moved = points.copy(), np.zeros(len(points), dtype=bool)
    inside, candidates, distance, behind = enclosure(caster, scene_triangles_m, points, normals, offset_m)
    kept = inside[candidates]
    enclosed, distance, behind = candidates[kept], distance[kept], behind[kept]
    _, directions = tangent_rays(points[enclosed], normals[enclosed], offset_m)
    reach = np.broadcast_to(reach_m, len(points))[enclosed]
    shut = (distance <= BURIED_REACHES * reach[:, None]).all(axis=1)
    distance = np.where(behind & (distance <= reach[:, None]), distance, np.inf)
    nearest = distance.argmin(axis=1)
    found = np.isfinite(distance.min(axis=1))
    step = distance[found, nearest[found]] + 2 * offset_m
    out[enclosed[found]] += directions.reshape(-1, TANGENT_RAYS, 3)[found, nearest[found]] * step[:, None]
    moved[enclosed[found]] = True
    buried = np.zeros(len(points), dtype=bool)
    buried[enclosed[~found & shut]] = True
    return out, moved, buried


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
    return enclosure(caster, scene_triangles_m, points, normals, offset_m)[0]


def buried_in_geometry(caster: RayCaster, scene_triangles_m: np.ndarray, points: np.ndarray, normals: np.ndarray,
                       reach_m, offset_m: float) -> np.ndarray:
    """(m,) True where a surface point is inside closed geometry (``inside_closed_geometry``) and every one of its
    tangent rays meets a face within BURIED_REACHES x ``reach_m`` (about a texel; a scalar or one length per
    point): the part of a rail's underside inside a column it runs through. A point beside open shells, whose
    rays run on to distant single-sided faces (a floor under an arcade), is not buried. The tangent rays are cast
    as occlusion rays of that length, one direction at a time for the points whose rays so far all met a face
    (most points are let go after one or two); only the points left are probed for closed geometry."""
    reach = np.broadcast_to(reach_m, len(points))
    frames = tangent_frames(normals)
    shut = np.arange(len(points))
    for angle in TANGENT_ANGLES:
        direction = np.cos(angle) * frames[shut, 0] + np.sin(angle) * frames[shut, 1]
        origins = points[shut] + offset_m * normals[shut]
        shut = shut[caster.occluded(origins, direction, BURIED_REACHES * reach[shut])]
    buried = np.zeros(len(points), dtype=bool)
    buried[shut] = inside_closed_geometry(caster, scene_triangles_m, points[shut], normals[shut], offset_m)
    return buried


def enclosure(caster: RayCaster, scene_triangles_m: np.ndarray, points: np.ndarray, normals: np.ndarray,
              offset_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``inside_closed_geometry``'s probe: (m,) inside; the (k,) points whose normal ray meets a back face, the
    only ones that cast tangent rays (``tangent_rays``); and for those, (k, TANGENT_RAYS) the distance each
    tangent ray travels to the face it meets (inf for none) and whether that face is turned away from it."""
    inside = np.zeros(len(points), dtype=bool)
    _, normal_behind = back_face_hits(caster, scene_triangles_m, points + offset_m * normals, normals)
    candidates = np.flatnonzero(normal_behind)
    origins, directions = tangent_rays(points[candidates], normals[candidates], offset_m)
    distance, behind = (hits.reshape(-1, TANGENT_RAYS)
                        for hits in back_face_hits(caster, scene_triangles_m, origins, directions))
    inside[candidates] = np.isfinite(distance).all(axis=1) & (1 + behind.sum(axis=1) >= INSIDE_BACK_FACES)
    return inside, candidates, distance, behind


def distance_in_front(caster: RayCaster, points: np.ndarray, normals: np.ndarray, offset_m: float) -> np.ndarray:
    """(m,) distance from surface points, ``offset_m`` above them along their unit normals, to the first surface
    in front along the normal (inf where none)."""
    return caster.hit_distance(points + offset_m * normals, normals)


def covered_within(caster: RayCaster, points: np.ndarray, normals: np.ndarray, depth_m: float) -> np.ndarray:
    """(m,) True where another face lies over a surface point, less than ``depth_m`` above it along its unit
    normal (and more than COVER_ROUND_OFF of that above): the middle of a column's facet inside a copy of the
    column turned half a facet, the floor under a rug lying a hair above it. Rays that leave the point
    ``depth_m`` above the surface (the ray offset) start beyond such a face and miss it, where Cycles' rays, which
    start on the surface, meet it: the point is dark. One ray per point, cast down the normal from ``depth_m``
    above it and stopped just short of the point's own face."""
    origins = points + depth_m * normals
    return caster.occluded(origins, -normals, np.full(len(points), (1.0 - COVER_ROUND_OFF) * depth_m))


def other_face_test(scene_triangles_m: np.ndarray, tolerance_m: float):
    """``on_another_face(point_triangle, points)``: (m,) True where surface points, (m, 3) on the given scene triangles,
    lie on another face in the same plane; the scene's planes are matched once, for any number of calls. The other face
    faces the other way and the point's face rests against it (the bottom of a box standing on a floor), or it faces the
    same way (a duplicated face, two objects' slabs overlapping). Cycles gives such a point no light, in its bake and in
    its renders (benchmarks/coplanar_render.py): every ray from it meets the other face at distance zero. A sample point
    lifted off the surface passes through the other face, and one Embree ray cannot tell two coplanar faces apart, so
    planes are matched by quantised normal and offset (``tolerance_m``), and each point is tested against the triangles
    of its plane other than its own and those of the opposite plane. An opposite face counts unless it lies behind the
    point by more than CONTACT_BEHIND of the tolerance: two sheets back to back (a decal 3 mm behind a single-sided
    wall) face open space on both sides and stay lit. A face turned the same way counts unless it lies behind the point
    at all (by more than COINCIDENT_BEHIND of the tolerance, round-off of the point's own position): a copy in exactly
    the same plane covers it, as a copy a little in front does; of two copies whose vertices differ by single-precision
    round-off (a column and its copy turned 90 degrees), each covers the other where it lies in front, as it does for
    Cycles' rays. Points whose planes hold at most SMALL_PLANE_TRIANGLES such triangles (a prop's facets) are tested
    pair by pair, all at once; the larger planes one at a time. With ``any_depth``, a point counts as on another
    face wherever it lies in one of those triangles, in front of or behind it (``overlap_test``); with ``faces``,
    the call returns (point, face) index arrays instead: each point with a face it lies on."""
    planes, plane_of, normals = triangle_planes(scene_triangles_m, tolerance_m)
    number = {tuple(plane): index for index, plane in enumerate(planes.tolist())}
    opposite = np.array([number.get(tuple(plane), -1) for plane in (-planes).tolist()], dtype=np.int64)
    order = np.argsort(plane_of, kind="stable")
    start = np.searchsorted(plane_of[order], np.arange(len(planes) + 1))
    count = np.append(np.diff(start), 0)  # the last entry: the triangles of no plane, for opposite = -1

    def on_another_face(point_triangle: np.ndarray, points: np.ndarray, any_depth: bool = False,
                        faces: bool = False):
        covered, found = np.zeros(len(points), dtype=bool), []
        for point, face in _covering_pairs(point_triangle, points, any_depth):
            covered[point] = True
            found.append((point, face))
        if not faces:
            return covered
        return tuple(np.concatenate([pair[side] for pair in found] or [np.zeros(0, dtype=np.int64)])
                     for side in (0, 1))

    def _covering_pairs(point_triangle, points, any_depth):
        point_plane = plane_of[point_triangle]
        candidates = count[point_plane] + count[opposite[point_plane]]
        small = np.flatnonzero((candidates > 1) & (candidates <= SMALL_PLANE_TRIANGLES))
        for first, stop in budget_ranges(candidates[small], CANDIDATES_PER_CHUNK):
            point = np.repeat(small[first:stop], candidates[small[first:stop]])
            plane = point_plane[point]
            index = concatenated_ranges(candidates[small[first:stop]])
            mine = index < count[plane]
            face = order[np.where(mine, start[plane] + index,
                                  start[np.maximum(opposite[plane], 0)] + index - count[plane])]
            behind_m = np.inf if any_depth else np.where(mine, COINCIDENT_BEHIND, CONTACT_BEHIND) * tolerance_m
            hit = _inside_pairs(points[point], normals[point_triangle[point]], scene_triangles_m[face], behind_m)
            hit &= face != point_triangle[point]
            yield point[hit], face[hit]
        large = np.flatnonzero(candidates > SMALL_PLANE_TRIANGLES)
        large = large[np.argsort(point_plane[large], kind="stable")]
        planes_of_large, first = np.unique(point_plane[large], return_index=True)
        for plane, here in zip(planes_of_large.tolist(), np.split(large, first[1:])):  # one step per plane
            faces = np.sort(np.concatenate([order[start[side]:start[side + 1]] for side in (plane, opposite[plane])
                                            if side >= 0]))
            behind_m = np.inf if any_depth else \
                np.where(plane_of[faces] == plane, COINCIDENT_BEHIND, CONTACT_BEHIND) * tolerance_m
            for point, face in triangles_containing(points[here], normals[point_triangle[here]],
                                                    scene_triangles_m[faces], behind_m,
                                                    np.searchsorted(faces, point_triangle[here])):
                yield here[point], faces[face]

    return on_another_face


def overlap_test(scene_triangles_m: np.ndarray, tolerance_m: float):
    """``on_another_face(point_triangle, barycentric)``: ``other_face_test``'s answer for surface points given by
    their scene triangles and (m, 3) barycentrics, for many calls of a few points each (where gather rays land).
    The pairs of triangles that overlap in their plane or the opposite one are found once: where a corner of one
    (OVERLAP_INSET of the way to its centroid) or its centroid lies in the other, at any depth. Each triangle's
    partners are binned on a grid over its own (u, v) barycentrics (OVERLAP_PARTNERS_PER_CELL to a cell, on the
    mean: a floor holds hundreds of tiles), and a point is tested, as ``other_face_test`` tests it, against the
    partners of its cell alone. Two triangles that cross without a corner or centroid of one in the other (two
    slivers crossing in an X) are missed."""
    count = len(scene_triangles_m)
    centroids = scene_triangles_m.mean(axis=1, keepdims=True)
    points = np.concatenate([scene_triangles_m + OVERLAP_INSET * (centroids - scene_triangles_m), centroids], axis=1)
    point, face = other_face_test(scene_triangles_m, tolerance_m)(
        np.repeat(np.arange(count), 4), points.reshape(-1, 3), any_depth=True, faces=True)
    pairs = np.unique(np.stack([np.concatenate([point // 4, face]), np.concatenate([face, point // 4])], axis=1),
                      axis=0)
    mine, partner = pairs[:, 0], pairs[:, 1]
    normals = triangle_unit_normals(scene_triangles_m)
    same_way = np.einsum("nk,nk->n", normals[mine], normals[partner]) > 0
    behind_m = np.where(same_way, COINCIDENT_BEHIND, CONTACT_BEHIND) * tolerance_m
    side = np.ceil(np.sqrt(np.bincount(mine, minlength=count) / OVERLAP_PARTNERS_PER_CELL)).astype(np.int64)
    first_cell = np.concatenate([[0], np.cumsum(side ** 2)])
    cell, pair = _partner_cells(scene_triangles_m, mine, partner, side, first_cell)
    cell_start = np.searchsorted(cell, np.arange(first_cell[-1] + 2))  # one past the last: a triangle of none

    def on_another_face(point_triangle: np.ndarray, barycentric: np.ndarray) -> np.ndarray:
        grid = side[point_triangle]
        u, v = (np.clip(barycentric[:, axis] * grid, 0, np.maximum(grid - 1, 0)).astype(np.int64) for axis in (1, 2))
        here = first_cell[point_triangle] + u * grid + v
        partners = np.where(grid > 0, cell_start[here + 1] - cell_start[here], 0)
        point = np.repeat(np.arange(len(point_triangle)), partners)
        tested = pair[np.repeat(cell_start[here], partners) + concatenated_ranges(partners)]
        hit = _inside_pairs(np.einsum("mc,mck->mk", barycentric[point], scene_triangles_m[point_triangle[point]]),
                            normals[point_triangle[point]], scene_triangles_m[partner[tested]], behind_m[tested])
        covered = np.zeros(len(point_triangle), dtype=bool)
        covered[point[hit]] = True
        return covered

    return on_another_face


def _partner_cells(scene_triangles_m, mine, partner, side, first_cell) -> tuple[np.ndarray, np.ndarray]:
    """(cell, pair) sorted by cell: each pair (``mine``, ``partner``) in every cell of ``mine``'s side x side grid
    over its (u, v) barycentrics that the partner's bounding box in those coordinates overlaps."""
    grid = side[mine]
    low, high = [], []
    for coordinate in _edge_coordinates(scene_triangles_m[mine], scene_triangles_m[partner])[:2]:
        low.append(np.clip(np.floor(coordinate.min(axis=1) * grid), 0, grid - 1).astype(np.int64))
        high.append(np.clip(np.floor(coordinate.max(axis=1) * grid), 0, grid - 1).astype(np.int64))
    across, up = high[0] - low[0] + 1, high[1] - low[1] + 1
    pair = np.repeat(np.arange(len(mine)), across * up)
    step = concatenated_ranges(across * up)
    u, v = low[0][pair] + step // up[pair], low[1][pair] + step % up[pair]
    cell = first_cell[mine[pair]] + u * side[mine[pair]] + v
    order = np.argsort(cell, kind="stable")
    return cell[order], pair[order]


def triangle_planes(triangles_m: np.ndarray, tolerance_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The planes of (T, 3, 3) triangles, matched by normal (to 1/PLANE_NORMAL_STEPS per component) and offset (to
    ``tolerance_m``): (P, 4) int64 plane keys (negated, the same plane facing the other way), (T,) each
    triangle's plane, and (T, 3) the triangles' unit normals."""
    normals = triangle_unit_normals(triangles_m)
    offsets = np.einsum("tk,tk->t", normals, triangles_m[:, 0])
    keys = np.concatenate([np.round(normals * PLANE_NORMAL_STEPS), np.round(offsets / tolerance_m)[:, None]],
                          axis=1).astype(np.int64)
    plane_of, first = row_groups(keys)
    return keys[first], plane_of, normals


def inside_any_triangle(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray,
                        behind_m: float | np.ndarray, own: np.ndarray | None = None) -> np.ndarray:
    """(p,) whether each point lies inside any of the triangles: ``triangles_containing``'s points."""
    inside = np.zeros(len(points), dtype=bool)
    for point, _ in triangles_containing(points, normals, triangles, behind_m, own):
        inside[point] = True
    return inside


def triangles_containing(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray,
                         behind_m: float | np.ndarray, own: np.ndarray | None = None):
    """Yields (point, triangle) index arrays, a bounded number at a time: each point (near the triangles' plane)
    with each of the (q, 3, 3) triangles it lies inside whose plane is at most ``behind_m`` (one for all, or (q,)
    one per triangle) behind it along its unit normal (all points share one plane), other than the one ``own``
    (p,) gives it (an index into ``triangles``; or none). Points are binned on a grid in that plane,
    POINTS_PER_CELL to a cell on average, and each triangle is tested only against the points of the cells its
    bounding box overlaps: the work follows the overlap, not points x triangles."""
    if len(points) == 0 or len(triangles) == 0:
        return
    axes = tangent_frames(normals[:1])[0, :2]
    flat, corners = points @ axes.T, triangles @ axes.T
    low, cell, shape, order, cell_start = _bin_points(flat)
    margin = 1e-9 * max(1.0, float(np.abs(flat).max()))
    lower = np.floor((corners.min(axis=1) - margin - low) / cell).astype(np.int64)
    upper = np.floor((corners.max(axis=1) + margin - low) / cell).astype(np.int64)
    overlaps = np.flatnonzero((upper >= 0).all(axis=1) & (lower < shape).all(axis=1))
    lower, upper = np.clip(lower[overlaps], 0, shape - 1), np.clip(upper[overlaps], 0, shape - 1)
    span = upper - lower + 1
    cells_per_triangle = span[:, 0] * span[:, 1]
    # Triangles a few at a time, and their (point, triangle) pairs a bounded number at a time.
    for first, stop in budget_ranges(cells_per_triangle, CANDIDATES_PER_CHUNK // POINTS_PER_CELL):
        triangle = np.repeat(np.arange(first, stop), cells_per_triangle[first:stop])
        within = concatenated_ranges(cells_per_triangle[first:stop])
        grid = (lower[triangle, 0] + within // span[triangle, 1]) * shape[1] + lower[triangle, 1] + \
            within % span[triangle, 1]
        count = cell_start[grid + 1] - cell_start[grid]
        for start, end in budget_ranges(count, CANDIDATES_PER_CHUNK):
            point = order[np.repeat(cell_start[grid[start:end]], count[start:end]) +
                          concatenated_ranges(count[start:end])]
            pair_triangle = overlaps[np.repeat(triangle[start:end], count[start:end])]
            hit = _inside_pairs(points[point], normals[point], triangles[pair_triangle],
                                np.broadcast_to(behind_m, len(triangles))[pair_triangle])
            if own is not None:
                hit &= pair_triangle != own[point]
            yield point[hit], pair_triangle[hit]


def _bin_points(flat: np.ndarray) -> tuple:
    """(p, 2) points binned on a grid of about POINTS_PER_CELL points a cell (at most GRID_CELLS_PER_AXIS cells
    along its longer side): its corner, cell size and (rows, columns) shape, the points in cell order, and where
    each cell's points start in that order ((cells + 1,), the last entry p)."""
    low, extent = flat.min(axis=0), np.ptp(flat, axis=0)
    cell = max(np.sqrt(extent[0] * extent[1] * POINTS_PER_CELL / len(flat)), extent.max() / GRID_CELLS_PER_AXIS,
               1e-9)
    shape = np.floor(extent / cell).astype(np.int64) + 1
    index = np.clip(np.floor((flat - low) / cell).astype(np.int64), 0, shape - 1)
    point_cell = index[:, 0] * shape[1] + index[:, 1]
    order = np.argsort(point_cell, kind="stable")
    return low, cell, shape, order, np.searchsorted(point_cell[order], np.arange(shape[0] * shape[1] + 1))


def _inside_pairs(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray,
                  behind_m: float | np.ndarray) -> np.ndarray:
    """(n,) for (point, triangle) pairs: the point projects inside the triangle (barycentrics by the normal
    equations of its edges), whose plane lies at most ``behind_m`` (one, or one per pair) behind the point along
    its unit normal (measured to the triangle's own plane, which round-off may tilt)."""
    u, v, rel = _edge_coordinates(triangles, points)
    plane_normal = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    along = np.einsum("nk,nk->n", plane_normal, normals)
    along = np.where(np.abs(along) > 1e-300, along, np.inf)
    height = np.einsum("nk,nk->n", rel, plane_normal) / along  # > 0: the triangle's plane is behind
    return (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9) & (height <= behind_m)


def _edge_coordinates(triangles: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u, v, rel) of points, (n, 3) or (n, c, 3), in the planes of (n, 3, 3) triangles: the point projects to
    corner 0 + u e1 + v e2 (e1, e2 the edges from corner 0; by the normal equations of the edges), and rel is the
    point less corner 0."""
    e1, e2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    d11, d12, d22 = (np.einsum("nk,nk->n", e1, e1), np.einsum("nk,nk->n", e1, e2), np.einsum("nk,nk->n", e2, e2))
    det = d11 * d22 - d12 * d12
    det = np.where(np.abs(det) > 1e-300, det, np.inf)
    per_point = (slice(None),) + (None,) * (points.ndim - 2)  # (n,) quantities against (n, c) points
    rel = points - triangles[:, 0][per_point]
    r1, r2 = np.einsum("n...k,nk->n...", rel, e1), np.einsum("n...k,nk->n...", rel, e2)
    d11, d12, d22, det = d11[per_point], d12[per_point], d22[per_point], det[per_point]
    return (d22 * r1 - d12 * r2) / det, (d11 * r2 - d12 * r1) / det, rel


def tangent_rays(points: np.ndarray, normals: np.ndarray, offset_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(m * 8, 3) origins ``offset_m`` above the points and unit directions at 45 degree steps in their tangent
    planes."""
    frames = tangent_frames(normals)
    local = np.stack([np.cos(TANGENT_ANGLES), np.sin(TANGENT_ANGLES)], axis=1)
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


def nearest_uncovered(caster: RayCaster, scene_triangles_m: np.ndarray, triangles_m: np.ndarray,
                      barycentric: np.ndarray, offset_m: float) -> np.ndarray:
    """(m, 3) barycentrics on each of the (m, 3, 3) triangles of the nearest point found that is not inside
    closed geometry, for (m, 3) points that are (a decimated floor's corner under a wall): along the lines from
    each point to its triangle's corners, edge midpoints and centroid, the first of ``UNCOVER_STEPS`` that is
    free, then ``UNCOVER_BISECTIONS`` halvings towards where the line leaves the geometry; of those, the one
    nearest the point. A corner under a wall's junction thus takes the light of the room's corner, not of a spot
    a quarter of the floor away. Points are tested a hair inside their triangle, as ``Solution`` tests them.
    Points with no free point on any line are returned unchanged."""
    targets = np.vstack([np.eye(3), (1.0 - np.eye(3)) / 2.0, np.full(3, 1.0 / 3.0)])      # (K, 3) barycentrics
    count, lines = len(barycentric), len(targets)
    start = np.repeat(barycentric, lines, axis=0)
    toward = np.tile(targets, (count, 1)) - start
    triangle = np.repeat(np.arange(count), lines)
    normals = triangle_unit_normals(triangles_m)[triangle]

    def free(step: np.ndarray, rows: np.ndarray) -> np.ndarray:
        moved = start[rows] + step[:, None] * toward[rows]
        corners = triangles_m[triangle[rows]]
        points = inset(np.einsum("mc,mck->mk", moved, corners), corners.mean(axis=1), 4 * offset_m)
        return ~inside_closed_geometry(caster, scene_triangles_m, points, normals[rows], offset_m)

    buried, clear = np.zeros(len(start)), np.full(len(start), np.inf)
    for step in UNCOVER_STEPS:
        rows = np.flatnonzero(~np.isfinite(clear))
        found = free(np.full(len(rows), step), rows)
        clear[rows[found]], buried[rows[~found]] = step, step
    rows = np.flatnonzero(np.isfinite(clear))
    for _ in range(UNCOVER_BISECTIONS):
        middle = 0.5 * (buried[rows] + clear[rows])
        found = free(middle, rows)
        clear[rows[found]], buried[rows[~found]] = middle[found], middle[~found]
    length = lengths(np.einsum("mc,mck->mk", toward, triangles_m[triangle]))
    distance = np.full(len(clear), np.inf)  # along each line to its first clear step; inf: none is clear
    finite = np.isfinite(clear)
    distance[finite] = clear[finite] * length[finite]
    distance = distance.reshape(count, lines)
    best = distance.argmin(axis=1)
    out = barycentric.copy()
    found = np.flatnonzero(np.isfinite(distance[np.arange(count), best]))
    pick = found * lines + best[found]
    out[found] = start[pick] + clear[pick, None] * toward[pick]
    return out
