"""The pipeline: Scene -> elements -> direct light -> radiosity solve -> Solution.

``bake(scene, settings, progress, cancelled)`` is the one entry point the add-on, the command line and the tests
call. Everything is deterministic for a given scene, settings and seed. Two families of solvers:

- "hierarchical" (default, any scene size): face-cluster elements independent of the triangle count, two-sided,
  made finer where shadows cross them if asked (core.adaptive_elements), linked hierarchically to a cluster tree
  (core.clusters, core.cluster_tree, core.links, core.hierarchical);
- "progressive" and "direct" (the classic methods, for small scenes): every receiving triangle is cut into
  patches and elements (core.mesh), with ray-cast or hemicube form-factor rows, adaptive meshing and near-field
  links (core.formfactor_rows, core.solver, core.adaptive, core.nearfield).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, fields, replace

import numpy as np

from . import adaptive
from .adaptive_elements import adaptive_elements
from .cluster_tree import build_tree
from .clusters import emitted_exitance
from .direct_light import DirectLighting
from .errors import SettingsError
from .hierarchical import (HierarchicalState, live_side_test, node_deviation, node_radiosity, side_direct_irradiance,
                           side_mean, solve)
from .analytic_lights import direct_irradiance
from .links import OPENING, LinkSources, build_links, covered_share, refine_links
from .memory import check_bake_memory, default_limit_gb
from .mesh import build_mesh, bury, elements_of
from .nearfield import near_field_irradiance
from .progress import Progress, Timer, never_cancelled, no_progress
from .raycast import RayCaster, first_use_message
from .scene import MAX_REFLECTANCE, Scene
from .formfactor_rows import HemicubeRows, Patches, RayCastRows
from .gather import gather_at_receivers, gather_pays
from .parallel import steps_in_flight
from .solution import FRONT, SolvedElements, Solution
from .solver import FormFactorCache, RadiosityState, patch_mean, solve_direct, solve_progressive

RAY_OFFSET_FRACTION = 2e-5
RECEIVER_GATHER_SAMPLES_PER_EDGE = 12  # s, so s^2 rays per element side in gather_at_receivers
RECEIVER_GATHER_STREAM = 1 << 32  # added to the seed: rays apart from the lightmap's, whose seeds count texels
REFINEMENT_TOLERANCE = 0.03  # a link is refined where its error bound exceeds 3% of the receiver's irradiance
ROUGH_RESIDUAL = 0.05  # the solve before link refinement stops here (or at the residual threshold if looser)
SOLVERS = ("hierarchical", "progressive", "direct")


@dataclass(frozen=True)
class BakeSettings:
    """Settings of a bake; lengths in metres. The defaults suit a scene of a few metres, for tests and scripts;
    the add-on always passes its own, scaled to the scene (radiosity_addon/presets.py).

    element_size_m: target edge length of receiving elements.
    patch_size_m: of the classic solvers' shooting patches, and of the pieces emissive surfaces are sampled by.
    solver: "hierarchical" (default), "progressive" or "direct" (Gaussian elimination, small scenes).
    form_factors: "raycast" (analytic x shadow rays, default) or "hemicube" (classic solvers only).
    opening: a cluster is linked as a whole when its half diagonal is below this share of its distance
        (hierarchical solver; smaller is more accurate and slower).
    visibility_samples_per_edge: s, so s^2 shadow rays per link to a one-piece element or per element-patch pair.
    hemicube_resolution: pixels across the hemicube's top face.
    light_samples_per_edge: s, so s^2 shadow rays per element and soft light (area, sized point, sun angle, world).
    residual_threshold: stop when the unshot (or still changing) power falls below this share of the injected.
    max_shots: the most shots (progressive) or iterations (hierarchical).
    adaptive_passes, adaptive_threshold, min_element_size_m: adaptive meshing (core.adaptive_elements for the
        hierarchical solver, core.adaptive for the classic ones).
    form_factor_memory_mb: memory for the classic element-to-patch form-factor matrix; over it, rows are
        recomputed when needed (memory then stays O(n + P^2)).
    max_memory_gb: the bake is refused (core.memory.MemoryLimitError) before any large allocation when its
        estimate is over this; 0: core.memory.default_limit_gb(), a share of the machine's memory.
    receiver_gather: after the hierarchical solve, where outputs gather their indirect light
        (core.gather.gather_pays), the element sides' indirect light is solved again over rays traced from them
        (core.gather.gather_at_receivers); False: the links' solve as it is.
    """

    patch_size_m: float = 0.5
    element_size_m: float = 0.125
    form_factors: str = "raycast"
    solver: str = "hierarchical"
    opening: float = OPENING
    visibility_samples_per_edge: int = 2
    hemicube_resolution: int = 128
    light_samples_per_edge: int = 4
    residual_threshold: float = 0.01
    max_shots: int = 1_000_000
    adaptive_passes: int = 0
    adaptive_threshold: float = 0.2
    min_element_size_m: float = 0.01
    form_factor_memory_mb: float = 2048.0
    seed: int = 0
    threads: int = 0
    max_memory_gb: float = 0.0
    receiver_gather: bool = False

    def __post_init__(self):
        positive = ("patch_size_m", "element_size_m", "opening", "visibility_samples_per_edge",
                    "hemicube_resolution", "light_samples_per_edge", "residual_threshold", "max_shots",
                    "adaptive_threshold", "min_element_size_m")
        for name in positive:
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise SettingsError(f"Setting '{name}' must be a positive number, got {value}.")
        for name in ("adaptive_passes", "form_factor_memory_mb", "threads", "seed", "max_memory_gb"):
            if getattr(self, name) < 0:
                raise SettingsError(f"Setting '{name}' must not be negative, got {getattr(self, name)}.")
        if self.form_factors not in ("raycast", "hemicube"):
            raise SettingsError(f"Setting 'form_factors' must be 'raycast' or 'hemicube', got '{self.form_factors}'.")
        if self.solver not in SOLVERS:
            raise SettingsError(f"Setting 'solver' must be one of {', '.join(SOLVERS)}, got '{self.solver}'.")
        if self.form_factors == "hemicube" and self.solver == "hierarchical":
            raise SettingsError("Setting 'form_factors' 'hemicube' needs the 'progressive' or 'direct' solver.")
        if self.element_size_m > self.patch_size_m and self.solver != "hierarchical":
            raise SettingsError(f"Setting 'element_size_m' ({self.element_size_m}) must not exceed "
                                f"'patch_size_m' ({self.patch_size_m}).")

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def ray_offset_m(scene: Scene) -> float:
    """How far off a surface the rays that leave it start: RAY_OFFSET_FRACTION of the scene's size."""
    return RAY_OFFSET_FRACTION * scene.size_m


def ray_caster(scene: Scene, settings: BakeSettings, progress: Progress = no_progress) -> RayCaster:
    """The ray-casting scene of ``scene.triangles`` on the settings' threads (saying so first when the backend
    needs time on its first use)."""
    if first_use_message():  # Warp compiles its kernels on a machine's first bake: say so before the wait
        progress(0.0, first_use_message())
    return RayCaster(scene.triangles, settings.threads or None)


def bake(scene: Scene, settings: BakeSettings = BakeSettings(), progress: Progress = no_progress,
         cancelled=never_cancelled, caster: RayCaster | None = None) -> Solution:
    """Solve the scene's diffuse light; raises BakeCancelled if ``cancelled()`` turns True. ``caster``: a
    ray-casting scene of ``scene.triangles`` already built, for a caller that shares it with work of its own
    alongside the solve (lightmap texels planned meanwhile); else the bake builds one."""
    check_bake_memory(scene.triangles[~scene.casts_only], scene.triangles[scene.emissive], settings.element_size_m,
                      settings.patch_size_m, settings.max_memory_gb or default_limit_gb(), settings.threads,
                      settings.adaptive_passes if settings.solver == "hierarchical" else 0)
    timer = Timer()
    offset = ray_offset_m(scene)
    caster = caster or ray_caster(scene, settings, progress)
    solve_scene = _hierarchical if settings.solver == "hierarchical" else _classic
    mesh, elements, state, ambient, counts = solve_scene(scene, settings, caster, offset, timer, progress,
                                                         cancelled)
    direct = DirectLighting(scene, caster, settings.patch_size_m, offset, settings.light_samples_per_edge,
                            settings.seed)
    counts["emitters"] = direct.emitter_count
    solution = Solution(scene, mesh, elements, direct, caster, offset, ambient, state.history, timer.laps,
                        caster.rays_cast, state, reflectance_warnings(scene), counts, settings.element_size_m)
    if settings.solver == "hierarchical" and settings.receiver_gather and gather_pays(solution):
        solution = _gathered_at_receivers([solution], settings, progress, cancelled)[0]
        solution.counts["receiver_gather"] = True
        timer.lap("gather at the elements")
        solution.rays_cast = caster.rays_cast
    return solution


def _gathered_at_receivers(solutions: list[Solution], settings: BakeSettings, progress, cancelled) -> list:
    """core.gather.gather_at_receivers, seeded alike for a scene and its light groups (so that the groups' light
    sums to the scene's) and apart from the lightmap's gather rays."""
    return gather_at_receivers(solutions, RECEIVER_GATHER_SAMPLES_PER_EDGE, settings.seed + RECEIVER_GATHER_STREAM,
                               steps_in_flight(settings.threads or None), progress, cancelled)


def reflectance_warnings(scene: Scene) -> list[str]:
    """One warning naming the materials whose reflectance reaches 1 somewhere (pure white), which the solve keeps
    just below 1 so that light between white walls stays finite."""
    white = [m.name for m in scene.materials if max(m.reflectance) >= MAX_REFLECTANCE or
             (m.texture is not None and m.texture.pixels[..., :3].max() >= MAX_REFLECTANCE)]
    if not white:
        return []
    return [f"Reflectance of 1 (pure white) in {', '.join(map(repr, white))}: elements reflect at most "
            f"{MAX_REFLECTANCE} so that the solve converges."]


def _hierarchical(scene, settings, caster, offset, timer, progress, cancelled):
    """Face clusters, their live sides, links to the cluster tree and the Jacobi solve (core.hierarchical)."""
    size = settings.element_size_m
    mesh = build_mesh(scene, size, size)
    clusters, exposed_samples, receivers, sample_direct = adaptive_elements(
        mesh, scene, caster, offset, size, settings.adaptive_passes, settings.adaptive_threshold,
        settings.min_element_size_m, settings.light_samples_per_edge, settings.seed, progress)
    # A side whose hemisphere meets no solved surface exchanges no light with the scene (the bottom of a box
    # resting on the floor, facing the void under it; a ground plane under an open sky): it keeps its direct light
    # but sends nothing, so that it does not dilute its clusters' means.
    node_element = np.full(len(mesh.node_bary), -1)
    node_element[clusters.piece_node] = clusters.piece_element
    receives = live_side_test(scene, mesh, node_element, exposed_samples.sum(axis=2) > 0)
    covered = covered_share(caster, receivers.point, receivers.normal, offset, receives, settings.seed)
    isolated = covered == 0
    source_samples = exposed_samples.copy()
    source_samples[receivers.element[isolated], receivers.side[isolated]] = 0.0
    direct = np.zeros((clusters.count, 2, 3))
    direct[receivers.element, receivers.side] = side_mean(exposed_samples, receivers.element, receivers.side,
                                                          sample_direct)
    timer.lap("elements and direct light")
    tree = build_tree(clusters.centroid, clusters.low, clusters.high, clusters.normal, source_samples,
                      clusters.sample_point, clusters.sample_normal)
    sources = LinkSources.of(tree, clusters, offset)
    links = build_links(sources, receivers.point, receivers.normal, receivers.element, caster, settings.opening,
                        settings.visibility_samples_per_edge, offset, covered, progress, cancelled)
    timer.lap("links")
    exposed, sending = exposed_samples.sum(axis=2), source_samples.sum(axis=2)
    reflectance = np.minimum(clusters.reflectance, MAX_REFLECTANCE)
    state = HierarchicalState(clusters, tree, receivers, links, exposed, sending, reflectance, direct,
                              direct.copy(), exposed_samples=exposed_samples)
    rough = max(settings.residual_threshold, ROUGH_RESIDUAL)  # enough to tell where clusters' radiosity varies
    solve(state, rough, settings.max_shots, lambda: caster.rays_cast, progress, cancelled)
    timer.lap("solve")
    # BF refinement: links to clusters whose surfaces' radiosity varies, where that matters, are refined to their
    # parts; the solve then resumes with them.
    received = state.irradiance[receivers.element, receivers.side].sum(axis=1)
    mean = node_radiosity(tree, state.radiosity, sending).sum(axis=2).max(axis=1)
    state.links = refine_links(links, sources, caster, receivers.point, receivers.normal,
                               node_deviation(tree, state.radiosity, sending), mean, received, REFINEMENT_TOLERANCE,
                               settings.visibility_samples_per_edge, offset, cancelled)
    timer.lap("link refinement")
    solve(state, settings.residual_threshold, settings.max_shots, lambda: caster.rays_cast, progress, cancelled)
    timer.lap("solve")
    counts = {"pieces": len(clusters.piece_node), "element_sides": len(receivers.element),
              "nodes": tree.node_count, "links": state.links.count, "link_bytes": state.links.nbytes}
    return mesh, _solved_elements(state, node_element, size), state, state.ambient(), counts


def _solved_elements(state: HierarchicalState, node_element: np.ndarray, element_size_m: float) -> SolvedElements:
    """The hierarchical solve's elements (face clusters, both sides) as SolvedElements."""
    clusters, receivers = state.clusters, state.receivers
    point = np.repeat(clusters.centroid[:, None], 2, axis=1)
    point[receivers.element, receivers.side] = receivers.point
    reach = np.maximum(np.linalg.norm(clusters.high - clusters.low, axis=1), element_size_m)
    return SolvedElements(node_element, point, clusters.normal[:, None, :] * [[1.0], [-1.0]], state.exposed_m2,
                          state.irradiance, state.direct_irradiance, state.reflectance, clusters.emitted_exitance,
                          clusters.area_m2, reach, state.reflected_irradiance())


def bake_light_groups(solution: Solution, settings: BakeSettings = BakeSettings(), progress: Progress = no_progress,
                      cancelled=never_cancelled, grouped: Scene | None = None) -> dict[str, Solution]:
    """The light of each light group of ``solution``'s scene apart (core.scene.Scene.light_groups; "" the
    ungrouped): a Solution per group whose light sums to the scene's, since light is linear in emission (radiosity
    paper, section 4: B = (I - rho F)^-1 E). The hierarchical solver's elements, cluster tree and refined links,
    the transport that costs the rays, serve every group: each group has its own direct light and solve
    (Scene.lit_by). The classic solvers, for small scenes, bake each group anew. ``grouped``: the same scene with
    its lights grouped otherwise (core.relight.by_source: a group per source)."""
    groups, grouped = {}, grouped or solution.scene
    for group in grouped.light_groups:
        scene = grouped.lit_by(group)
        progress(0.0, f"Light group '{group or 'ungrouped'}'")
        if settings.solver == "hierarchical":
            groups[group] = _relit(solution, scene, settings, progress, cancelled)
        else:
            groups[group] = bake(scene, settings, progress, cancelled)
    if solution.counts.get("receiver_gather"):
        groups = dict(zip(groups, _gathered_at_receivers(list(groups.values()), settings, progress, cancelled)))
    return groups


def _relit(solution: Solution, scene: Scene, settings: BakeSettings, progress, cancelled) -> Solution:
    """``solution``'s hierarchical elements and links lit by ``scene``'s lights (the same surfaces): its direct light
    on the element sides, then the Jacobi solve from it."""
    timer, full, caster, offset = Timer(), solution.state, solution.caster, solution.offset_m
    clusters = replace(full.clusters, emitted_exitance=emitted_exitance(full.clusters, solution.mesh, scene))
    receivers = full.receivers
    direct = np.zeros((clusters.count, 2, 3))
    direct[receivers.element, receivers.side] = side_direct_irradiance(
        scene, clusters, caster, full.exposed_samples, receivers.element, receivers.side, offset,
        settings.light_samples_per_edge, settings.seed)
    timer.lap("direct light")
    state = HierarchicalState(clusters, full.tree, receivers, full.links, full.exposed_m2, full.sending_m2,
                              full.reflectance, direct, direct.copy(), exposed_samples=full.exposed_samples)
    solve(state, settings.residual_threshold, settings.max_shots, lambda: caster.rays_cast, progress, cancelled,
          full.sampled_scale, len(full.history))
    timer.lap("solve")
    elements = _solved_elements(state, solution.elements.node_element, settings.element_size_m)
    direct_lighting = DirectLighting(scene, caster, settings.patch_size_m, offset, settings.light_samples_per_edge,
                                     settings.seed)
    return solution.relit(scene, elements, direct_lighting, state, timer.laps)


def _classic(scene, settings, caster, offset, timer, progress, cancelled):
    """Patches and elements per triangle, form-factor rows, progressive or direct solve, adaptive passes and
    near-field links."""
    mesh = build_mesh(scene, settings.patch_size_m, settings.element_size_m)
    patches = Patches.of(mesh)
    rows = _form_factor_rows(settings, caster, patches, mesh, scene, offset)
    elements = bury(elements_of(mesh, scene), caster, scene, offset)
    progress(0.0, f"Direct light on {len(elements.node)} elements")
    direct = _direct(scene, caster, elements.centroid, elements.normal, offset, settings)
    timer.lap("direct light")
    state = RadiosityState.start(elements, patches, direct)
    threads = settings.threads or os.cpu_count() or 1
    factors = FormFactorCache(rows, len(patches.area_m2), int(settings.form_factor_memory_mb * 2 ** 20), threads)
    _solve(state, factors, settings, caster, progress, cancelled)
    timer.lap("solve")
    criteria = adaptive.RefinementCriteria(settings.adaptive_threshold, settings.min_element_size_m)
    for number in range(settings.adaptive_passes):
        progress(0.0, f"Adaptive pass {number + 1}: {len(state.elements.node)} elements")
        refined = _refine(mesh, scene, state, caster, factors, criteria, offset, settings, cancelled)
        if refined is None:
            break
        state = refined
        _solve(state, factors, settings, caster, progress, cancelled)
        timer.lap(f"adaptive pass {number + 1}")
    _near_field(state, settings, caster, offset, progress, cancelled)
    timer.lap("near field")
    # The light the unshot residual would still bring, spread evenly (the ambient term), so an early stop does
    # not leave multiple reflection short (by about residual / (1 - rho) on bright walls).
    ambient = state.ambient(factors.enclosure(state.patch_area_m2))
    return mesh, _classic_elements(mesh, state), state, ambient, {"patches": len(patches.area_m2)}


def _classic_elements(mesh, state: RadiosityState) -> SolvedElements:
    """The classic solve's elements (mesh leaves, front side only) as SolvedElements."""
    elements = state.elements
    count = len(elements.node)
    node_element = np.full(len(mesh.node_bary), -1)
    node_element[elements.node] = np.arange(count)
    exposed = np.zeros((count, 2))
    exposed[:, FRONT] = elements.exposed_m2
    irradiance, direct = np.zeros((count, 2, 3)), np.zeros((count, 2, 3))
    irradiance[:, FRONT], direct[:, FRONT] = state.irradiance, state.direct_irradiance
    reach = 2.0 * np.linalg.norm(elements.corners - elements.centroid[:, None, :], axis=2).max(axis=1)
    return SolvedElements(node_element, np.repeat(elements.centroid[:, None], 2, axis=1),
                          elements.normal[:, None, :] * [[1.0], [-1.0]], exposed, irradiance, direct,
                          elements.reflectance, elements.emitted_exitance, elements.area_m2, reach)


def _form_factor_rows(settings, caster, patches, mesh, scene, offset):
    if settings.form_factors == "hemicube":
        return HemicubeRows(caster, patches, mesh, settings.hemicube_resolution, offset,
                            mesh.scene_to_mesh(len(scene.triangles)))
    return RayCastRows(caster, patches, settings.visibility_samples_per_edge, offset)


def _direct(scene, caster, points, normals, offset, settings):
    return direct_irradiance(scene, caster, points, normals, offset, settings.light_samples_per_edge, settings.seed)


def _solve(state, factors, settings, caster, progress, cancelled):
    if settings.solver == "direct":
        solve_direct(state, factors, cancelled=cancelled)
    else:
        solve_progressive(state, factors, settings.residual_threshold, settings.max_shots,
                          lambda: caster.rays_cast, progress, cancelled)


def _near_field(state, settings, caster, offset, progress, cancelled):
    """Add the element-to-element light of near, unevenly lit patches (core.nearfield) to the solved irradiance.

    What the correction changes in a patch's mean radiosity becomes unshot radiosity, which the ambient term
    spreads (a re-solve would re-gather from the patches and drop the correction)."""
    progress(0.0, f"Near-field links of {len(state.elements.node)} elements")
    radiosity = state.radiosity
    patch_radiosity = patch_mean(radiosity, state.elements, state.patches)
    state.irradiance = state.irradiance + near_field_irradiance(
        caster, state.elements, state.patches, radiosity, patch_radiosity, state.irradiance,
        settings.visibility_samples_per_edge, offset, progress, cancelled)


def _refine(mesh, scene, state, caster, factors, criteria, offset, settings, cancelled):
    """One adaptive pass; returns the refined state, or None when nothing needs splitting."""
    elements = state.elements
    corners = adaptive.corner_sample_points(elements).reshape(-1, 3)
    corner_direct = _direct(scene, caster, corners, np.repeat(elements.normal, 3, axis=0), offset, settings)
    split = adaptive.elements_to_split(mesh, elements, state.irradiance, corner_direct.reshape(-1, 3, 3),
                                       state.direct_irradiance, criteria, offset / 10)
    if len(split) == 0:
        return None
    refined, old = adaptive.split_elements(mesh, scene, elements, split)
    refined = bury(refined, caster, scene, offset)
    new = np.flatnonzero(old < 0)
    new_elements = elements_of(mesh, scene, refined.node[new])
    new_direct = _direct(scene, caster, new_elements.centroid, new_elements.normal, offset, settings)
    direct = np.empty((len(refined.node), 3))
    irradiance = np.empty((len(refined.node), 3))
    kept = old >= 0
    direct[kept], irradiance[kept] = state.direct_irradiance[old[kept]], state.irradiance[old[kept]]
    direct[new] = new_direct
    factors.refine(old, refined, cancelled)
    if factors.rows is not None:
        irradiance[new] = new_direct + factors.rows[new] @ state.shot
    else:
        irradiance[new] = new_direct + factors.gather(state.shot, new_elements, cancelled, store=False)
    refined_state = RadiosityState(refined, state.patches, direct, irradiance, state.shot, state.injected_power_w,
                                   state.history)
    return refined_state
