"""The pipeline: Scene -> patches and elements -> direct light -> radiosity solve -> adaptive passes -> Solution.

``bake(scene, settings, progress, cancelled)`` is the one entry point the add-on, the command line and the tests
call. Everything is deterministic for a given scene, settings and seed.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, fields

import numpy as np

from . import adaptive
from .direct import DirectLighting
from .lights import direct_irradiance
from .mesh import build_mesh, bury, elements_of
from .nearfield import near_field_irradiance
from .progress import Progress, Timer, never_cancelled, no_progress
from .raycast import RayCaster
from .scene import Scene, SceneError
from .shooting import HemicubeRows, Patches, RayCastRows
from .solution import Solution
from .solver import FormFactors, RadiosityState, patch_mean, solve_direct, solve_progressive

RAY_OFFSET_FRACTION = 2e-5


@dataclass(frozen=True)
class BakeSettings:
    """Settings of a bake; lengths in metres.

    patch_size_m / element_size_m: target edge lengths of shooting patches and receiving elements.
    form_factors: "raycast" (analytic x shadow rays, default) or "hemicube".
    solver: "progressive" (default) or "direct" (Gaussian elimination, small scenes).
    visibility_samples_per_edge: s, so s^2 shadow rays per element-patch pair (ray-cast form factors).
    hemicube_resolution: pixels across the hemicube's top face.
    light_samples_per_edge: s, so s^2 shadow rays per element and soft light (area, sized point, sun angle, world).
    residual_threshold: stop shooting when unshot / injected power falls below it.
    adaptive_passes, adaptive_threshold, min_element_size_m: adaptive meshing (see core.adaptive).
    form_factor_memory_mb: memory for the element-to-patch form-factor matrix; over it, rows are recomputed
        when needed (memory then stays O(n + P^2)).
    """

    patch_size_m: float = 0.5
    element_size_m: float = 0.125
    form_factors: str = "raycast"
    solver: str = "progressive"
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

    def __post_init__(self):
        positive = ("patch_size_m", "element_size_m", "visibility_samples_per_edge", "hemicube_resolution",
                    "light_samples_per_edge", "residual_threshold", "max_shots", "adaptive_threshold",
                    "min_element_size_m")
        for name in positive:
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise SceneError(f"Setting '{name}' must be a positive number, got {value}.")
        for name in ("adaptive_passes", "form_factor_memory_mb", "threads", "seed"):
            if getattr(self, name) < 0:
                raise SceneError(f"Setting '{name}' must not be negative, got {getattr(self, name)}.")
        if self.form_factors not in ("raycast", "hemicube"):
            raise SceneError(f"Setting 'form_factors' must be 'raycast' or 'hemicube', got '{self.form_factors}'.")
        if self.solver not in ("progressive", "direct"):
            raise SceneError(f"Setting 'solver' must be 'progressive' or 'direct', got '{self.solver}'.")
        if self.element_size_m > self.patch_size_m:
            raise SceneError(f"Setting 'element_size_m' ({self.element_size_m}) must not exceed "
                             f"'patch_size_m' ({self.patch_size_m}).")

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def bake(scene: Scene, settings: BakeSettings = BakeSettings(), progress: Progress = no_progress,
         cancelled=never_cancelled) -> Solution:
    """Solve the scene's diffuse light; raises BakeCancelled if ``cancelled()`` turns True."""
    timer = Timer()
    offset = RAY_OFFSET_FRACTION * scene.size_m
    mesh = build_mesh(scene, settings.patch_size_m, settings.element_size_m)
    caster = RayCaster(scene.triangles, settings.threads or None)
    patches = Patches.of(mesh)
    rows = _form_factor_rows(settings, caster, patches, mesh, scene, offset)
    elements = bury(elements_of(mesh, scene), caster, scene, offset)
    progress(0.0, f"Direct light on {len(elements.node)} elements")
    direct = _direct(scene, caster, elements.centroid, elements.normal, offset, settings)
    timer.lap("direct light")
    state = RadiosityState.start(elements, patches, direct)
    threads = settings.threads or os.cpu_count() or 1
    factors = FormFactors(rows, len(patches.area_m2), int(settings.form_factor_memory_mb * 2 ** 20), threads)
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
    emission = patch_mean(state.elements.emitted_exitance, state.elements, patches)
    direct = DirectLighting(scene, caster, patches, emission, offset, settings.light_samples_per_edge, settings.seed)
    # The light the unshot residual would still bring, spread evenly (the ambient term), so an early stop does
    # not leave multiple reflection short (by about residual / (1 - rho) on bright walls).
    ambient = state.ambient(factors.enclosure(state.patch_area_m2))
    return Solution(scene, mesh, state, weld_tolerance_m=offset / 10, seconds=timer.laps, rays_cast=caster.rays_cast,
                    direct=direct, ambient_irradiance=ambient)


def _form_factor_rows(settings, caster, patches, mesh, scene, offset):
    if settings.form_factors == "hemicube":
        scene_to_mesh = np.full(len(scene.triangles), -1)
        scene_to_mesh[mesh.triangle_scene] = np.arange(len(mesh.triangle_scene))
        return HemicubeRows(caster, patches, mesh, settings.hemicube_resolution, offset, scene_to_mesh)
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
