"""One bake, in three steps shared by the operator (interactive and execute()) and the command line:

1. ``prepare`` (main thread): export the evaluated scene, plan the lightmap atlas, check the outputs can be written;
2. ``solve`` (any thread, no bpy): the core solve and the lightmap texels, with progress and cancel callables;
3. ``apply`` (main thread): write the results and return the report.
"""
from __future__ import annotations

import time
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..core import BakeSettings, SceneError, bake
from ..core.bake import bake_light_groups
from ..core.atlas import AtlasSize, uv_area
from ..core.geometry import triangle_areas
from ..core.lightmap import LightmapSettings, bake_lightmap
from ..core.memory import GIB, MemoryLimitError, default_limit_gb, fit_to_memory
from ..core.raycast import backend_name
from ..core.staged_files import StagedFiles
from .export import Export, export_scene, make_linked_local
from .lightmaps import LightmapPlan, plan_lightmap, write_lightmap
from .presets import bake_settings, lightmap_settings
from .settings import UNGROUPED, UserSettings, light_group_output
from .writeback import check_attribute_name_free, write_radiosity_mesh, write_vertex_colors

@dataclass
class Job:
    """A bake under way: the exported scene, the user's settings and the core's made from them, where lightmap
    files go ("" = pack into the .blend), the light groups written apart, and what the solve produced (with
    ``groups``, each light group's solution)."""

    export: Export
    settings: BakeSettings
    user: UserSettings
    lightmap_folder: str
    lightmap_settings: LightmapSettings | None = None
    lightmap_plan: LightmapPlan | None = None
    light_groups: tuple[str, ...] = ()
    started: float = field(default_factory=time.perf_counter)
    solution: object = None
    groups: dict = field(default_factory=dict)
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
    job.light_groups = _light_groups(job)
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


def _light_groups(job: Job) -> tuple[str, ...]:
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
                  job.settings.threads)


def _fit_to_memory(job: Job, limit_gb: float) -> None:
    """Estimate the bake's memory before the heavy work; coarsen the elements if that makes it fit (with a
    warning), or refuse the bake (core.memory.MemoryLimitError) if nothing does."""
    scene, plan = job.export.scene, job.lightmap_plan
    covered, image = 0, 0
    if plan is not None:
        width, height = plan.layout.width, plan.layout.height
        covered = max((int(uv_area(corner_uv) * width * height) for _, corner_uv in plan.page_triangles), default=0)
        image = width * height * len(plan.page_triangles)
    asked = job.settings.element_size_m
    size, estimate = fit_to_memory(scene.triangles[~scene.casts_only], asked, limit_gb, covered, image,
                                   job.settings.threads)
    job.memory = {"limit_gb": limit_gb, "estimated_gb": round(estimate.peak_bytes / GIB, 2),
                  "steps_gb": {name: round(value / GIB, 2) for name, value in estimate.steps.items()}}
    if size != asked:
        job.settings = replace(job.settings, element_size_m=size, patch_size_m=max(job.settings.patch_size_m, size),
                               min_element_size_m=job.settings.min_element_size_m * size / asked)
        job.warnings.append(f"Elements are {size / asked:.2g} times the quality's size ({size:.3g} m instead of "
                            f"{asked:.3g} m) so that the bake fits the memory limit of {limit_gb:g} GiB (about "
                            f"{estimate.peak_bytes / GIB:.1f} GiB now); raise the limit for finer indirect light.")


def solve(job: Job, progress, cancelled) -> None:
    """The solve and the lightmap texels; an allocation that fails anyway (the estimate is not a promise) becomes
    a MemoryLimitError naming the limit to lower."""
    try:
        _solve(job, progress, cancelled)
    except MemoryError:
        job.solution, job.lightmaps = None, []
        raise MemoryLimitError(
            f"The bake ran out of memory (estimated {job.memory.get('estimated_gb', 0):g} GiB, limit "
            f"{job.memory.get('limit_gb', 0):g} GiB): set a lower memory limit (--max-memory-gb) so that it "
            "adapts, lower the quality or the lightmap's texel density, or close other programs.") from None


def _solve(job: Job, progress, cancelled) -> None:
    job.solution = bake(job.export.scene, job.settings, progress, cancelled)
    if job.light_groups:
        job.groups = bake_light_groups(job.solution, job.settings, progress, cancelled)
    plan = job.lightmap_plan
    if plan is not None:
        job.lightmaps = [bake_lightmap(job.solution, scene_triangle, corner_uv, plan.layout.width,
                                       plan.layout.height, job.lightmap_settings, progress, cancelled,
                                       job.groups or None)
                         for scene_triangle, corner_uv in plan.page_triangles]


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
    warnings = list(job.export.warnings) + job.warnings + list(job.solution.warnings)
    group_files = {group: [] for group in job.light_groups}
    if job.lightmap_plan is not None:  # first: its files are what can still fail, before the .blend changes
        entries, more = write_lightmap(job.lightmap_plan, [page.light for page in job.lightmaps], _metadata(job),
                                       job.lightmap_folder, staged)
        warnings += job.lightmap_plan.warnings + more
        for group in job.light_groups:
            group_entries, more = write_lightmap(job.lightmap_plan.for_light_group(group),
                                                 [page.groups[group] for page in job.lightmaps], _metadata(job),
                                                 job.lightmap_folder, staged)
            group_files[group] = sorted({entry["image"] for entry in group_entries})
            warnings += more
    if job.user.vertex_colors:
        objects, more = write_vertex_colors(job.export, job.solution, job.user, job.groups or None)
        warnings += more
    objects = _merge(objects, entries)
    if job.user.create_radiosity_mesh:
        obj = write_radiosity_mesh(job.solution, job.user.attribute_name)
        objects.append({"name": obj.name, "color_attribute": job.user.attribute_name, "uv_map": None, "image": None,
                        "resolution": None})
    solution = job.solution
    report = {
        "objects": objects,
        "seconds": time.perf_counter() - job.started,
        "timings": solution.seconds,
        "elements": solution.element_count,
        "solve": solution.counts,
        "residual": solution.residual,
        "rays": solution.rays_cast,
        "ray_backend": backend_name(),
        "dropped_triangles": job.export.scene.dropped_triangles,
        "settings": job.settings.as_dict(),
        "memory": job.memory,
        "units": "irradiance / pi (Cycles Diffuse bake, Direct + Indirect, no Color), scene-linear",
        "warnings": warnings,
    }
    if job.light_groups:
        report["light_groups"] = [_group_entry(job, group, group_files[group]) for group in job.light_groups]
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
            "color_attribute": light_group_output(job.user.attribute_name, group) if job.user.vertex_colors else None,
            "timings": job.groups[group].seconds}


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
