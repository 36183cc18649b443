"""Write a solution back into the .blend: colour attributes on the original meshes and the radiosity mesh object.

Only what this add-on made is ever replaced: a mesh remembers the name of the attribute we wrote
(``mesh["radiosity_attribute"]``, and the light groups' in ``mesh["radiosity_group_attributes"]``) and the radiosity
mesh object carries ``obj["radiosity_mesh"]``. Existing UV maps,
materials and other colour attributes are never touched. The writing runs in the main thread, after the solve, so
a failed or cancelled bake has changed nothing; the light of the mesh corners is traced before, in the solve
(``objects_loop_light``, which reads no bpy data).
"""
from __future__ import annotations

import bpy
import numpy as np

from ..core import BakeCancelled, SceneError
from ..core.vertex_light import corner_light, projected_points
from .export import RADIOSITY_MESH_TAG, Export, ExportedObject, local_by_name
from .settings import UserSettings, light_group_output

OWNED_ATTRIBUTE = "radiosity_attribute"
OWNED_GROUP_ATTRIBUTES = "radiosity_group_attributes"
PROJECTION_REACH = 0.05  # of the scene's size: how far a corner of a modified mesh looks for its baked surface
CORNERS_PER_BATCH = 1 << 14  # mesh corners lit per call when many objects are baked to colour attributes


def check_attribute_name_free(export: Export, name: str) -> None:
    """Refuse, before any work, to overwrite a colour attribute the user made with the same name."""
    meshes = local_by_name(bpy.data.meshes)
    for item in export.objects:
        mesh = meshes.get(item.mesh_name) if item.writable else None
        if mesh is not None and name in mesh.color_attributes and name not in _owned(mesh):
            raise SceneError(f"Mesh '{mesh.name}' (object '{item.name}') already has a colour attribute '{name}' "
                             "that this add-on did not make; choose another attribute name.")


def _owned(mesh) -> set[str]:
    """The colour attributes this add-on wrote on the mesh."""
    return {mesh.get(OWNED_ATTRIBUTE)} | set(mesh.get(OWNED_GROUP_ATTRIBUTES, ()))


def write_vertex_colors(export: Export, user: UserSettings, light_of,
                        light_groups=()) -> tuple[list[dict], list[str]]:
    """Write the light of every baked object into its mesh's colour attribute (user.attribute_name, per corner or
    per vertex: user.vertex_domain); ``light_of(item)`` gives an object's (loops, 3) light per mesh loop and
    that of each of the ``light_groups``, which go into attributes of their own (settings.light_group_output).
    Returns per-object report entries and warnings. An object that shares its mesh with one written before gets
    its own copy of the mesh first (user.own_mesh_copies), as Blender's Make Single User > Object Data does; else
    it keeps the first one's colours, with a warning."""
    written, outputs, warnings, copied = {}, [], [], []
    holders = {item.name for item in colour_holders(export.objects, user.own_mesh_copies)}
    objects, meshes = local_by_name(bpy.data.objects), local_by_name(bpy.data.meshes)
    for item in export.objects:
        if not item.writable:
            continue
        obj, mesh = objects[item.name], meshes[item.mesh_name]
        if item.name not in holders:
            warnings.append(f"Object '{item.name}' shares mesh '{mesh.name}' with '{written[mesh.name]}': its colour "
                            "attribute holds the light of the first of them.")
            continue
        entry = {"name": item.name, "color_attribute": user.attribute_name, "uv_map": None, "image": None,
                 "resolution": None}
        if mesh.name in written:
            obj.data = mesh = mesh.copy()
            entry["own_mesh_copy"] = mesh.name
            copied.append(item.name)
        light, groups = light_of(item)
        _write_attribute(mesh, user.attribute_name, light, user.vertex_domain)
        for group in light_groups:
            _write_attribute(mesh, light_group_output(user.attribute_name, group), groups[group], user.vertex_domain,
                             group=True)
        if light_groups:
            entry["light_group_attributes"] = [light_group_output(user.attribute_name, g) for g in light_groups]
        written[mesh.name] = item.name
        outputs.append(entry)
    if copied:
        names = ", ".join(f"'{name}'" for name in copied[:5]) + (", ..." if len(copied) > 5 else "")
        warnings.append(f"{len(copied)} object(s) that shared a mesh got their own copy of it, to hold their own "
                        f"light (Make Single User; Undo reverses it): {names}.")
    return outputs, warnings


def colour_holders(objects: list[ExportedObject], own_mesh_copies: bool) -> list[ExportedObject]:
    """The writable objects whose own light a vertex-colour bake writes: all of them with ``own_mesh_copies``
    (each sharer gets its own mesh), else the first of the objects that share a mesh (the others show its
    colours, so their corners are not lit)."""
    writable = [item for item in objects if item.writable]
    if own_mesh_copies:
        return writable
    first = {}
    for item in writable:
        first.setdefault(item.mesh_name, item)
    return list(first.values())


def objects_loop_light(items: list[ExportedObject], solution, kept: np.ndarray, method: str,
                       gather_samples_per_edge: int, lightings: list, progress, cancelled) -> dict[str, np.ndarray]:
    """(G, loops, 3) light per loop of each object's original mesh, by name, for each of the G ``lightings``
    (``solution`` or parts of its light; core.vertex_light.corner_light: direct light traced at each corner,
    indirect light by ``method``, the gather's rays shared). No bpy: runs in the bake's worker thread. Corners
    are lit for many objects at once, at least CORNERS_PER_BATCH per call (the last call fewer), so that a level's
    many small props do not each pay a call's fixed work; progress is reported and BakeCancelled raised between
    calls."""
    light, batch, corners = {}, [], 0
    for number, item in enumerate(items, 1):
        batch.append((item, *_surface_corners(item, solution, kept)))
        corners += len(batch[-1][1])
        if corners >= CORNERS_PER_BATCH or number == len(items):
            if cancelled():
                raise BakeCancelled("Bake cancelled while lighting the colour attributes' corners.")
            light.update(_batch_light(batch, solution, method, gather_samples_per_edge, lightings))
            progress(number / len(items), f"Vertex colours: {number} of {len(items)} objects lit")
            batch, corners = [], 0
    return light


def _surface_corners(item: ExportedObject, solution, kept: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An object's corners as (n,) scene triangles, (n, 3) barycentrics and the (n,) loop of each: its solved
    triangles' corners; for a mesh whose modifiers changed its topology, the points where its original corners
    project onto its solved surface (core.vertex_light.projected_points; loops that find none stay black)."""
    triangles = kept[item.first_triangle + np.arange(item.triangle_count)]
    corners = item.original_corners
    if corners is None:
        valid = triangles >= 0
        return (np.repeat(triangles[valid], 3), np.tile(np.eye(3), (int(valid.sum()), 1)),
                item.corner_loops[valid].ravel())
    hit, bary = projected_points(solution, triangles[triangles >= 0], corners.points, corners.normals,
                                 corners.face_centroids, PROJECTION_REACH * solution.scene.size_m)
    found = np.flatnonzero(hit >= 0)
    return hit[found], bary[found], found


def _batch_light(batch: list, solution, method: str, gather_samples_per_edge: int, lightings: list) -> dict:
    """(G, loops, 3) light per loop of each object in ``batch`` (object, scene triangles, barycentrics, loops),
    from one corner_light call; NaN (unsolved) and loops without a corner point are 0."""
    values = corner_light(solution, np.concatenate([triangles for _, triangles, _, _ in batch]),
                          np.concatenate([bary for _, _, bary, _ in batch]), method, gather_samples_per_edge,
                          lightings=lightings)
    light, start = {}, 0
    for item, triangles, _, loops in batch:
        per_loop = np.zeros((len(lightings), item.loop_count, 3))
        per_loop[:, loops] = values[:, start:start + len(triangles)]
        light[item.name], start = np.nan_to_num(per_loop), start + len(triangles)
    return light


def _write_attribute(mesh, name: str, light: np.ndarray, domain: str = "CORNER", group: bool = False) -> None:
    """The colour attribute ``name`` (replacing ours) holding (loops, 3) light per corner, or per vertex the mean of
    its corners (what Cycles bakes into a vertex attribute); remembered as the main one or, ``group``, a light
    group's."""
    existing = mesh.color_attributes.get(name)
    if existing is not None:
        mesh.color_attributes.remove(existing)
    if domain == "POINT":
        vertex = np.empty(len(mesh.loops), dtype=np.int64)
        mesh.loops.foreach_get("vertex_index", vertex)
        count = np.maximum(np.bincount(vertex, minlength=len(mesh.vertices)), 1)
        light = np.stack([np.bincount(vertex, light[:, c], len(mesh.vertices)) for c in range(3)], axis=1)
        light /= count[:, None]
    attribute = mesh.color_attributes.new(name, "FLOAT_COLOR", domain)
    rgba = np.concatenate([light, np.ones((len(light), 1))], axis=1).astype(np.float32)
    attribute.data.foreach_set("color", rgba.ravel())
    if group:
        mesh[OWNED_GROUP_ATTRIBUTES] = sorted(set(mesh.get(OWNED_GROUP_ATTRIBUTES, ())) | {name})
    else:
        mesh[OWNED_ATTRIBUTE] = name


def write_radiosity_mesh(radiosity_mesh: tuple, attribute: str, name: str = "Radiosity Mesh"):
    """A new object holding the adaptive element mesh with its light as a corner colour attribute (``radiosity_mesh``:
    core.solution.Solution.radiosity_mesh's vertices, triangles and corner light); replaces the one a previous bake
    made."""
    for obj in [o for o in bpy.data.objects if o.get(RADIOSITY_MESH_TAG)]:
        mesh = obj.data
        bpy.data.objects.remove(obj)
        if mesh.users == 0:
            bpy.data.meshes.remove(mesh)
    vertices, triangles, corner_light = radiosity_mesh
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices.tolist(), [], triangles.tolist())
    _write_attribute(mesh, attribute, corner_light.reshape(-1, 3))
    obj = bpy.data.objects.new(name, mesh)
    obj[RADIOSITY_MESH_TAG] = True
    bpy.context.scene.collection.objects.link(obj)
    return obj
