"""One bake, in three steps shared by the operator (interactive and execute()) and the command line:

1. ``prepare`` (main thread): export the evaluated scene and check the outputs can be written;
2. ``solve`` (any thread, no bpy): the core solve, with progress and cancel callables;
3. ``apply`` (main thread): write the results and return the report's per-object part.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from ..core import SceneError
from .export import Export, export_scene
from .presets import UserSettings, bake_settings
from .writeback import check_attribute_name_free, write_radiosity_mesh, write_vertex_colors


@dataclass
class Job:
    export: Export
    settings: object
    attribute: str
    create_radiosity_mesh: bool
    started: float = field(default_factory=time.perf_counter)
    solution: object = None


def prepare(context, user: UserSettings, attribute: str, create_radiosity_mesh: bool) -> Job:
    export = export_scene(context)
    settings = bake_settings(user, export.scene.size_m)
    if not any(item.writable for item in export.objects) and not create_radiosity_mesh:
        raise SceneError("Nothing to bake: no visible mesh object is set to 'Bake'.")
    check_attribute_name_free(export, attribute)
    return Job(export, settings, attribute, create_radiosity_mesh)


def solve(job: Job, progress, cancelled) -> None:
    from ..core import bake
    job.solution = bake(job.export.scene, job.settings, progress, cancelled)


def apply(job: Job) -> dict:
    """Write the outputs; returns the report (REPORT.json's contract, docs/design in the README)."""
    objects, warnings = write_vertex_colors(job.export, job.solution, job.attribute)
    if job.create_radiosity_mesh:
        obj = write_radiosity_mesh(job.solution, job.attribute)
        objects.append({"name": obj.name, "color_attribute": job.attribute, "uv_map": None, "image": None,
                        "resolution": None})
    solution = job.solution
    return {
        "objects": objects,
        "seconds": time.perf_counter() - job.started,
        "timings": solution.seconds,
        "elements": solution.element_count,
        "patches": len(solution.state.patches.area_m2),
        "residual": solution.residual,
        "rays": solution.rays_cast,
        "dropped_triangles": job.export.scene.dropped_triangles,
        "settings": job.settings.as_dict(),
        "units": "irradiance / pi (Cycles Diffuse bake, Direct + Indirect, no Color), scene-linear",
        "warnings": job.export.warnings + warnings,
    }
