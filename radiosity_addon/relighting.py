"""Relighting caches: a bake split by light source (core.relight), kept in a file (and in memory for the Blender
session), from which later changes of the lamps' strengths and colours, emission strengths, the world's strength
and light groups are written without baking again (Update Light in the panel, --relight on the command line).

The file holds the sources and their emission when baked, what the transport depends on (core.relight
.TransportKey), the lightmap plan, each source's lightmap pages and light per mesh loop of every baked object, and
the solve's numbers for the report. It is a data-only file (core.data_file): reading one runs nothing it holds,
so a .blend from elsewhere that names a crafted cache gets a refusal, not code run. Its header holds the key, so
that the panel's check of whether the cache still fits the scene reads nothing else.
"""
from __future__ import annotations

import os
from dataclasses import asdict, replace

import bpy

from ..core import OutputError, SceneError
from ..core.atlas import AtlasLayout
from ..core.bake import BakeSettings
from ..core.data_file import data_writer, read_data, read_header
from ..core.lightmap import LightmapSettings
from ..core.relight import TransportKey
from ..core.scene import Source
from ..core.staged_files import StagedFiles
from .export import ExportedObject, OriginalCorners
from .lightmaps import LightmapPlan
from .settings import UserSettings

FORMAT = "radiosity-relight"
VERSION = 3
CLASSES = (Source, BakeSettings, LightmapSettings, LightmapPlan, AtlasLayout, ExportedObject, OriginalCorners)
WHAT = "relighting cache"
# The settings a bake's light depends on, besides what presets.bake_settings makes of them; output names,
# folders, formats and light groups are free to change.
TRANSPORT_SETTINGS = ("quality", "element_size", "patch_size", "adaptive_passes", "residual", "light_samples",
                      "seed", "vertex_domain", "vertex_indirect", "vertex_gather_samples",
                      "own_mesh_copies", "texels_per_metre", "lightmap_resolution", "lightmap_max_size",
                      "lightmap_padding", "lightmap_indirect", "gather_samples", "lightmap_uv_map",
                      "lightmap_existing_uv", "make_local")
SESSION = {}  # absolute path -> the cache last written or read there in this Blender session


def cache_path(setting: str) -> str:
    """The cache file's absolute path; // is the .blend's folder, which an unsaved .blend does not have."""
    if setting.startswith("//") and not bpy.data.filepath:
        raise SceneError("The relighting cache path is relative to the .blend, which is not saved yet: save it, or "
                         "give an absolute path.")
    return os.path.abspath(bpy.path.abspath(setting))


def check_cache_path(setting: str) -> None:
    """Refuse, before the bake, a cache path whose folder cannot be written (OutputError names it)."""
    path = cache_path(setting)
    folder = os.path.dirname(path)
    if not (os.path.isdir(folder) and os.access(folder, os.W_OK)) or os.path.isdir(path):
        raise OutputError(f"Cannot write the relighting cache '{path}' (missing or read-only folder).")


def transport_key(scene, user: UserSettings) -> TransportKey:
    return TransportKey.of(scene, {name: getattr(user, name) for name in TRANSPORT_SETTINGS})


def stage_cache(job, staged: StagedFiles) -> str:
    """Stage the job's relighting cache (its basis by source) in ``staged``; returns the file's path."""
    path = cache_path(job.user.relight_cache)
    pages = [{"groups": page.groups, "covered": page.covered, "moved": page.moved, "texel_count": page.texel_count,
              "indirect": page.indirect} for page in job.lightmaps]
    # The plan without the user's settings; a relight gives it the settings of its own time.
    plan = None if job.lightmap_plan is None else replace(job.lightmap_plan, user=None)
    key = transport_key(job.export.scene, job.user)
    cache = {"sources": job.sources, "light_groups": job.light_groups, "settings": job.settings,
             "lightmap_settings": job.lightmap_settings, "lightmap_plan": plan, "pages": pages,
             "corner_basis": job.corner_basis, "stats": job.stats, "memory": job.memory}
    staged.stage(path, data_writer({"format": FORMAT, "version": VERSION, "key": asdict(key)}, cache, CLASSES))
    SESSION[path] = {**cache, "key": key}
    return path


def load_cache(path: str) -> dict:
    """The cache at ``path`` (from this session's memory when it was written or read here), its "key" a
    TransportKey; SceneError names a file that is missing or not a cache of this version."""
    path = os.path.abspath(path)
    if path not in SESSION or not os.path.isfile(path):
        header, cache = read_data(path, FORMAT, VERSION, WHAT, CLASSES)
        SESSION[path] = {**cache, "key": _key(header, path)}
    return SESSION[path]


def cache_key(path: str) -> TransportKey:
    """The key of the cache at ``path``, read from its header alone (or from this session's memory)."""
    path = os.path.abspath(path)
    if path in SESSION and os.path.isfile(path):
        return SESSION[path]["key"]
    return _key(read_header(path, FORMAT, VERSION, WHAT), path)


def _key(header: dict, path: str) -> TransportKey:
    try:
        return TransportKey(**header["key"])
    except (KeyError, TypeError) as error:
        raise SceneError(f"'{path}' is not a {WHAT} (its header has no key).") from error
