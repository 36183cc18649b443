"""Lightmap textures from a solved scene: per-texel direct light by shadow rays plus indirect light from the
radiosity solution (final gather, or interpolation between elements where the elements resolve the light: texels
facing a surface nearer than an element gather even then), then dilation into the padding and the stitching of UV
seams.

Values are irradiance / pi, scene-linear: what Cycles' Diffuse bake (Direct + Indirect, no Color) writes into an
image on the same UV map (docs/units.md). Images are (height, width, 3) float32 with row 0 at the bottom, as
Blender stores pixels.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from itertools import chain

import numpy as np

from .denoise import denoise_gathered
from .errors import BakeCancelled, SettingsError
from .gather import NEAR_ELEMENTS, NEAR_SAMPLES_PER_EDGE, final_gather_parts, gather_pays
from .parallel import ordered_map, steps_in_flight
from .progress import Progress, Timer, never_cancelled, no_progress
from .ragged import even_ranges
from .raycast import RayCaster
from .geometry import inset, lengths, triangle_areas
from .scene import PointLight, SpotLight, SunLight
from .seams import seam_points, stitch_seams
from .surface_probes import (buried_in_geometry, covered_within, distance_in_front, inside_closed_geometry,
                             other_face_test, push_out_of_geometry)
from .texels import (footprint_barycentrics, footprint_inside, footprint_steps, footprint_unfolded, rasterize,
                     sample_points, subcell_order)

INDIRECT_METHODS = ("auto", "gather", "interpolate")
# Texels lit per step: bounds the memory of the shadow and gather rays of a big page (9 points x 16 rays per
# texel at High), and lets progress and Esc through between steps.
TEXELS_PER_CHUNK = 8192
PLAN_TEXELS_PER_CHUNK = 65536  # texels whose footprints are probed at once: their rays take about 5 kB a texel
# Shadow edges: a texel whose sub-points' direct light from one source spreads over more than this share of the
# brightest (or differs by that much from a neighbour's) is lit again by that source from this many points per
# edge in each sub-point's cell: wide sources (area lights, emissive surfaces, the world) cast wide penumbrae, and
# suns, points and spots sharp edges, whose covered share needs the finer points (docs/benchmarks.md, "Penumbra
# texels", "Shadow edges between the sub-points" and "Shadow edges per light").
PENUMBRA_SPREAD = 0.1
PENUMBRA_SAMPLES_PER_EDGE = 2
SHARP_EDGE_SAMPLES_PER_EDGE = 3
LIGHT_SOURCES = 8  # of shadows whose edges are found apart (_light_sources): the memory of so many lit at once
GATHER_ORDER_STREAM = 1  # the random stream, beside the gather's directions', that orders its points
SLIVER_GRID = 4  # texels reaching fewer than s of their s x s gather points take them from a grid so much finer
# The denoiser keeps apart texels whose gather rays land within this many texels in shares that differ by more
# than their noise (a soffit's corner that runs into the next arch beside its open span): docs/benchmarks.md,
# History "Slivers gather over the sliver; the denoiser guided by close hits".
CLOSE_TEXELS = 4.0
GATHER_UNDER_ELEMENTS = 1.0  # interpolating, texels under a surface nearer than this many element sizes gather
SAME_SURFACE_COSINE = 0.999  # neighbouring texels whose faces' normals agree this well lie on one surface


@dataclass(frozen=True)
class LightmapSettings:
    """indirect: "gather" (rays from each texel look up the solution), "interpolate" (element corners: fast,
    softer) or "auto" (the gather where the elements are coarse next to the distances between surfaces,
    core.gather.gather_pays). gather_samples_per_edge: s, so s^2 gather rays per texel. subtexel_samples_per_edge:
    k, so direct light is averaged over k x k points of each texel's footprint, each with the bake's light samples
    per edge divided by k (rounded up): about the bake's shadow rays per texel, spread over its footprint, which on
    the sample scenes measured closer to Cycles than as many rays from the texel centre (docs/benchmarks.md).
    dilation_texels: how far values are grown into the empty texels around charts (the add-on: its padding). seed:
    of the stratified gather directions. denoise: filter the gathered indirect light over the page by its noise
    (core.denoise). The default method is the gather, the reference; the add-on's presets use "auto"."""

    indirect: str = "gather"
    gather_samples_per_edge: int = 8
    subtexel_samples_per_edge: int = 3
    dilation_texels: int = 4
    seed: int = 0
    denoise: bool = True

    def __post_init__(self):
        if self.indirect not in INDIRECT_METHODS:
            raise SettingsError(f"Setting 'indirect' must be one of {INDIRECT_METHODS}, got '{self.indirect}'.")
        if min(self.gather_samples_per_edge, self.subtexel_samples_per_edge) < 1 or \
                min(self.dilation_texels, self.seed) < 0:
            raise SettingsError("Lightmap settings: sample counts must be positive, dilation and seed not negative.")


@dataclass
class Lightmap:
    """light: (height, width, 3) float32; covered: (height, width) texels a triangle covers (before dilation);
    moved: (height, width) texels whose sample point was inside closed geometry and was pushed out of it;
    indirect: the method that lit them ("gather" or "interpolate"); seconds: time per phase; groups: each light
    group's own light, like ``light`` (which is then their sum), when the page was baked by groups."""

    light: np.ndarray
    covered: np.ndarray
    moved: np.ndarray
    texel_count: int
    indirect: str
    seconds: dict[str, float] = field(default_factory=dict)
    groups: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class TexelLight:
    """The light of a page's texels (or of one chunk's), irradiance / pi, for G lightings of the scene (1, or its
    light groups): direct (G, m, 3) (with the world's light when it is not gathered), indirect (G, m, 3), the
    (m, 3) variance of the mean of the gathered indirect light, summed over the lightings, and the (m,) share of
    the gather's rays that land within CLOSE_TEXELS texels (the denoiser's guide; both 0 where the indirect light
    is interpolated)."""

    direct: np.ndarray
    indirect: np.ndarray
    indirect_variance: np.ndarray
    close_share: np.ndarray

    @classmethod
    def zeros(cls, texel_count: int, lightings: int = 1) -> TexelLight:
        return cls(*np.zeros((2, lightings, texel_count, 3)), np.zeros((texel_count, 3)), np.zeros(texel_count))

    def put(self, texels: slice, part: TexelLight) -> None:
        """Store a chunk's light at its texels."""
        self.direct[:, texels], self.indirect[:, texels] = part.direct, part.indirect
        self.indirect_variance[texels], self.close_share[texels] = part.indirect_variance, part.close_share


@dataclass
class TexelPlan:
    """The texels of one lightmap page and where their light is sampled, split into chunks that are lit
    independently (``light_chunk``): with a saved solution (core.solution_file), each chunk can run as its own
    task, in any order or process, and ``finish_lightmap`` puts the chunks' light together into the same image.

    pixel: (m,) flat index of each texel in the (height, width) page; tri, barycentric: its scene triangle and
    the barycentrics of its point; points, normals: (m, 3) the point (pushed out of closed geometry where it was
    inside) and its face's unit normal; texel_m: (m,) a texel's edge length on its triangle; sub_points,
    sub_bary: (m, q, 3) points over its footprint; steps: (m, 2, 3) its ``core.texels.footprint_steps``, for
    finer points over the footprint; moved: (m,) pushed out; dark: (m, q) footprint points no light reaches (on
    another face in the same plane, under a face nearer than the ray offset, or buried in closed geometry: the part
    of a rail's texel that reaches into a column), left out of the texel's means;
    contact: (m,) the share of its footprint they cover (of its points in its triangle; for a texel pushed out, the
    share of its footprint inside closed geometry), or all of it where its point is buried deeper in closed
    geometry than it can be pushed out (core.surface_probes.push_out_of_geometry);
    settings: with the indirect method chosen; texels_per_chunk: the chunks' size (the rays of a chunk are seeded
    from its first texel); seams: (k, 2) and (k, 2) points along the page's UV seams as drawn on either side, in
    texels (core.seams.seam_points), where the finished page is stitched."""

    width: int
    height: int
    pixel: np.ndarray
    tri: np.ndarray
    barycentric: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    texel_m: np.ndarray
    sub_points: np.ndarray
    sub_bary: np.ndarray
    steps: np.ndarray
    moved: np.ndarray
    dark: np.ndarray
    contact: np.ndarray
    settings: LightmapSettings
    texels_per_chunk: int
    seams: tuple[np.ndarray, np.ndarray]

    @property
    def texel_count(self) -> int:
        return len(self.pixel)

    @property
    def chunk_count(self) -> int:
        return -(-self.texel_count // self.texels_per_chunk)

    def chunk(self, index: int) -> slice:
        """The texels of chunk ``index``."""
        if not 0 <= index < self.chunk_count:
            raise SettingsError(f"Lightmap chunk {index} does not exist: the page has {self.chunk_count} chunks.")
        start = index * self.texels_per_chunk
        return slice(start, min(start + self.texels_per_chunk, self.texel_count))


def bake_lightmap(solution, scene_triangle: np.ndarray, corner_uv: np.ndarray, width: int, height: int,
                  settings: LightmapSettings = LightmapSettings(), progress: Progress = no_progress,
                  cancelled=never_cancelled, groups: dict | None = None) -> Lightmap:
    """Light the texels of one atlas image: ``scene_triangle`` (t,) are the solved scene triangles it holds and
    ``corner_uv`` (t, 3, 2) their UVs in [0, 1]: ``plan_texels``, then ``light_texels``."""
    timer = Timer()
    plan = plan_texels(solution, scene_triangle, corner_uv, width, height, settings)
    timer.lap("texels")
    return light_texels(solution, plan, progress, cancelled, groups, timer.laps)


def light_texels(solution, plan: TexelPlan, progress: Progress = no_progress, cancelled=never_cancelled,
                 groups: dict | None = None, seconds: dict | None = None) -> Lightmap:
    """The page of a plan: ``light_chunk`` per chunk, chunks side by side (core.parallel), then
    ``finish_lightmap``. A plan made before the solve (``sample_texels``) takes its indirect method from the
    solution here. With ``groups`` (light group -> its Solution, core.bake.bake_light_groups), the texels planned
    once are lit by each group's solution in turn: the page's ``groups`` hold each group's light and its
    ``light`` their sum. ``seconds``: the phases timed before (the plan's), reported with the page's."""
    plan = with_indirect_method(plan, solution)
    timer = Timer()
    timer.laps.update(seconds or {})
    light, chunk_seconds = TexelLight.zeros(plan.texel_count, len(groups or [None])), {}

    def lit(index: int) -> tuple[TexelLight, dict]:
        chunk_timer = Timer()
        return light_chunk(solution, plan, index, chunk_timer, groups), chunk_timer.laps

    # The first chunk alone builds the tables the solution computes on first use; the others then share them.
    chunks = range(plan.chunk_count)
    lights = chain(map(lit, chunks[:1]), ordered_map(lit, chunks[1:], steps_in_flight(solution.caster.threads)))
    for index, (part, laps) in zip(chunks, lights):
        if cancelled():
            raise BakeCancelled("Bake cancelled while lighting the lightmap.")
        chunk = plan.chunk(index)
        light.put(chunk, part)
        for phase, lap in laps.items():
            chunk_seconds[phase] = chunk_seconds.get(phase, 0.0) + lap
        progress(chunk.stop / plan.texel_count, f"Lightmap: {chunk.stop} of {plan.texel_count} texels lit")
    timer.share(chunk_seconds)
    return finish_lightmap(solution, plan, light, timer.laps, groups)


def plan_texels(solution, scene_triangle: np.ndarray, corner_uv: np.ndarray, width: int, height: int,
                settings: LightmapSettings = LightmapSettings()) -> TexelPlan:
    """The texels of one page (``bake_lightmap``'s arguments), their sample points and the indirect method."""
    plan = sample_texels(solution.scene, solution.caster, solution.offset_m, scene_triangle, corner_uv, width,
                         height, settings)
    return with_indirect_method(plan, solution)


def sample_texels(scene, caster, offset_m: float, scene_triangle: np.ndarray, corner_uv: np.ndarray, width: int,
                  height: int, settings: LightmapSettings = LightmapSettings()) -> TexelPlan:
    """``plan_texels`` from the scene alone, its ray-casting scene and ray offset (core.bake.ray_offset_m), so
    that it can run before or during the solve: the indirect method is left as ``settings`` have it. The probes
    of the texels' footprints run PLAN_TEXELS_PER_CHUNK texels at a time, so that their rays' memory does not
    grow with the page."""
    texels = rasterize(np.asarray(corner_uv, dtype=np.float64), width, height)
    tri = np.asarray(scene_triangle, dtype=np.int64)[texels.triangle]
    points, normals = sample_points(scene.triangles[np.asarray(scene_triangle, dtype=np.int64)], texels,
                                    4 * offset_m)
    reach = texel_size_m(scene.triangles[tri], corner_uv[texels.triangle], width, height)
    steps = footprint_steps(texels, corner_uv)
    probe = _FootprintProbe(scene.triangles, caster, offset_m, settings.subtexel_samples_per_edge)
    parts = [probe(tri[rows], texels.barycentric[rows], steps[rows], points[rows], normals[rows], reach[rows])
             for rows in even_ranges(len(tri), PLAN_TEXELS_PER_CHUNK) or [slice(0, 0)]]  # a page of no texel too
    points, moved, buried, sub_points, sub_bary, dark, weight, moved_inside = (
        np.concatenate(part) for part in zip(*parts))
    dark |= _on_another_face(other_face_test(scene.triangles, 4 * offset_m), tri, points, sub_points, texels.pixel,
                             width, height)
    contact = (dark * weight).sum(axis=1) / weight.sum(axis=1)
    contact[moved] = moved_inside[moved]
    contact[buried] = 1.0  # no light gets there: Cycles bakes the inside of the geometry
    page = np.asarray(scene_triangle, dtype=np.int64)
    seams = seam_points(scene.triangles[page], scene.corner_normals[page],
                        np.asarray(corner_uv, dtype=np.float64) * [width, height])
    return TexelPlan(width, height, texels.pixel, tri, texels.barycentric, points, normals, reach, sub_points,
                     sub_bary, steps, moved, dark, contact, settings, TEXELS_PER_CHUNK, seams)


@dataclass(frozen=True)
class _FootprintProbe:
    """The ray probes of a run of texels' footprints (each texel's alone: a page's is the concatenation of its
    runs'). Called with (m,) scene triangles, (m, 3) barycentrics, (m, 2, 3) footprint steps, (m, 3) points and
    normals and (m,) reaches, it returns the points pushed out of closed geometry, which moved and which are
    buried (core.surface_probes.push_out_of_geometry), the (m, q, 3) footprint points and barycentrics, (m, q)
    which are dark (under a face nearer than the ray offset, or buried in closed geometry), (m, q) the weights
    of the points where Cycles' samples land, and (m,) for a moved texel the share of its footprint inside
    closed geometry (``_share_inside``; 0 for the others)."""

    scene_triangles_m: np.ndarray
    caster: RayCaster
    offset_m: float
    samples_per_edge: int

    def __call__(self, tri, barycentric, steps, points, normals, reach):
        triangles, offset = self.scene_triangles_m, self.offset_m
        on_surface = points
        points, moved, buried = push_out_of_geometry(self.caster, triangles, points, normals, reach, offset)
        sub_points, sub_bary = _footprint_points(triangles[tri], barycentric, steps, self.samples_per_edge, points,
                                                 moved, 4 * offset)
        m, q = sub_points.shape[:2]
        flat_points, flat_normals = sub_points.reshape(-1, 3), np.repeat(normals, q, axis=0)
        dark = covered_within(self.caster, flat_points, flat_normals, offset).reshape(m, q)
        dark |= buried_in_geometry(self.caster, triangles, flat_points, flat_normals, np.repeat(reach, q),
                                   offset).reshape(m, q)
        in_triangle = footprint_inside(barycentric, steps, self.samples_per_edge)
        weight = np.where(in_triangle.any(axis=1)[:, None], in_triangle, True)  # where Cycles' samples land
        moved_inside = np.zeros(m)
        moved_inside[moved] = _share_inside(self.caster, triangles, tri, barycentric, steps, on_surface, normals,
                                            moved, weight, self.samples_per_edge, offset)
        return points, moved, buried, sub_points, sub_bary, dark, weight, moved_inside


def _share_inside(caster, scene_triangles_m, tri, barycentric, steps, points, normals, moved, weight,
                  samples_per_edge: int, offset_m: float) -> np.ndarray:
    """(moved,) the share of each moved texel's footprint (its k x k points where they were, before its point was
    pushed out, weighted by ``weight``) that lies inside closed geometry (core.surface_probes): where Cycles'
    samples see the inside of the geometry and bring no light. A texel wholly under a cover, pushed out to a
    point beside it, then takes none of that point's light; one half out takes half."""
    rows = np.flatnonzero(moved)
    stay = np.zeros(len(rows), dtype=bool)
    original, _ = _footprint_points(scene_triangles_m[tri[rows]], barycentric[rows], steps[rows], samples_per_edge,
                                    points[rows], stay, 4 * offset_m)
    q = original.shape[1]
    inside = inside_closed_geometry(caster, scene_triangles_m, original.reshape(-1, 3),
                                    np.repeat(normals[rows], q, axis=0), offset_m).reshape(-1, q)
    return (inside * weight[rows]).sum(axis=1) / weight[rows].sum(axis=1)


def with_indirect_method(plan: TexelPlan, solution) -> TexelPlan:
    """The plan with the automatic indirect method settled for the solution: a final gather where it pays
    (core.gather.gather_pays), else interpolation."""
    if plan.settings.indirect != "auto":
        return plan
    method = "gather" if gather_pays(solution) else "interpolate"
    return replace(plan, settings=replace(plan.settings, indirect=method))


def light_chunk(solution, plan: TexelPlan, index: int, timer: Timer | None = None,
                groups: dict | None = None) -> TexelLight:
    """The direct and indirect light of the c texels of chunk ``index``: depends on the solution, the plan and the
    index only (the shadow and gather rays are seeded from the chunk's first texel, so no two chunks repeat each
    other's samples). Light arrives by the shading normal (smooth shading, as Cycles bakes); the faces' own normals
    find buried points and the receivers to interpolate from. A gather ray that lands within NEAR_ELEMENTS element
    sizes gathers again there (core.gather). With ``groups`` (light group -> its Solution), the light of each
    group, the gather's rays shared."""
    chunk, settings, timer = plan.chunk(index), plan.settings, timer or Timer()
    points, sub_points, sub_bary = plan.points[chunk], plan.sub_points[chunk], plan.sub_bary[chunk]
    normals, tri, barycentric = plan.normals[chunk], plan.tri[chunk], plan.barycentric[chunk]
    scene = solution.scene
    c, q = sub_points.shape[:2]
    shading = scene.shading_normals(np.repeat(tri, q), sub_bary.reshape(-1, 3)).reshape(c, q, 3)
    gather = settings.indirect == "gather"  # its rays bring the world's light
    lightings = list(groups.values()) if groups else [solution]
    in_triangle = footprint_inside(barycentric, plan.steps[chunk], settings.subtexel_samples_per_edge)
    reached = _reached(in_triangle, plan.dark[chunk])  # a texel wholly dark keeps its points: its light is zeroed
    direct = _direct_light(lightings, plan, chunk, shading, reached, world=not gather)
    timer.lap("direct")
    if gather:
        indirect, variance, close_share = _gathered(solution, lightings, plan, chunk, np.arange(c), world=True)
    else:
        buried = _inside(solution, points, normals, sub_points)
        indirect = np.stack([_footprint_mean(scene, np.where(buried[..., None], 0.0, lit.indirect_light(
            points, normals, tri, barycentric)[:, None, :]), tri, sub_bary, reached) for lit in lightings])
        variance, close_share = np.zeros_like(indirect[0]), np.zeros(c)
        near = _under_near_surface(solution, points, normals)
        if len(near):  # their direct light has the world's
            indirect[:, near], variance[near], close_share[near] = _gathered(solution, lightings, plan, chunk, near,
                                                                             world=False)
    timer.lap("indirect")
    return TexelLight(direct, indirect, variance, close_share)


def finish_lightmap(solution, plan: TexelPlan, light: TexelLight, seconds: dict | None = None,
                    groups: dict | None = None) -> Lightmap:
    """The page from its texels' light (all chunks): the gathered light denoised, contacts dark, then dilated
    into the padding. With ``groups`` (the light groups ``light`` holds, in order), each group's page too, the
    page being their sum (the denoiser's weights are the sum's, so that the groups sum to it)."""
    indirect = light.indirect
    if plan.settings.denoise and light.indirect_variance.any():  # some texels were gathered
        indirect = denoise_gathered(plan.pixel, plan.width, plan.height, plan.points, plan.normals, plan.texel_m,
                                    indirect.sum(axis=0), light.indirect_variance, parts=indirect,
                                    guide=(light.close_share, plan.settings.gather_samples_per_edge ** 2))
    height, width = plan.height, plan.width
    covered = np.zeros(height * width, dtype=bool)
    covered[plan.pixel] = True
    covered = covered.reshape(height, width)
    pages = [_page(solution, plan, direct + part, covered) for direct, part in zip(light.direct, indirect)]
    moved_texels = np.zeros(height * width, dtype=bool)
    moved_texels[plan.pixel[plan.moved]] = True
    return Lightmap(sum(pages), covered, moved_texels.reshape(height, width), plan.texel_count,
                    plan.settings.indirect, dict(seconds or {}), dict(zip(groups, pages)) if groups else {})


def _page(solution, plan: TexelPlan, light: np.ndarray, covered: np.ndarray) -> np.ndarray:
    """(height, width, 3) float32 image of the texels' (m, 3) light as outputs store it, the share of each where
    no light arrives (``plan.contact``) dark, dilated into the padding, its seams stitched (core.seams)."""
    light = solution.output_light(light, plan.tri)
    # On another face, buried, or (for texels pushed out) inside closed geometry, no light gets there.
    light *= 1.0 - plan.contact[:, None]
    image = np.zeros((plan.height * plan.width, 3))
    image[plan.pixel] = np.nan_to_num(light)
    image, _ = dilate(image.reshape(plan.height, plan.width, 3), covered, plan.settings.dilation_texels)
    return stitch_seams(image, covered, *plan.seams).astype(np.float32)


def _gathered(solution, lightings: list, plan: TexelPlan, chunk: slice, rows: np.ndarray,
              world: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """core.gather.final_gather_parts at the chunk's texels ``rows``: (g, r, 3) each lighting's indirect light
    (with the world's if ``world``), (r, 3) its variance and (r,) the share of rays that land within CLOSE_TEXELS.
    A ray landing within NEAR_ELEMENTS element sizes gathers again there; the rays are seeded from the chunk's
    first texel."""
    settings, seed = plan.settings, plan.settings.seed + chunk.start
    tri, barycentric = plan.tri[chunk][rows], plan.barycentric[chunk][rows]
    return final_gather_parts(
        lightings, solution.caster, _gather_points(solution, plan, chunk, seed)[rows],
        solution.scene.shading_normals(tri, barycentric), settings.gather_samples_per_edge, solution.offset_m, seed,
        face_normals=plan.normals[chunk][rows], near_m=NEAR_ELEMENTS * solution.element_size_m,
        near_samples_per_edge=NEAR_SAMPLES_PER_EDGE, close_m=CLOSE_TEXELS * plan.texel_m[chunk][rows], world=world)


def _under_near_surface(solution, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Indices of the (m, 3) texel points with unit face ``normals`` that face a surface nearer than
    GATHER_UNDER_ELEMENTS element sizes along the normal: a wall behind a moulding 1 cm proud, a gap between
    cushions. The elements there are larger than the gap, so the irradiance interpolated between them is the open
    surface's beside it; interpolating lightmaps gather these texels instead."""
    distance = distance_in_front(solution.caster, points, normals, solution.offset_m)
    return np.flatnonzero(distance < GATHER_UNDER_ELEMENTS * solution.element_size_m)


def _inside(solution, points, normals, sub_points) -> np.ndarray:
    """(m, q) sub-texel points inside closed geometry, where interpolated indirect light is 0 (the part of a
    texel that reaches under a box standing on the floor, where Cycles' samples see the inside of the box)."""
    m, q = sub_points.shape[:2]
    return inside_closed_geometry(solution.caster, solution.scene.triangles, sub_points.reshape(-1, 3),
                                  np.repeat(normals, q, axis=0), solution.offset_m).reshape(m, q)


def _gather_points(solution, plan: TexelPlan, chunk: slice, seed: int) -> np.ndarray:
    """(c, s^2, 3) a point of each texel's footprint per gather ray, as Cycles' samples each take their own: an
    s x s grid over the footprint (s the gather's rays per edge; ``_footprint_points``), each point dark where its
    cell of the k x k grid is (``plan.dark``), in a seeded order per texel (so that a point's place on the texel
    and its ray's direction are unrelated), those outside the triangle or dark replaced by the others in turn.
    Rays taking the k x k points in turn let a strip a few centimetres wide, that one column of k points falls
    in, stand for 1/k of the texel (a narrow gap beside a face in front of the texel, open to bright light).
    Where fewer than s of the grid's points are reached (a sliver triangle across the texel, one point of it often
    below a floor or inside the next arch), the points come from a grid SLIVER_GRID times finer, spread over the
    sliver as Cycles' samples are (it draws each again until it falls in the triangle)."""
    s = plan.settings.gather_samples_per_edge
    barycentric, steps, moved, dark = plan.barycentric[chunk], plan.steps[chunk], plan.moved[chunk], plan.dark[chunk]
    triangles = solution.scene.triangles[plan.tri[chunk]]
    inset_m = 4 * solution.offset_m
    rng = np.random.default_rng([seed, GATHER_ORDER_STREAM])
    points, _ = _footprint_points(triangles, barycentric, steps, s, plan.points[chunk], moved, inset_m)
    reached = _reached(footprint_inside(barycentric, steps, s), dark)
    points = _in_random_turn(points, reached, rng)
    sliver = np.flatnonzero((reached.sum(axis=1) < s) & ~moved)
    unfolded = footprint_unfolded(barycentric[sliver], steps[sliver], s * SLIVER_GRID)
    inside = (unfolded >= 0.0).all(axis=-1)
    finer = _in_random_turn(unfolded, _reached(inside, dark[sliver]), rng)[:, :s * s]
    found = inside.any(axis=1)
    corners = triangles[sliver[found]]
    points[sliver[found]] = inset(np.einsum("mqc,mck->mqk", finer[found], corners), corners.mean(axis=1)[:, None, :],
                                  inset_m)
    return points


def _reached(inside: np.ndarray, dark: np.ndarray) -> np.ndarray:
    """(m, n^2) the points of an n x n footprint grid (``inside`` their triangle) that Cycles' samples reach and
    see light at: those whose cell of the k x k grid is not ``dark`` (m, k^2); all those inside where none is."""
    n, k = int(round(np.sqrt(inside.shape[1]))), int(round(np.sqrt(dark.shape[1])))
    column, row = np.divmod(np.arange(n * n), n)
    reached = inside & ~dark[:, (column * k // n) * k + row * k // n]
    return np.where(reached.any(axis=1)[:, None], reached, inside)


def _in_random_turn(values: np.ndarray, reached: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``_in_turn`` of (m, q, d) ``values`` in a random order per texel."""
    order = np.argsort(rng.random(reached.shape), axis=1)
    return _in_turn(np.take_along_axis(values, order[..., None], axis=1), np.take_along_axis(reached, order, axis=1))


def _in_turn(sub_points: np.ndarray, reached: np.ndarray) -> np.ndarray:
    """(m, q, 3) each texel's footprint points with those not ``reached`` ((m, q) False: outside its triangle, or
    dark) replaced by the others, in turn: the gather's rays start only where Cycles' samples land and see light."""
    m, q = reached.shape
    inside_first = np.argsort(~reached, axis=1, kind="stable")
    count = np.maximum(reached.sum(axis=1), 1)
    slot = inside_first[np.arange(m)[:, None], np.arange(q) % count[:, None]]
    return sub_points[np.arange(m)[:, None], slot]


def _footprint_mean(scene, light: np.ndarray, tri: np.ndarray, sub_bary: np.ndarray,
                    point_weight: np.ndarray) -> np.ndarray:
    """(..., m, 3) reflectance-weighted mean of (..., m, q, 3) light over each texel's sub-points, each also
    weighted by its (m, q) ``point_weight``: the share of it inside the texel's triangle
    (core.texels.footprint_inside). Cycles' Diffuse bake without Color divides the diffuse light x colour its
    samples gathered by the colour they gathered, so where a texture's edge meets a shadow's edge inside one
    texel, the brighter-coloured side counts more; multiplied by the texture again, the texel then keeps its mean
    exitance."""
    m, q = light.shape[-3:-1]
    reflectance = scene.reflectance_at(np.repeat(tri, q), sub_bary.reshape(-1, 3)).reshape(m, q, 3)
    weight = reflectance * point_weight[..., None]
    total = weight.sum(axis=-2)
    weighted = (weight * light).sum(axis=-2) / np.where(total > 0, total, 1.0)
    return np.where(total > 0, weighted, light.mean(axis=-2))


def _on_another_face(on_another_face, tri, points, sub_points, pixel, width, height) -> np.ndarray:
    """(m, q) which of the texels' (m, q, 3) footprint points lie on another face in the same plane
    (core.surface_probes.other_face_test's ``on_another_face``), where no light arrives: tested for texels whose
    point, or a point of a texel next to it in the (height, width) page, lies on one; elsewhere none (an overlap
    that holds no texel's point is left out)."""
    centre = on_another_face(tri, points)
    page = np.zeros(height * width, dtype=bool)
    page[pixel[centre]] = True
    page = np.pad(page.reshape(height, width), 1)
    near = np.zeros((height, width), dtype=bool)
    for row, column in np.ndindex(3, 3):
        near |= page[row:row + height, column:column + width]
    near = np.flatnonzero(near.ravel()[pixel])
    q = sub_points.shape[1]
    covered = np.zeros(sub_points.shape[:2], dtype=bool)
    covered[near] = on_another_face(np.repeat(tri[near], q), sub_points[near].reshape(-1, 3)).reshape(-1, q)
    return covered


def _footprint_points(triangles_m, barycentric, steps, samples_per_edge, points, moved,
                      inset_m) -> tuple[np.ndarray, np.ndarray]:
    """(m, k^2, 3) points over each texel's footprint (core.texels.footprint_barycentrics, inset from the
    triangle's edges) and their barycentrics; texels pushed out of geometry or only partly covered keep their
    one point."""
    bary = footprint_barycentrics(barycentric, steps, samples_per_edge)
    sub_points = inset(np.einsum("mqc,mck->mqk", bary, triangles_m), triangles_m.mean(axis=1)[:, None, :], inset_m)
    keep = moved | ~steps.any(axis=(1, 2))
    sub_points[keep] = points[keep, None, :]
    return sub_points, bary


def _direct_light(lightings: list, plan: TexelPlan, chunk: slice, shading: np.ndarray,
                  reached: np.ndarray, world: bool) -> np.ndarray:
    """(g, m, 3) direct light of each lighting (the solution, or one per light group) on the chunk's texels: the
    mean (``_footprint_mean``) over their q footprint points with (m, q, 3) unit shading normals, of those in their
    triangle where light reaches them (``reached``). With 1/k the shadow rays per edge at each (rounded up); the
    world's only if ``world``. Where the points of a texel see one source of light (``_light_sources``) spread
    over more than PENUMBRA_SPREAD of the brightest point's light, the texel is lit again by that source from
    p x p points spread over each point's cell of the footprint (p = PENUMBRA_SAMPLES_PER_EDGE, or
    SHARP_EDGE_SAMPLES_PER_EDGE for a source of small lights), new rays in place of the first (an estimate
    independent of the test that chose the texel, so the choice adds no bias): a penumbra is where a few rays per
    point are noisiest, and where a sharp shadow's edge crosses the texel, a few fixed points measure its covered
    share only to 1/k. Each finer point takes 1/p of a point's shadow rays per edge (rounded up). Small lights'
    edges are lit again at every quality (more rays per point do not measure the share a sharp edge covers);
    other sources' only where a point takes fewer than PENUMBRA_SAMPLES_PER_EDGE rays per edge (more resolve a
    penumbra). Only the source whose shadow's edge it is: the sun's shadows cost the lamps no more rays.
    The edges are found on the lightings' sum, so that light groups sum to the ordinary bake."""
    k = plan.settings.subtexel_samples_per_edge
    tri, barycentric, sub_bary = plan.tri[chunk], plan.barycentric[chunk], plan.sub_bary[chunk]
    light_samples = -(-lightings[0].direct.samples_per_edge // k)
    scene = lightings[0].scene

    def lit(points, normals, texels, seed_offset, sources, samples):  # (g, sources, texels, points/texel, 3)
        per_texel = points.shape[1]
        return np.stack([solution.direct_light(
            points.reshape(-1, 3), normals.reshape(-1, 3), np.repeat(tri[texels], per_texel),
            np.repeat(barycentric[texels], per_texel, axis=0), samples, seed_offset=seed_offset,
            world=world, sources=sources).reshape(len(sources), len(points), per_texel, 3)
            for solution in lightings])

    sources = _light_sources(len(scene.lights))
    light = lit(plan.sub_points[chunk], shading, slice(None), k * k * chunk.start, sources, light_samples)
    texel_light = _footprint_mean(scene, light, tri, sub_bary, reached.astype(np.float64))
    small = [_small_lights(scene, *source) for source in sources]
    again = [index for index in range(len(sources)) if small[index] or light_samples < PENUMBRA_SAMPLES_PER_EDGE]
    if not again:
        return texel_light.sum(axis=1)
    brightness = np.nan_to_num(light).sum(axis=(0, 4))                                  # (sources, m, q)
    brightest = brightness.sum(axis=0).max(axis=1)
    neighbours = _surface_neighbours(plan, chunk)  # the same for every source
    for index in again:
        edge = _shadow_edge_texels(neighbours, brightness[index], brightest)
        if len(edge) == 0:
            continue
        source, split = sources[index], SHARP_EDGE_SAMPLES_PER_EDGE if small[index] else PENUMBRA_SAMPLES_PER_EDGE
        points, normals = _finer_footprint_points(lightings[0], plan, chunk, edge, shading, split)
        # Seeds past every texel's first pass (k^2 texel_count), so no ray repeats another's.
        finer = lit(points, normals, edge, k * k * plan.texel_count + points.shape[1] * chunk.start, [source],
                    -(-light_samples // split))
        cells = finer.reshape(len(lightings), len(edge), k * k, split * split, 3)
        finer_in = footprint_inside(barycentric[edge], plan.steps[chunk][edge], k * split)[:, subcell_order(k, split)]
        counted = np.where(finer_in.any(axis=2, keepdims=True), finer_in, True)[None, ..., None]
        cell_light = (cells * counted).sum(axis=3) / counted.sum(axis=3)  # a cell wholly outside weighs 0
        texel_light[:, index, edge] = _footprint_mean(scene, cell_light, tri[edge], sub_bary[edge],
                                                      finer_in.mean(axis=2) * ~plan.dark[chunk][edge])
    return texel_light.sum(axis=1)


def _light_sources(light_count: int) -> list[tuple[np.ndarray, bool]]:
    """The sources whose shadows' edges ``_direct_light`` finds apart: the scene's lights in at most
    LIGHT_SOURCES - 1 runs of consecutive lights (each its own for a few), as (indices, False), then the world
    and the emissive surfaces, as (no lights, True)."""
    runs = np.array_split(np.arange(light_count), min(light_count, LIGHT_SOURCES - 1)) if light_count else []
    return [(run, False) for run in runs] + [(np.zeros(0, dtype=np.int64), True)]


def _small_lights(scene, lights: np.ndarray, rest: bool) -> bool:
    """Whether a source of ``_light_sources`` is suns, points and spots only: small lights, whose shadows' edges
    are sharp at a texel's scale wherever the occluder is near (an area light's or a glowing panel's penumbrae
    spread over many texels, where more points only cost time)."""
    return not rest and all(isinstance(scene.lights[index], (SunLight, PointLight, SpotLight)) for index in lights)


def _surface_neighbours(plan: TexelPlan, chunk: slice) -> list[tuple[np.ndarray, np.ndarray]]:
    """(texels, their neighbours) indices into the chunk: each texel and the one to its right, and each and the one
    above, where both lie in the chunk on the same surface (normals within SAME_SURFACE_COSINE, within two
    texels)."""
    pixel, points, normals = plan.pixel[chunk], plan.points[chunk], plan.normals[chunk]
    pairs = []
    for step in (1, plan.width):  # the neighbour to the right and the one above
        found = np.minimum(np.searchsorted(pixel, pixel + step), len(pixel) - 1)
        neighbour = (pixel[found] == pixel + step) & ((step != 1) | (pixel % plan.width != plan.width - 1))
        same_surface = neighbour & (np.einsum("mk,mk->m", normals, normals[found]) > SAME_SURFACE_COSINE) & (
            lengths(points - points[found]) < 2 * plan.texel_m[chunk])
        texel = np.flatnonzero(same_surface)
        pairs.append((texel, found[texel]))
    return pairs


def _shadow_edge_texels(neighbours: list, brightness: np.ndarray, brightest: np.ndarray) -> np.ndarray:
    """Indices into the chunk of its texels on a shadow's edge, from the (c, q) brightness of their footprint
    points in one source's light and the (c,) brightest point's in all: the points' brightness spreads over more
    than PENUMBRA_SPREAD of the brightest, or the texel's mean differs by that much from a neighbouring texel's on
    the same surface (``_surface_neighbours``: an edge that passes between a texel's outer points and its border
    leaves its points agreeing)."""
    mean = brightness.mean(axis=1)
    edge = np.ptp(brightness, axis=1) > PENUMBRA_SPREAD * brightest
    for texel, found in neighbours:
        differ = np.abs(mean[texel] - mean[found]) > PENUMBRA_SPREAD * np.maximum(brightest[texel], brightest[found])
        edge[texel[differ]] = True
        edge[found[differ]] = True
    return np.flatnonzero(edge)


def _finer_footprint_points(solution, plan: TexelPlan, chunk: slice, edge: np.ndarray, shading: np.ndarray,
                            split: int) -> tuple[np.ndarray, np.ndarray]:
    """(e, q p^2, 3) points over the footprints of the chunk's ``edge`` texels, p x p (``split``) over each cell
    of their k x k grid, cell by cell (the p^2 of the first cell first), and their unit shading normals (each
    cell's)."""
    k = plan.settings.subtexel_samples_per_edge
    texels = np.arange(chunk.start, chunk.stop)[edge]
    points, _ = _footprint_points(solution.scene.triangles[plan.tri[texels]], plan.barycentric[texels],
                                  plan.steps[texels], k * split, plan.points[texels], plan.moved[texels],
                                  4 * solution.offset_m)
    return points[:, subcell_order(k, split).ravel()], np.repeat(shading[edge], split * split, axis=1)


def texel_size_m(triangles_m: np.ndarray, corner_uv: np.ndarray, width: int, height: int) -> np.ndarray:
    """(m,) edge length in metres of one texel on each triangle (world area per texel area, square-rooted)."""
    texel_corners = np.concatenate([corner_uv * [width, height], np.zeros(corner_uv.shape[:2] + (1,))], axis=2)
    texel_area = np.maximum(triangle_areas(texel_corners), 1e-12)
    return np.sqrt(triangle_areas(triangles_m) / texel_area)


def dilate(image: np.ndarray, filled: np.ndarray, passes: int) -> tuple[np.ndarray, np.ndarray]:
    """Grow values into empty texels: each pass gives every empty texel with filled 8-neighbours their mean."""
    image, filled = image.copy(), filled.copy()
    height, width = filled.shape
    for _ in range(passes):
        padded = np.pad(image * filled[..., None], ((1, 1), (1, 1), (0, 0)))
        weight = np.pad(filled.astype(np.float64), 1)
        total = np.zeros_like(image)
        count = np.zeros(filled.shape)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):  # nine shifted views of the whole image, not a loop over texels
                total += padded[1 + dy:1 + dy + height, 1 + dx:1 + dx + width]
                count += weight[1 + dy:1 + dy + height, 1 + dx:1 + dx + width]
        grow = ~filled & (count > 0)
        if not grow.any():
            break
        image[grow] = total[grow] / count[grow, None]
        filled |= grow
    return image, filled
