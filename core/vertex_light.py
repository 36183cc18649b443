"""Light at mesh corners, for vertex colours: what Cycles' vertex bake evaluates at the vertex itself.

Direct light is traced at each corner (core.solution.Solution.direct_light). Indirect light comes by one of two
methods, or by "auto": the gather at corners where surfaces lie close by (a crease, a contact), interpolation
elsewhere (open flat surfaces, where it is smooth and the gather would only add noise):
- a final gather from the corner (core.gather.final_gather: s x s cosine-weighted stratified rays, seeded; where a
  ray lands, the reflectance there x (its direct light + its indirect light); an escaping ray brings the sky).
  The indirect light where a ray lands is the element's, except within NEAR_ELEMENTS element sizes of the corner,
  where it is gathered again: in a concave corner (a room's, where walls of one quad each meet) most rays land
  close by, and neither the elements around the corner nor the one under a close hit hold the light of that
  spot. The gather measured closer to Cycles there (docs/benchmarks.md, "Vertex colours").
  Where a ray lands, each of the EXACT_LIGHTS_PER_HIT lamps brightest there gets a shadow ray (and one more goes
  to one of the others, chosen by importance): with no texel denoiser after it, a corner would otherwise keep the
  noise of choosing one lamp per hit, which sets a relit corner apart from a new bake's (about 1% with four
  lamps; docs/benchmarks.md, "Update Light").
- interpolation from the elements around the corner (core.solution.Solution.evaluate): fast and smooth.
Corners that share a point, normals and material (the corners of one vertex on a flat or smooth-shaded surface)
share their rays: each such point is evaluated once. A corner on another face in the same plane (a duplicated
face; core.surface_probes.other_face_test) or under a face nearer than the ray offset (a rug a hair above the floor;
core.surface_probes.covered_within) gets no light, as in Cycles, by every method.

A mesh whose modifiers changed its topology keeps its original corners, which lie on or near the rendered surface
but on none of its triangles: ``projected_points`` casts two rays along each corner's normal line, one from
``reach_m`` in front of it looking back and one from ``reach_m`` behind it looking forward, and takes the light at
the hit nearer to the corner on the object's solved triangles. So a surface up to ``reach_m`` on either side is
found even when the corner lies inside it. A surface turned like the corner's face is preferred, and a corner
whose line meets none is tried again a little way into its face; it stays black only when none of those lines
meets the surface.
"""
from __future__ import annotations

import numpy as np

from .errors import SettingsError
from .gather import NEAR_ELEMENTS, NEAR_SAMPLES_PER_EDGE, final_gather_parts
from .geometry import lengths, tangent_frames, triangle_unit_normals
from .parallel import MAX_STEPS_IN_FLIGHT, steps_in_flight
from .ragged import row_groups
from .raycast import RayCaster
from .sampling import cosine_hemisphere, stratified_square
from .surface_probes import covered_within, other_face_test

NORMAL_STEPS = 1e4  # normals are matched to 1e-4 per component when corners share a point
EXACT_LIGHTS_PER_HIT = 8  # the lamps brightest where a corner's gather ray lands that get a shadow ray each
PROBE_SAMPLES_PER_EDGE = 4  # rays per edge that tell whether surfaces lie close to a corner (method "auto")
GATHER_NEAR_SHARE = 0.3  # "auto" gathers where at least this share of the probe rays lands close by
VERTEX_METHODS = ("auto", "gather", "interpolate")
PROJECTION_INSET_STEPS = (0.0, 0.05, 0.15, 0.3, 0.5)  # of the way from a corner to its face's centroid
FACING_ALIGNMENT = 0.9  # a surface turned within about 25 degrees of a corner's normal is taken first


def corner_light(solution, scene_triangle: np.ndarray, barycentric: np.ndarray, method: str,
                 gather_samples_per_edge: int, seed: int = 0, lightings: list | None = None) -> np.ndarray:
    """(m, 3) light (irradiance / pi, as outputs store it) at surface points given by scene triangle and
    barycentrics: direct light traced there, indirect light by ``method``: "gather" (s^2 rays, s =
    ``gather_samples_per_edge``), "interpolate", or "auto": the gather at corners where surfaces lie close by
    (``near_share``), interpolation elsewhere. NaN on unsolved triangles. With ``lightings`` (G solutions of the
    same surfaces lit by parts of the light: light groups, sources), (G, m, 3) the light of each, the gather's
    rays shared."""
    if method not in VERTEX_METHODS:
        raise SettingsError(f"Vertex indirect light must be one of {', '.join(VERTEX_METHODS)}, got '{method}'.")
    scene_triangle = np.asarray(scene_triangle, dtype=np.int64)
    barycentric = np.asarray(barycentric, dtype=np.float64)
    parts = [solution] if lightings is None else list(lightings)
    moved, points, normals = solution.sample_points(scene_triangle, barycentric)
    if method == "interpolate":
        light = np.stack([part.light_at(scene_triangle, moved, points, normals, direct_per_point=True)
                          for part in parts])
        light[:, _dark(solution, scene_triangle, points, normals)] = 0.0
        return light if lightings is not None else light[0]
    shading = solution.scene.shading_normals(scene_triangle, moved)
    surface = np.einsum("mc,mck->mk", moved, solution.scene.triangles[scene_triangle])  # before the inset
    first, shared = _distinct(solution, scene_triangle, surface, normals, shading)
    triangle, point, face, shade = scene_triangle[first], points[first], normals[first], shading[first]
    gathered = np.ones(len(first), dtype=bool)
    if method == "auto":
        gathered = near_share(solution, point, face, seed) >= GATHER_NEAR_SHARE
    light = np.zeros((len(parts), len(first), 3))
    near_m = NEAR_ELEMENTS * solution.element_size_m
    here, rest = np.flatnonzero(gathered), np.flatnonzero(~gathered)
    indirect, _, _ = final_gather_parts(parts, solution.caster, point[here][:, None, :], shade[here],
                                       gather_samples_per_edge, solution.offset_m, seed, face_normals=face[here],
                                       near_m=near_m, near_samples_per_edge=NEAR_SAMPLES_PER_EDGE,
                                       workers=steps_in_flight(solution.caster.threads),
                                       exact_lights=EXACT_LIGHTS_PER_HIT, min_chunks=MAX_STEPS_IN_FLIGHT)
    for part, part_light, part_indirect in zip(parts, light, indirect):
        part_light[here] = part.output_light(part.direct_light(
            point[here], shade[here], triangle[here], moved[first][here], world=False) + part_indirect,
            triangle[here])
        part_light[rest] = part.light_at(triangle[rest], moved[first][rest], point[rest], face[rest],
                                         direct_per_point=True)
    light[:, _dark(solution, triangle, point, face)] = 0.0
    return light[:, shared] if lightings is not None else light[0, shared]


def _dark(solution, scene_triangle: np.ndarray, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(m,) points where Cycles' rays, which start on the surface, meet another face at once, as lightmap texels
    are tested (core.lightmap.sample_texels): on another face in their plane (core.surface_probes.other_face_test,
    at 4 ray offsets) or under a face nearer than the ray offset along their unit normals (covered_within)."""
    on_another_face = other_face_test(solution.scene.triangles, 4 * solution.offset_m)(scene_triangle, points)
    return on_another_face | covered_within(solution.caster, points, normals, solution.offset_m)


def near_share(solution, points: np.ndarray, normals: np.ndarray, seed: int) -> np.ndarray:
    """(m,) share of PROBE_SAMPLES_PER_EDGE^2 cosine-weighted rays from each point that meet a surface within
    NEAR_ELEMENTS element sizes: half or more in a concave crease (a wall's foot), none on open flat ground."""
    rays = PROBE_SAMPLES_PER_EDGE ** 2
    local = cosine_hemisphere(stratified_square(len(points), PROBE_SAMPLES_PER_EDGE, seed))
    directions = np.einsum("mrk,mkj->mrj", local, tangent_frames(normals)).reshape(-1, 3)
    origins = np.repeat(points + solution.offset_m * normals, rays, axis=0)
    distance = solution.caster.hit_distance(origins, directions)
    return (distance < NEAR_ELEMENTS * solution.element_size_m).reshape(-1, rays).mean(axis=1)


def _distinct(solution, scene_triangle, points, normals, shading) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the distinct (surface point, face normal, shading normal, material) among the corners, and for
    every corner the position of its own among them; each is evaluated at the first corner's inset point."""
    key = np.concatenate([np.round(points / solution.offset_m), np.round(normals * NORMAL_STEPS),
                          np.round(shading * NORMAL_STEPS), solution.scene.material_index[scene_triangle][:, None]],
                         axis=1).astype(np.int64)
    shared, first = row_groups(key)
    return first, shared


def projected_points(solution, triangles: np.ndarray, points: np.ndarray, normals: np.ndarray,
                     face_centroids: np.ndarray, reach_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(m,) scene triangle and (m, 3) barycentrics of the point where the normal line of each (m, 3) world corner
    point with unit normals meets the given solved scene triangles nearest to it (rays from ``reach_m`` out on
    either side), on a surface turned like the corner's face; triangle -1 where none is found. A corner whose
    line meets none is moved along PROJECTION_INSET_STEPS of the way towards its original face's centroid
    (``face_centroids``, (m, 3)) and tried again: a Bevel cuts a cube's edges back, so the normal line through an
    original corner runs in the plane of a neighbouring face, just outside it, or meets the chamfer at the
    corner. Corners that find no such surface take the nearest surface their lines meet, however it is turned
    (a curved Subdivision surface)."""
    caster = RayCaster(solution.scene.triangles[triangles], threads=1)
    hit_triangle = np.full(len(points), -1)
    hit_bary = np.zeros((len(points), 3))
    try:
        for alignment in (FACING_ALIGNMENT, -1.0):  # a face turned like the corner's first, then any surface
            for step in PROJECTION_INSET_STEPS:
                missing = np.flatnonzero(hit_triangle < 0)
                moved = points[missing] + step * (face_centroids[missing] - points[missing])
                found, triangle, bary = _nearest_along_normal(solution, caster, triangles, moved,
                                                              normals[missing], reach_m, alignment)
                hit_triangle[missing[found]], hit_bary[missing[found]] = triangle, bary
    finally:
        caster.close()
    return hit_triangle, hit_bary


def _nearest_along_normal(solution, caster, triangles, points, normals, reach_m, alignment):
    """For each point, the hit of its normal line on the triangles nearest to it (two rays, from ``reach_m`` out
    on either side, looking back), on a triangle whose normal's dot with the point's is at least ``alignment``:
    indices of the points that found one, their scene triangles and barycentrics."""
    best = np.full(len(points), np.inf)
    hit_triangle = np.full(len(points), -1)
    hit_bary = np.zeros((len(points), 3))
    for sign in (1.0, -1.0):
        hit, bary = caster.first_hit(points + sign * reach_m * normals, -sign * normals)
        found = np.flatnonzero(hit >= 0)
        facing = np.einsum("mk,mk->m", triangle_unit_normals(solution.scene.triangles[triangles[hit[found]]]),
                           normals[found])
        found = found[facing >= alignment]
        hit_points = np.einsum("mc,mck->mk", bary[found], solution.scene.triangles[triangles[hit[found]]])
        distance = lengths(hit_points - points[found])
        nearer = distance < best[found]
        closer = found[nearer]
        best[closer] = distance[nearer]
        hit_triangle[closer], hit_bary[closer] = triangles[hit[closer]], bary[closer]
    found = np.flatnonzero(hit_triangle >= 0)
    return found, hit_triangle[found], hit_bary[found]
