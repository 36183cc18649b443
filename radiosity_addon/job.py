"""One bake, in three steps shared by the operator (interactive and execute()) and the command line:

1. ``prepare`` (main thread): export the evaluated scene, plan the lightmap atlas, check the outputs can be written;
2. ``solve`` (any thread, no bpy): the core solve and the lightmap texels, with progress and cancel callables;
3. ``apply`` (main thread): write the results and return the report.
"""
from __future__ import annotations

import threading
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..core import BakeSettings, SceneError, bake
from ..core.bake import bake_light_groups, ray_caster, ray_offset_m
from ..core.relight import basis, mix, weights
from ..core.scene import sources
from ..core.atlas import AtlasSize, uv_area
from ..core.geometry import triangle_areas
from ..core.lightmap import Lightmap, LightmapSettings, light_texels, sample_texels
from ..core.progress import Timer
from ..core.memory import GIB, MemoryLimitError, default_limit_gb, fit_to_memory, memory_guard
from ..core.raycast import backend_name
from ..core.staged_files import StagedFiles
from .export import Export, export_scene, make_linked_local
from .lightmaps import LightmapPlan, checked, plan_lightmap, write_lightmap
from .presets import bake_settings, corner_gather_samples, lightmap_settings
from .relighting import check_cache_path, load_cache, stage_cache, transport_key
from .settings import UNGROUPED, UserSettings, light_group_output
from .writeback import (check_attribute_name_free, colour_holders, objects_loop_light, write_radiosity_mesh,
                        write_vertex_colors)

@dataclass
class Job:
    """A bake under way: the exported scene, the user's settings and the core's made from them, where lightmap
    files go ("" = pack into the .blend), the light groups written apart, and what the solve produced.

    The outputs are mixed from a basis: ``basis`` the solutions of the light's parts (each light group's, or each
    source's for a relighting cache, core.relight; none for a plain bake, whose one part is ""), ``weights`` (3,)
    per part, and ``members``, the parts of each light group written apart. ``stats``: the solve's numbers the
    report gives; ``corner_basis``: per object, each part's light per mesh loop (traced in the solve, or read from
    a relighting cache)."""

    export: Export
    settings: BakeSettings
    user: UserSettings
    lightmap_folder: str
    lightmap_settings: LightmapSettings | None = None
    lightmap_plan: LightmapPlan | None = None
    light_groups: tuple[str, ...] = ()
    started: float = field(default_factory=time.perf_counter)
    solution: object = None
    basis: dict = field(default_factory=dict)
    weights: dict = field(default_factory=lambda: {"": np.ones(3)})
    members: dict = field(default_factory=dict)
    sources: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)
    corner_basis: dict = field(default_factory=dict)
    lightmaps: list = field(default_factory=list)
    memory: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)


def prepare(context, user: UserSettings, lightmap_folder: str) -> Job:
    """Export the scene and plan the outputs of a bake of ``user``'s settings; lightmap files go into
    ``lightmap_folder`` ("" = packed into the .blend)."""
    made_local = make_linked_local(context) if user.make_local else []
    export = export_scene(context)
    export.warnings.extend(made_local)
    settings = bake_settings(user, export.scene.size_m)
    if not any(item.writable for item in export.objects) and not user.create_radiosity_mesh:
        raise SceneError("Nothing to bake: no visible mesh object is set to 'Bake'.")
    job = Job(export, settings, user, lightmap_folder)
    job.light_groups = light_groups_to_write(job)
    if user.relight_cache:
        check_cache_path(user.relight_cache)
    if user.vertex_colors:
        for name in [user.attribute_name] + [light_group_output(user.attribute_name, g) for g in job.light_groups]:
            check_attribute_name_free(export, name)
    limit_gb = user.max_memory_gb or default_limit_gb()
    if user.lightmaps:
        job.lightmap_settings, size = lightmap_settings(user, export.scene.size_m)
        _check_texel_density(job, size, limit_gb)
        job.lightmap_plan = plan_lightmap(context, export, user, size, job.light_groups)
    _fit_to_memory(job, limit_gb)
    return job


def light_groups_to_write(job: Job) -> tuple[str, ...]:
    """The light groups to write apart: the scene's (core.scene.Scene.light_groups) when the user asked for them
    and something is in one (with a warning when nothing is)."""
    if not job.user.light_groups:
        return ()
    groups = tuple(job.export.scene.light_groups)
    if not any(groups):
        job.warnings.append("Light Groups is on, but no lamp, emissive object or world is in a light group (Object "
                            "or World properties > Shading > Light Group): only the whole light is written.")
        return ()
    return groups


def _check_texel_density(job: Job, size: AtlasSize, limit_gb: float) -> None:
    """Refuse, before the atlas is unwrapped, a texel density whose texels alone would not fit the memory limit
    (the texels the surfaces cover at that density, twice that in the pages' images)."""
    if size.resolution:
        return
    receivers = job.export.scene.triangles[~job.export.scene.casts_only]
    covered = int(min(triangle_areas(receivers).sum() * size.texels_per_metre ** 2, 2 ** 60))
    fit_to_memory(receivers, job.settings.element_size_m, limit_gb, min(covered, size.max_size ** 2), 2 * covered,
                  job.settings.threads, covered, job.settings.adaptive_passes)


def _fit_to_memory(job: Job, limit_gb: float) -> None:
    """Estimate the bake's memory before the heavy work; coarsen the elements if that makes it fit (with a
    warning), or refuse the bake (core.memory.MemoryLimitError) if nothing does. A bake split into parts (light
    groups, or sources for a relighting cache) holds every part's texels and pages."""
    scene, plan = job.export.scene, job.lightmap_plan
    covered, image, planned = 0, 0, 0
    parts = len(basis(scene)[1]) if job.user.relight_cache else max(1, len(job.light_groups))
    if plan is not None:
        width, height = plan.layout.width, plan.layout.height
        page_texels = [int(uv_area(corner_uv) * width * height) for _, corner_uv in plan.page_triangles]
        covered, planned = parts * max(page_texels, default=0), sum(page_texels)
        image = parts * width * height * len(plan.page_triangles)
    asked = job.settings.element_size_m
    size, estimate = fit_to_memory(scene.triangles[~scene.casts_only], asked, limit_gb, covered, image,
                                   job.settings.threads, planned, job.settings.adaptive_passes)
    job.memory = {"limit_gb": limit_gb, "estimated_gb": round(estimate.peak_bytes / GIB, 2),
                  "steps_gb": {name: round(value / GIB, 2) for name, value in estimate.steps.items()}}
    if size != asked:
        job.settings = replace(job.settings, element_size_m=size, patch_size_m=max(job.settings.patch_size_m, size),
                               min_element_size_m=job.settings.min_element_size_m * size / asked)
        job.warnings.append(f"Elements are {size / asked:.2g} times the quality's size ({size:.3g} m instead of "
                            f"{asked:.3g} m) so that the bake fits the memory limit of {limit_gb:g} GiB (about "
                            f"{estimate.peak_bytes / GIB:.1f} GiB now); raise the limit for finer indirect light.")


def solve(job: Job, progress, cancelled) -> None:
    """The solve and the lightmap texels, stopped by a MemoryLimitError once the process's resident memory
    exceeds the Memory Limit (core.memory.memory_guard; the estimate is not a promise); an allocation that fails
    anyway becomes one too, naming the limit to lower."""
    if job.memory:
        cancelled = memory_guard(job.memory["limit_gb"], cancelled, job.memory.get("estimated_gb"))
    try:
        _solve(job, progress, cancelled)
    except MemoryError:
        job.solution, job.lightmaps = None, []
        raise MemoryLimitError(
            f"The bake ran out of memory (estimated {job.memory.get('estimated_gb', 0):g} GiB, limit "
            f"{job.memory.get('limit_gb', 0):g} GiB): set a lower memory limit (--max-memory-gb) so that it "
            "adapts, lower the quality or the lightmap's texel density, or close other programs.") from None


def _solve(job: Job, progress, cancelled) -> None:
    scene = job.export.scene
    # With a relighting cache, a part per source of light (core.relight.basis), every lamp on: the links are
    # refined for each source's light, the lamps that are off now included.
    split, job.sources = basis(scene) if job.user.relight_cache else (None, [])
    caster = ray_caster(scene, job.settings, progress)
    with ThreadPoolExecutor(1) as planner:  # the lightmap's texels are planned while the scene is solved
        stop = threading.Event()
        planned = planner.submit(_plan_pages, job, caster.with_own_count(), stop)
        try:
            job.solution = solution = bake(split or scene, job.settings, progress, cancelled, caster)
            _bake_light_groups(job, split, progress, cancelled)
        except BaseException:
            stop.set()  # pages not started yet are left unplanned when the solve fails or is cancelled
            raise
        pages = planned.result()
    job.stats = {"timings": solution.seconds, "elements": solution.element_count, "solve": solution.counts,
                 "residual": solution.residual, "rays": solution.rays_cast, "warnings": list(solution.warnings)}
    job.lightmaps = [light_texels(solution, page, progress, cancelled, job.basis or None, seconds)
                     for page, seconds in pages]
    if job.user.vertex_colors:
        started = time.perf_counter()
        light = objects_loop_light(colour_holders(job.export.objects, job.user.own_mesh_copies), solution,
                                   job.export.scene_index_of_input(), job.user.vertex_indirect,
                                   corner_gather_samples(job.user), list(job.basis.values()) or [solution],
                                   progress, cancelled)
        job.corner_basis = {name: dict(zip(job.basis or [""], parts)) for name, parts in light.items()}
        job.stats["timings"] = {**job.stats["timings"], "vertex colours": time.perf_counter() - started}


def _bake_light_groups(job: Job, split, progress, cancelled) -> None:
    """The solve of each light group (or, for a relighting cache, of each source in ``split``, the basis scene)."""
    solution = job.solution
    if split is not None:
        job.basis = bake_light_groups(solution, job.settings, progress, cancelled, split)
        job.weights = weights(job.sources, sources(job.export.scene))
        job.members = {group: list(dict.fromkeys(s.key for s in job.sources if s.light_group == group))
                       for group in job.light_groups}
    elif job.light_groups:
        job.basis = bake_light_groups(solution, job.settings, progress, cancelled)
        job.weights = {key: np.ones(3) for key in job.basis}
        job.members = {group: [group] for group in job.light_groups}


def _plan_pages(job: Job, caster, stop: threading.Event) -> list:
    """(core.lightmap.TexelPlan, its seconds) of each page of the job's lightmap, from the scene alone (the
    indirect method is settled once the solution is there), until ``stop`` is set."""
    plan, pages = job.lightmap_plan, []
    if plan is None:
        return pages
    scene = job.export.scene
    for scene_triangle, corner_uv in plan.page_triangles:
        if stop.is_set():
            break
        timer = Timer()
        page = sample_texels(scene, caster, ray_offset_m(scene), scene_triangle, corner_uv, plan.layout.width,
                             plan.layout.height, job.lightmap_settings)
        timer.lap("texels")
        pages.append((page, timer.laps))
    return pages


def write_outputs(job: Job) -> dict:
    """``apply`` with its files moved into place at once: for callers that write nothing else (the panel)."""
    with StagedFiles() as staged:
        report = apply(job, staged)
        staged.commit()
    return report


def apply(job: Job, staged: StagedFiles) -> dict:
    """Write the outputs into the .blend and stage their files in ``staged`` (the caller commits them); returns
    the report (REPORT.json's contract, docs/design in the README)."""
    objects, entries = [], []
    warnings = list(job.export.warnings) + job.warnings + list(job.stats["warnings"])
    group_files = {group: [] for group in job.light_groups}
    if job.lightmap_plan is not None:  # first: its files are what can still fail, before the .blend changes
        entries, more = write_lightmap(job.lightmap_plan, [_mixed(job, page) for page in job.lightmaps],
                                       _metadata(job), job.lightmap_folder, staged)
        warnings += job.lightmap_plan.warnings + more
        for group in job.light_groups:
            group_entries, more = write_lightmap(job.lightmap_plan.for_light_group(group),
                                                 [_mixed(job, page, group) for page in job.lightmaps],
                                                 _metadata(job), job.lightmap_folder, staged)
            group_files[group] = sorted({entry["image"] for entry in group_entries})
            warnings += more
    if job.user.vertex_colors:
        objects, more = write_vertex_colors(job.export, job.user, lambda item: _corner_light(job, item),
                                            job.light_groups)
        warnings += more
    objects = _merge(objects, entries)
    if job.user.create_radiosity_mesh and job.solution is not None:
        obj = write_radiosity_mesh(_radiosity_mesh(job), job.user.attribute_name)
        objects.append({"name": obj.name, "color_attribute": job.user.attribute_name, "uv_map": None, "image": None,
                        "resolution": None})
    report = {
        "objects": objects,
        "seconds": time.perf_counter() - job.started,
        "timings": job.stats["timings"],
        "elements": job.stats["elements"],
        "solve": job.stats["solve"],
        "residual": job.stats["residual"],
        "rays": job.stats["rays"],
        "ray_backend": backend_name(),
        "dropped_triangles": job.export.scene.dropped_triangles,
        "settings": job.settings.as_dict(),
        "memory": job.memory,
        "units": "irradiance / pi (Cycles Diffuse bake, Direct + Indirect, no Color), scene-linear",
        "warnings": warnings,
    }
    if job.light_groups:
        report["light_groups"] = [_group_entry(job, group, group_files[group]) for group in job.light_groups]
    if job.user.relight_cache and job.solution is not None:  # a bake, not a relight: keep its basis
        report["relight_cache"] = stage_cache(job, staged)
    if job.lightmaps:
        timings = {}
        for page in job.lightmaps:
            for phase, seconds in page.seconds.items():
                timings[phase] = timings.get(phase, 0.0) + seconds
        report["lightmap"] = {"pages": len(job.lightmaps), "texels": sum(page.texel_count for page in job.lightmaps),
                              "moved_texels": sum(int(page.moved.sum()) for page in job.lightmaps),
                              "texels_per_metre": job.lightmap_plan.layout.texels_per_metre,
                              "indirect": job.lightmaps[0].indirect,
                              "timings": timings, "settings": vars(job.lightmap_settings).copy()}
    return report


def _mixed(job: Job, page, group: str | None = None) -> np.ndarray:
    """A page's light: the whole (``group`` None) or a light group's, mixed from the basis at its weights."""
    if not page.groups:
        return page.light
    return mix(page.groups, job.weights, list(job.weights) if group is None else job.members[group])


def _radiosity_mesh(job: Job) -> tuple:
    """The solve's mesh with its light; a bake with a relighting cache solved every source on at the basis's
    emission, so its light is mixed from the basis."""
    if not job.user.relight_cache:
        return job.solution.radiosity_mesh()
    vertices, triangles, light = job.solution.radiosity_mesh(list(job.basis.values()))
    return vertices, triangles, mix(dict(zip(job.basis, light)), job.weights, list(job.weights))


def _corner_light(job: Job, item) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """An object's light per mesh loop, whole and per light group written apart, mixed from the basis (each
    part's light traced in the solve, or read from a relighting cache)."""
    basis = job.corner_basis[item.name]
    return mix(basis, job.weights, list(job.weights)), {group: mix(basis, job.weights, job.members[group])
                                                         for group in job.light_groups}


def _group_entry(job: Job, group: str, images: list[str]) -> dict:
    """The report's entry of one light group: its name ("" for the ungrouped light), its lamps, and the names of
    its outputs (lightmap files, or images packed into the .blend, and colour attribute)."""
    scene = job.export.scene
    return {"name": group or UNGROUPED, "group": group,
            "lights": [light.name for light in scene.lights if light.light_group == group],
            "emissive_materials": sorted({m.name for m in scene.materials if m.light_group == group and
                                          max(m.emitted_radiance) > 0}),
            "world": bool(scene.world.light_group == group and max(scene.world.radiance) > 0),
            "lightmap_image": light_group_output(job.user.lightmap_image, group) if job.user.lightmaps else None,
            "images": images,
            "color_attribute": light_group_output(job.user.attribute_name, group) if job.user.vertex_colors else None}


def _merge(vertex_entries: list[dict], lightmap_entries: list[dict]) -> list[dict]:
    """One report entry per object, with its colour attribute and its lightmap."""
    by_name = {entry["name"]: entry for entry in vertex_entries}
    for entry in lightmap_entries:
        if entry["name"] in by_name:
            by_name[entry["name"]].update({k: v for k, v in entry.items() if k != "color_attribute"})
        else:
            by_name[entry["name"]] = entry
    return list(by_name.values())


def _metadata(job: Job) -> dict:
    return {"Software": f"Radiosity Baker {_version()}",
            "radiosity:units": "irradiance / pi (W m^-2 sr^-1), scene-linear; Cycles Diffuse bake, no Color",
            "radiosity:settings": repr(job.settings.as_dict()),
            "radiosity:lightmap": repr(vars(job.lightmap_settings))}


def _version() -> str:
    """The extension's version, from blender_manifest.toml beside this package."""
    manifest = Path(__file__).resolve().parents[1] / "blender_manifest.toml"
    with open(manifest, "rb") as handle:
        return tomllib.load(handle)["version"]


def relight_job(context, user: UserSettings, lightmap_folder: str, path: str):
    """A job whose outputs are mixed from the cache at ``path`` for the scene as it is now, with no ray cast;
    SceneError names what changed when the cache no longer holds (core.relight.TransportKey.changes) or a source
    it cannot light."""
    started = time.perf_counter()
    cache = load_cache(path)
    export = export_scene(context)
    changed = transport_key(export.scene, user).changes(cache["key"])
    if changed:
        raise SceneError(f"The relighting cache '{path}' no longer fits the scene: {', '.join(changed)} changed "
                         "since it was baked. Bake again.")
    job = Job(export, cache["settings"], user, lightmap_folder, cache["lightmap_settings"])
    now = sources(export.scene)
    # The groups the bake wrote too: a group whose lamps are all off now is written dark, not left as it was.
    groups = sorted(set(export.scene.light_groups) | set(cache["light_groups"]))
    job.light_groups = tuple(groups) if user.light_groups and any(groups) else ()
    job.weights = weights(cache["sources"], now)
    group_of = {source.key: source.light_group for source in cache["sources"]} | {s.key: s.light_group for s in now}
    job.members = {group: [key for key in job.weights if group_of[key] == group] for group in job.light_groups}
    job.sources, job.stats, job.memory = cache["sources"], dict(cache["stats"]), cache["memory"]
    job.corner_basis = cache["corner_basis"]
    if cache["lightmap_plan"] is not None and user.lightmaps:
        job.lightmap_plan = checked(replace(cache["lightmap_plan"], user=user, light_groups=job.light_groups))
        job.lightmaps = [Lightmap(None, page["covered"], page["moved"], page["texel_count"], page["indirect"], {},
                                  page["groups"]) for page in cache["pages"]]
    job.stats["timings"] = {"relight": time.perf_counter() - started}
    if user.vertex_colors and not job.corner_basis:
        raise SceneError(f"The relighting cache '{path}' holds no colour attributes (it was baked with Target "
                         "Lightmap): bake again, or relight the lightmap only.")
    if user.lightmaps and not job.lightmaps:
        raise SceneError(f"The relighting cache '{path}' holds no lightmap (it was baked with Target Vertex "
                         "Colors): bake again, or relight the colour attributes only.")
    return job
