"""Final gather: indirect light at points by looking up the radiosity solution where rays from them land.

Radiosity paper, section 10 (two-pass methods): the view-independent solution supplies the light leaving every
surface; a per-point gather over the hemisphere turns it into irradiance at points much finer than the elements.
With cosine-weighted directions (pdf cos(theta) / pi) the indirect irradiance is

    E(x) = integral of L(hit) cos(theta) dw  ~  (pi / N) sum L(hit)  =  (1 / N) sum B_r(hit),

where B_r = rho H is the reflected radiosity at the hit (a diffuse surface's radiance is B / pi), and a ray that
escapes brings the world's radiance (pi L_world in place of B_r: the sky by the gather's many cosine-weighted rays
rather than the direct light's few, as Cycles traces it by BSDF samples). Emission is left out: core.direct_light adds
it exactly, with shadow rays. A ray that lands on the back of a face
sees the back side's radiosity (surfaces reflect from both sides, as in Cycles); unsolved ("shadow only")
surfaces return nothing, as do faces where they overlap another in their plane (Cycles renders them black), and so
do directions below the face's own plane when the cosine lobe is turned by a
shading normal (Cycles' diffuse BSDF gives them no weight). Directions are stratified (s x s jittered cells,
Malley's method) with a seeded shift per point, so the result is deterministic.
"""
from __future__ import annotations

import numpy as np

from .errors import BakeCancelled
from .geometry import lengths, tangent_frames, triangle_areas, triangle_unit_normals
from .parallel import ordered_map
from .progress import Progress, never_cancelled, no_progress
from .ragged import even_ranges
from .raycast import RayCaster
from .sampling import cosine_hemisphere, stratified_square
from .scene import MAX_REFLECTANCE

RAYS_PER_CHUNK = 1 << 20
FREE_PATH_RAYS = 1 << 14
# A final gather pays where half the light a surface receives comes from surfaces closer than this many elements
# (the median free path): there, irradiance interpolated between elements blurs what the elements are too coarse to
# resolve (an arcade's ceiling 3 m above a floor, with 2.5 m elements; a furnished room's props). The median, not
# the mean, which the long rays across a room's open middle hold up. Where the threshold comes from:
# docs/benchmarks.md, "Presets".
GATHER_BELOW_ELEMENTS = 2.0
# A gather ray that lands within this many element sizes of its origin gathers the indirect light there again
# (``final_gather``'s near_m), by NEAR_SAMPLES_PER_EDGE^2 rays: close by, the element's one value is not the light
# of the spot the ray meets (measured: docs/benchmarks.md, "Vertex colours" and "Gathering again near by").
NEAR_ELEMENTS = 2.0
NEAR_SAMPLES_PER_EDGE = 1  # one ray per near hit: the least noise per second
RECEIVER_ITERATIONS = 1000  # the most Jacobi iterations of gather_at_receivers' transport
RECEIVER_RAYS_PER_CHUNK = 1 << 18  # its rays traced at once: their hits and shadow rays, some 70 MB, beside the links
RECEIVER_TOLERANCE = 1e-4   # they stop when the receivers' indirect light changes by less than this share


def free_paths_m(scene, caster: RayCaster, offset_m: float, seed: int) -> np.ndarray:
    """(k,) distances from surface points to the surface each sees along a cosine-weighted direction, for the k of
    FREE_PATH_RAYS rays that land, from points spread by area over the solved triangles (either side of each).
    Inside a closed convex room their mean is the mean chord length 4 V / S (Cauchy's formula); between two wide
    parallel plates h apart their median is sqrt(2) h (cos^2 of a cosine-weighted direction is uniform)."""
    triangles = scene.triangles[~scene.casts_only]
    rng = np.random.default_rng(seed)
    area = triangle_areas(triangles)
    picked = triangles[rng.choice(len(triangles), FREE_PATH_RAYS, p=area / area.sum())]
    u, v = rng.random((2, FREE_PATH_RAYS, 1))
    fold = u + v > 1
    u, v = np.where(fold, 1 - u, u), np.where(fold, 1 - v, v)
    points = picked[:, 0] + u * (picked[:, 1] - picked[:, 0]) + v * (picked[:, 2] - picked[:, 0])
    normals = triangle_unit_normals(picked) * rng.choice([-1.0, 1.0], (FREE_PATH_RAYS, 1))
    local = cosine_hemisphere(stratified_square(FREE_PATH_RAYS, 1, seed))
    directions = np.einsum("mrk,mkj->mrj", local, tangent_frames(normals))[:, 0]
    hit, bary = caster.first_hit(points + offset_m * normals, directions)
    landed = hit >= 0
    ends = np.einsum("mc,mck->mk", bary[landed], scene.triangles[hit[landed]])
    return lengths(ends - points[landed])


def gather_at_receivers(solutions: list, samples_per_edge: int, seed: int, workers: int = 1,
                        progress: Progress = no_progress, cancelled=never_cancelled) -> list:
    """The hierarchical ``solutions`` (a scene's, or its light groups' along the same rays) with each live
    element side's indirect irradiance solved again over rays in place of the links: from each side's receiver
    point s^2 cosine-weighted rays, seeded from ``seed``, land on element sides; H_i = (1 / N) sum over its rays
    of rho (E + H_j) at the landing point, with E the direct irradiance there (one shadow ray, as
    Solution.landing) and H_j the indirect irradiance of the side landed on (escaping rays bring nothing: the
    sides' direct light has the world's). This transport, traced once, is iterated from the links' solution
    until it settles (Jacobi, RECEIVER_TOLERANCE): the two-pass method of the radiosity paper, section 10, at
    the elements, where the links are least exact (close by, a link to a cluster of a curved surface draws its
    parts as flat squares; measured: docs/benchmarks.md, "Third-party scene")."""
    def checked():
        if cancelled():
            raise BakeCancelled("Bake cancelled while gathering at the elements.")

    first = solutions[0]
    element, side = np.nonzero(first.elements.alive)
    receiver = element * 2 + side
    points, normals = first.elements.point[element, side], first.elements.normal[element, side]
    chunks = even_ranges(len(points), max(1, RECEIVER_RAYS_PER_CHUNK // samples_per_edge ** 2))

    def traced(chunk):
        checked()
        progress(chunk.start / max(len(points), 1), "Gathering at the elements")
        return _receiver_transport(solutions, points[chunk], normals[chunk], samples_per_edge, seed + chunk.start)

    parts = list(ordered_map(traced, chunks, workers))
    rows = np.concatenate([part[0] + chunk.start for chunk, part in zip(chunks, parts)])
    target = np.concatenate([part[1] for part in parts])
    weight = np.concatenate([part[2] for part in parts])
    gathered = []
    for number, solution in enumerate(solutions):
        constant = np.concatenate([part[3][number] for part in parts])
        indirect = solution.side_indirect_irradiance().reshape(-1, 3).copy()
        for _ in range(RECEIVER_ITERATIONS):
            checked()
            again = constant + _sum_by_row(rows, weight * indirect[target], len(points))
            change = np.abs(again - indirect[receiver]).sum() / max(np.abs(again).sum(), 1e-300)
            indirect[receiver] = again
            if change < RECEIVER_TOLERANCE:
                break
        gathered.append(solution.with_indirect(indirect.reshape(-1, 2, 3)))
    return gathered


def _receiver_transport(solutions, points, normals, samples_per_edge, seed):
    """gather_at_receivers' rays from c receivers: per distinct (receiver, side landed on) pair, the (p,) receiver,
    (p,) side landed on and (p, 3) sum of rho / N over its rays (rho capped at core.scene.MAX_REFLECTANCE, so
    that light between white walls stays finite), and (G, c, 3) each lighting's (1 / N) sum of rho E."""
    first = solutions[0]
    rays = samples_per_edge ** 2
    _, hit, bary, _, landed, side = _gather_rays(first.scene, first.caster, points[:, None, :], normals, normals,
                                                 samples_per_edge, first.offset_m, seed)
    landings = [solution.landing(hit[landed], bary[landed], side, seed) for solution in solutions]
    lit, sides, reflectance, _ = landings[0]  # the same surfaces in each
    row = landed[lit] // rays
    constant = np.stack([_sum_by_row(row, reflectance * direct / rays, len(points)) for *_, direct in landings])
    sides_count = 2 * first.elements.count
    pairs, which = np.unique(row * sides_count + sides, return_inverse=True)
    weight = _sum_by_row(which, np.minimum(reflectance, MAX_REFLECTANCE) / rays, len(pairs))
    return ((pairs // sides_count).astype(np.int32), (pairs % sides_count).astype(np.int32),
            weight.astype(np.float32), constant)


def _sum_by_row(rows: np.ndarray, values: np.ndarray, count: int) -> np.ndarray:
    """(count, 3) sums of the (k, 3) values by their (k,) rows."""
    return np.stack([np.bincount(rows, weights=channel, minlength=count) for channel in values.T], axis=1)


def gather_pays(solution) -> bool:
    """Whether a final gather resolves the indirect light better than interpolation between the solution's
    elements: where the median free path is under GATHER_BELOW_ELEMENTS elements (none landing: no)."""
    paths = free_paths_m(solution.scene, solution.caster, solution.offset_m, 0)
    return len(paths) > 0 and float(np.median(paths)) < GATHER_BELOW_ELEMENTS * solution.element_size_m


def final_gather(solution, caster: RayCaster, points: np.ndarray, normals: np.ndarray, samples_per_edge: int,
                 offset_m: float, seed: int, face_normals: np.ndarray | None = None, near_m: float = 0.0,
                 near_samples_per_edge: int = 0, workers: int = 1,
                 exact_lights: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(m, 3) indirect and world light (irradiance / pi) at (m, q, 3) points (q points per texel, used in turn by
    its rays) with (m, 3) unit (shading) normals, from s^2 gather rays each, and the (m, 3) variance of that mean
    (the rays' sample variance over their count, for core.denoise); ``face_normals`` (m, 3), where they differ
    from the shading normals, cut off the directions below the face. Where a ray lands within ``near_m`` of its
    origin, the light there is gathered again by ``near_samples_per_edge``^2 rays instead of taken from the
    element: close by, in a concave corner, the element's one value is not the light of the spot the ray meets.
    Where a ray lands, the lamps' light comes by one shadow ray to one lamp chosen by importance, after one to
    each of the ``exact_lights`` brightest there (Solution.reflected_radiosity): a scene with no more lamps than
    that has none of the choice's noise at those hits (the second gather near by keeps one lamp per ray: it
    casts most of the shadow rays and brings the least light). Chunks of at most RAYS_PER_CHUNK rays (bounded
    memory), ``workers`` of them side by side (core.parallel), each seeded by its first point."""
    light, variance, _ = final_gather_parts([solution], caster, points, normals, samples_per_edge, offset_m, seed,
                                            face_normals, near_m, near_samples_per_edge, workers, exact_lights)
    return light[0], variance


def final_gather_parts(solutions: list, caster: RayCaster, points: np.ndarray, normals: np.ndarray,
                       samples_per_edge: int, offset_m: float, seed: int, face_normals: np.ndarray | None = None,
                       near_m: float = 0.0, near_samples_per_edge: int = 0, workers: int = 1,
                       exact_lights: int = 0, min_chunks: int = 1, close_m: np.ndarray | float = 0.0,
                       world: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``final_gather`` of several solutions of the same surfaces, lit by parts of the light (light groups,
    core.bake.bake_light_groups), along the same rays: (G, m, 3) each one's light, the (m, 3) variance of the
    mean of their sum (the rays' sample variance of the summed light over their count), and the (m,) share of
    each point's rays that land within its ``close_m`` (a scalar or (m,); the denoiser's guide, core.denoise).
    The points are split into at least ``min_chunks`` chunks where there are that many, so that one call's chunks
    can fill ``workers`` (a fixed number, not ``workers``: the chunks seed the rays, and the result must not depend
    on the machine). ``world`` False: rays that escape bring nothing (the indirect light alone, for points whose
    direct light has the world's)."""
    rays = samples_per_edge ** 2
    step = max(1, min(RAYS_PER_CHUNK // rays, -(-len(points) // min_chunks)))
    faces = normals if face_normals is None else face_normals
    chunks = even_ranges(len(points), step)
    close_m = np.broadcast_to(close_m, len(points))
    gathered = lambda chunk: _gather_chunk(solutions, caster, points[chunk], normals[chunk], faces[chunk],
                                           samples_per_edge, offset_m, seed + chunk.start, near_m,
                                           near_samples_per_edge, exact_lights, close_m[chunk], world)
    light, variance = np.zeros((len(solutions), len(points), 3)), np.zeros((len(points), 3))
    close_share = np.zeros(len(points))
    for chunk, parts in zip(chunks, ordered_map(gathered, chunks, workers)):
        light[:, chunk], variance[chunk], close_share[chunk] = parts
    return light, variance, close_share


def _gather_chunk(solutions, caster, points, normals, face_normals, samples_per_edge, offset_m, seed, near_m,
                  near_samples_per_edge, exact_lights, close_m, world):
    solution = solutions[0]  # the surfaces are the same in each
    count, rays = len(points), samples_per_edge ** 2
    origins, hit, bary, above, landed, side = _gather_rays(solution.scene, caster, points, normals, face_normals,
                                                           samples_per_edge, offset_m, seed)
    distance = lengths(np.einsum("mc,mck->mk", bary[landed], solution.scene.triangles[hit[landed]]) -
                       origins[landed])
    near = distance < near_m if near_samples_per_edge > 0 else np.zeros(len(landed), dtype=bool)
    close = np.zeros(len(hit), dtype=bool)
    close[landed] = distance < np.repeat(close_m, rays)[landed]
    far, again = landed[~near], landed[near]
    radiosity = np.zeros((len(solutions), len(hit), 3))
    for part, lit in zip(radiosity, solutions):
        part[far] = lit.reflected_radiosity(hit[far], bary[far], side[~near], seed, exact_lights=exact_lights)
        if len(again):
            part[again] = lit.reflected_radiosity(hit[again], bary[again], side[near], seed + len(hit),
                                                  near_samples_per_edge, exact_lights)
        if world:
            part[(hit < 0) & above] = np.pi * np.asarray(lit.scene.world.radiance, dtype=np.float64)
    per_ray = radiosity.reshape(len(solutions), count, rays, 3) / np.pi
    return per_ray.mean(axis=2), per_ray.sum(axis=0).var(axis=1) / rays, close.reshape(count, rays).mean(axis=1)


def _gather_rays(scene, caster: RayCaster, points: np.ndarray, normals: np.ndarray, face_normals: np.ndarray,
                 samples_per_edge: int, offset_m: float, seed: int):
    """The s^2 stratified cosine-weighted rays from each of m points (q points (m, q, 3) used in turn by a point's
    rays) about its unit normal: (m s^2, 3) origins, their hits' (m s^2,) triangles and (m s^2, 3) barycentrics,
    (m s^2,) whether each leaves above the face (``face_normals``), the (k,) rays that land above it, and (k,) the
    side they land on (0 front, 1 back)."""
    count, rays = len(points), samples_per_edge ** 2
    local = cosine_hemisphere(stratified_square(count, samples_per_edge, seed))
    directions = np.einsum("mrk,mkj->mrj", local, tangent_frames(normals)).reshape(-1, 3)
    which = np.arange(rays) % points.shape[1]
    origins = (points[:, which, :] + offset_m * normals[:, None, :]).reshape(-1, 3)
    hit, bary = caster.first_hit(origins, directions)
    above = np.einsum("mrk,mk->mr", directions.reshape(count, rays, 3), face_normals).ravel() > 0
    landed = np.flatnonzero((hit >= 0) & above)
    side = (np.einsum("mk,mk->m", scene.unit_normals[hit[landed]], directions[landed]) > 0).astype(np.int64)
    return origins, hit, bary, above, landed, side
