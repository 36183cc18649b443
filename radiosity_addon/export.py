"""Export what Blender renders into a core.Scene: evaluated meshes, materials, lights and the world.

Geometry comes from the evaluated depsgraph (modifiers applied, instances and linked duplicates included) through
foreach_get, in world space. A curve, surface, text or metaball object is listed twice by the depsgraph: as
itself and as an instance of its own evaluated mesh; as Cycles does, only the mesh is read, so that its surface is
not exported twice (two coincident copies, each on the other's plane, would bake and reflect as black). Objects
disabled in renders are skipped; an object's Radiosity mode can exclude it or make it "shadow only" (casts
shadows, is not baked). Light and emission conventions: docs/units.md.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field, replace

import bpy
import numpy as np

from ..core import AreaLight, Material, PointLight, Scene, SceneError, SpotLight, SunLight, World
from ..core.scene import TERMINATOR_GEOMETRY_OFFSET
from ..core.bsdf import principled_reflectance
from ..core.texture import ReflectanceTexture

GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}
TYPE_NAMES = {"CURVE": "curve", "SURFACE": "surface", "META": "metaball", "FONT": "text"}
TEXTURE_MAX_SIDE = 256
DEFAULT_MATERIAL = Material("(no material)", (0.8, 0.8, 0.8))


@dataclass
class OriginalCorners:
    """The corners of an original mesh, world space: (loops, 3) points, unit shading normals, and the centroid
    of each corner's face (core.vertex_light.projected_points)."""

    points: np.ndarray
    normals: np.ndarray
    face_centroids: np.ndarray


@dataclass
class ExportedObject:
    """Where one object instance's triangles sit in the exported scene.

    first_triangle / triangle_count: its range in the scene's input triangles; corner_loops / corner_vertices:
    (t, 3) loop and vertex of each triangle corner in the evaluated mesh; writable: a real (not instanced) mesh
    object that is baked; same_topology: its evaluated mesh has the original mesh's loops, so values map loop to loop;
    loop_count: the original mesh's loops; original_corners: those loops' corners where a writable object's
    modifiers changed its topology (so that they are lit without bpy, in the bake's worker thread);
    lightmap_scale: the object's Lightmap Scale (its texel density over the scene's).
    """

    name: str
    mesh_name: str
    first_triangle: int
    triangle_count: int
    corner_loops: np.ndarray
    corner_vertices: np.ndarray
    writable: bool
    same_topology: bool
    loop_count: int
    original_corners: OriginalCorners | None = None
    lightmap_scale: float = 1.0


@dataclass
class Export:
    """The core scene, where each object sits in it, and the (T, 3, 3) triangles as exported (before the scene
    dropped zero-area ones; ExportedObject ranges index these)."""

    scene: Scene
    objects: list[ExportedObject]
    input_triangles: np.ndarray
    warnings: list[str] = field(default_factory=list)

    def scene_index_of_input(self) -> np.ndarray:
        """Input triangle -> scene triangle (-1 where the scene dropped a zero-area triangle)."""
        kept = np.full(len(self.input_triangles), -1)
        kept[self.scene.triangle_source] = np.arange(len(self.scene.triangle_source))
        return kept


RADIOSITY_MESH_TAG = "radiosity_mesh"  # marks the Radiosity Mesh a bake wrote: a copy of the surfaces, not exported

# Per-triangle arrays of a core.Scene, gathered object by object; the first three hold a value per corner.
CORNER_COLUMNS = ("triangles", "triangle_uv", "corner_normals")
COLUMNS = CORNER_COLUMNS + ("material_index", "casts_only", "object_index", "terminator_offset")


def export_scene(context) -> Export:
    """Read the evaluated scene; raises core.SceneError (naming the item) for what the core refuses."""
    depsgraph = context.evaluated_depsgraph_get()
    materials = _Materials()
    groups = _LightGroups(context.view_layer, materials.warnings)
    columns = {name: [] for name in COLUMNS}
    objects, lights, names, unmeshed, meshed, unbaked = [], [], [], set(), set(), {}
    first_triangle = 0
    for instance in depsgraph.object_instances:
        evaluated = instance.object
        original = evaluated.original
        owner = instance.parent.original if instance.is_instance and instance.parent else original
        if owner.hide_render or original.hide_render or original.get(RADIOSITY_MESH_TAG):
            continue
        if evaluated.type == "LIGHT":
            lights.append(_light(evaluated, np.array(instance.matrix_world), groups.of(original)))
            continue
        instanced = instance.is_instance and owner != original  # not a curve's, text's or metaball's own mesh
        mode = _object_setting(owner if instanced else original, "mode", "BAKE")
        if evaluated.type not in GEOMETRY_TYPES or mode == "EXCLUDE":
            continue
        if evaluated.type != "MESH":  # its surface comes as an instance of its own mesh, if it has one
            if not instance.is_instance:
                unmeshed.add(original.name)
            continue
        part = _mesh_triangles(evaluated, np.array(instance.matrix_world), materials, groups.of(original))
        if part is None:
            if not instance.is_instance:
                unmeshed.add(original.name)
            continue
        meshed.add(original.name)
        loops, vertices = part.pop("loops"), part.pop("vertices")
        count = len(loops)
        name = original.name if not instanced else f"{original.name} (instance of {owner.name})"
        writable = not instance.is_instance and original.type == "MESH" and mode == "BAKE"
        source = _linked(original) if writable else ""
        if source:
            writable = False
            materials.warnings.append(f"Object '{original.name}' is linked from {source}: it lights the scene but "
                                      "its bake cannot be saved in this file (make it local to bake it).")
        elif not writable and mode == "BAKE":
            kind = _unbaked_kind(original, instanced)
            unbaked[owner.name, kind] = unbaked.get((owner.name, kind), 0) + 1
        same = _same_topology(evaluated, original)
        objects.append(ExportedObject(
            name=original.name, mesh_name=original.data.name if original.type == "MESH" else "",
            first_triangle=first_triangle, triangle_count=count, corner_loops=loops,
            corner_vertices=vertices, writable=writable, same_topology=same,
            loop_count=len(original.data.loops) if original.type == "MESH" else 0,
            original_corners=None if same or not writable else original_corners(original),
            lightmap_scale=_object_setting(original, "lightmap_scale", 1.0)))
        names.append(name)
        first_triangle += count
        part.update(casts_only=np.full(count, mode == "SHADOW_ONLY"), object_index=np.full(count, len(names) - 1),
                    terminator_offset=np.full(count, _terminator_offset(original)))
        for key, value in part.items():
            columns[key].append(value)
    materials.warnings += [f"Object '{name}' has no faces: it is not baked." for name in sorted(unmeshed - meshed)]
    materials.warnings += [_unbaked_warning(name, kind, count) for (name, kind), count in sorted(unbaked.items())]
    materials.warnings += [f"Library '{library.filepath}' is missing: the objects linked from it are not in the "
                           "bake (relink it: File > External Data > Find Missing Files)." for library in
                           bpy.data.libraries if not os.path.isfile(bpy.path.abspath(library.filepath))]
    if objects:
        _add_emitter_backs(columns, names, materials.list)
    nothing = {"triangles": np.zeros((0, 3, 3)), "material_index": np.zeros(0, dtype=int)}
    arrays = {key: np.concatenate(value) for key, value in columns.items() if value} or nothing
    scene = Scene(materials=materials.list or [DEFAULT_MATERIAL], lights=lights,
                  world=_world(context.scene, materials.warnings, groups), object_names=names, **arrays)
    export = Export(scene, objects, arrays["triangles"], materials.warnings)
    kept = export.scene_index_of_input() >= 0
    export.warnings += [f"Object '{item.name}': none of its {item.triangle_count} faces has any area (a scale of 0, "
                        "or its vertices merged): it is not baked." for item in objects
                        if not kept[item.first_triangle:item.first_triangle + item.triangle_count].any()]
    return export


def _add_emitter_backs(columns: dict, names: list[str], materials: list[Material]) -> None:
    """Cycles' mesh lights emit from both faces: append a flipped copy of every emissive triangle (after all
    objects' ranges, as one extra unwritable part) so the back face shoots too."""
    emissive = np.array([max(m.emitted_radiance) > 0 for m in materials] or [False])
    back = emissive[np.concatenate(columns["material_index"])] & ~np.concatenate(columns["casts_only"])
    if not back.any():
        return
    names.append("(back faces of emitters)")
    flipped = {key: np.concatenate(columns[key])[back] for key in COLUMNS}
    for key in CORNER_COLUMNS:
        flipped[key] = flipped[key][:, ::-1]
    flipped["corner_normals"] = -flipped["corner_normals"]
    flipped["object_index"] = np.full(int(back.sum()), len(names) - 1)
    for key, value in flipped.items():
        columns[key].append(value)


def make_linked_local(context) -> list[str]:
    """Make the rendered mesh objects this file cannot save changes to local, with their meshes (Blender's Make
    Local), so that they hold their bake; returns a note per object."""
    notes = []
    for obj in [o for o in context.scene.objects if o.type == "MESH" and not o.hide_render and _linked(o)]:
        source = _linked(obj)
        if obj.library is not None:
            obj = obj.make_local()
        if obj.data.library is not None or obj.data.override_library is not None:
            obj.data = obj.data.make_local()
        notes.append(f"Object '{obj.name}' was linked from {source}: made local, with its mesh, to hold its bake.")
    return notes


def _linked(obj) -> str:
    """Where an object's own data comes from when this file cannot save changes to it (a linked library, or a
    library override of its mesh); "" when it is local."""
    for block in (obj, obj.data):
        if block.library is not None:
            return f"the library '{block.library.filepath}'"
        if block.override_library is not None and block.override_library.reference.library is not None:
            return f"the library '{block.override_library.reference.library.filepath}' (a library override)"
    return ""


def _terminator_offset(obj) -> float:
    """The object's Shadow Terminator Geometry Offset (Object properties > Shading): on its Cycles settings in
    Blender 4.2, on the object itself in Blender 5."""
    for owner in (obj, getattr(obj, "cycles", None)):
        if hasattr(owner, "shadow_terminator_geometry_offset"):
            return float(owner.shadow_terminator_geometry_offset)
    return TERMINATOR_GEOMETRY_OFFSET


def local_by_name(blocks) -> dict:
    """This file's own data-blocks of a bpy.data collection (objects, meshes), by name. The collection's own
    lookup by name is a linear search: a bake that visits each of 10,000 objects builds this map once instead."""
    return {block.name: block for block in blocks if block.library is None}


def _unbaked_kind(original, instanced: bool) -> str:
    """Why a part of the scene that lights it holds no bake: 'instances' of other objects (collection instances,
    particles), 'geometry' instanced by its own geometry nodes, or the type of a non-mesh object (CURVE, FONT...)."""
    if instanced:
        return "instances"
    return "geometry" if original.type == "MESH" else original.type


def _unbaked_warning(name: str, kind: str, count: int) -> str:
    """One line for an object whose surface lights the scene but cannot hold baked light, with how to bake it."""
    if kind == "instances":
        return (f"Object '{name}': its {count} instance(s) of other objects light the scene but cannot hold baked "
                "light (Object > Apply > Make Instances Real to bake them).")
    if kind == "geometry":
        return (f"Object '{name}': its {count} geometry-node instance(s) light the scene but cannot hold baked "
                "light (add a Realize Instances node to its node tree to bake them).")
    return (f"Object '{name}' is a {TYPE_NAMES[kind]} object: it lights the scene but cannot hold baked light "
            "(Object > Convert > Mesh to bake it).")


def _object_setting(obj, name: str, default):
    """The object's Radiosity property ``name`` (RadiosityObjectSettings), or ``default`` where it has none."""
    return getattr(getattr(obj, "radiosity", None), name, default)


def _same_topology(evaluated, original) -> bool:
    if original.type != "MESH":
        return False
    mesh = evaluated.data
    return len(mesh.loops) == len(original.data.loops) and len(mesh.polygons) == len(original.data.polygons)


def _mesh_triangles(evaluated, matrix: np.ndarray, materials: "_Materials", light_group: str) -> dict | None:
    """An evaluated object's triangles as Scene columns: world-space "triangles" (t, 3, 3), "corner_normals"
    (t, 3, 3), global "material_index" (t,) (its emissive materials in the object's ``light_group``), each
    corner's "triangle_uv" in its material's texture (t, 3, 2), and its "loops" and "vertices" (t, 3) in the
    evaluated mesh; None without faces."""
    mesh = evaluated.to_mesh()
    try:
        corners, loops = loop_triangles(mesh)
        if len(corners) == 0:
            return None
        world = world_positions(mesh, matrix)
        normals = world_corner_normals(mesh, matrix)
        slot = np.empty(len(corners), dtype=np.int32)
        mesh.loop_triangles.foreach_get("material_index", slot)
        table = np.array([materials.index(s.material, light_group) for s in evaluated.material_slots] or
                         [materials.index(None)])
        material = table[np.clip(slot, 0, len(table) - 1)]
        uv = _texture_uvs(mesh, material, loops, materials.list)
    finally:
        evaluated.to_mesh_clear()
    if np.linalg.det(matrix[:3, :3]) < 0:  # mirrored: keep the winding consistent with Blender's normals
        corners, loops, uv = corners[:, ::-1], loops[:, ::-1], uv[:, ::-1]
    return {"triangles": world[corners], "corner_normals": normals[loops], "material_index": material,
            "triangle_uv": uv, "loops": loops, "vertices": corners}


def loop_triangles(mesh) -> tuple[np.ndarray, np.ndarray]:
    """A mesh's triangulation: (t, 3) vertex and (t, 3) loop indices of each triangle's corners."""
    mesh.calc_loop_triangles()
    count = len(mesh.loop_triangles)
    vertices, loops = np.empty(count * 3, dtype=np.int32), np.empty(count * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", vertices)
    mesh.loop_triangles.foreach_get("loops", loops)
    return vertices.reshape(-1, 3), loops.reshape(-1, 3)


def original_corners(obj) -> OriginalCorners:
    """The corners of a mesh object's original mesh (before modifiers), world space."""
    mesh, matrix = obj.data, np.array(obj.matrix_world)
    vertex = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", vertex)
    centres, start, total = (np.empty(len(mesh.polygons) * width, dtype=kind) for width, kind in
                             ((3, np.float32), (1, np.int64), (1, np.int64)))
    for name, values in (("center", centres), ("loop_start", start), ("loop_total", total)):
        mesh.polygons.foreach_get(name, values)
    order = np.argsort(start)  # a polygon's loops are contiguous from its loop_start
    polygon_of_loop = np.repeat(order, total[order])
    centres = centres.reshape(-1, 3).astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
    return OriginalCorners(world_positions(mesh, matrix)[vertex], world_corner_normals(mesh, matrix),
                           centres[polygon_of_loop])


def world_positions(mesh, matrix: np.ndarray) -> np.ndarray:
    """(v, 3) world-space vertex positions, m: the mesh's coordinates through the 4 x 4 object matrix."""
    positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", positions)
    return positions.reshape(-1, 3).astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3]


def world_corner_normals(mesh, matrix: np.ndarray) -> np.ndarray:
    """(loops, 3) unit world-space shading normal of every face corner (smooth shading, sharp edges and custom
    normals as Blender computes them), through the inverse transpose of the object matrix."""
    normals = np.empty(len(mesh.loops) * 3, dtype=np.float32)
    mesh.corner_normals.foreach_get("vector", normals)
    world = normals.reshape(-1, 3).astype(np.float64) @ np.linalg.pinv(matrix[:3, :3])  # a 0 scale flattens
    return world / np.maximum(np.linalg.norm(world, axis=1, keepdims=True), 1e-12)


def _texture_uvs(mesh, material: np.ndarray, loops: np.ndarray, materials: list[Material]) -> np.ndarray:
    """(t, 3, 2) UVs of each triangle corner in the UV map its material's texture reads (NaN where there is no
    such UV map or no texture: those triangles reflect the material's mean colour)."""
    uv = np.full(loops.shape + (2,), np.nan)
    for index in np.unique(material):
        texture = materials[index].texture
        if texture is None:
            continue
        layer = mesh.uv_layers.get(texture.uv_map) if texture.uv_map else \
            next((l for l in mesh.uv_layers if l.active_render), None)
        if layer is None:
            continue
        loop_uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
        layer.data.foreach_get("uv", loop_uv)
        rows = material == index
        uv[rows] = loop_uv.reshape(-1, 2)[loops[rows]]
    return uv


class _Materials:
    """Blender materials read once each into core Materials, with a warning for node setups we cannot read."""

    def __init__(self):
        self.list: list[Material] = []
        self.warnings: list[str] = []
        self._index: dict[str, int] = {}

    def index(self, material, light_group: str = "") -> int:
        """The material's index; an emissive one's in ``light_group`` (the emitting object's) has its own."""
        key = material.name if material is not None else ""
        if key not in self._index:
            self._index[key] = len(self.list)
            self.list.append(read_material(material, self.warnings))
        first = self.list[self._index[key]]
        if not light_group or max(first.emitted_radiance) <= 0:
            return self._index[key]
        if (key, light_group) not in self._index:
            self._index[key, light_group] = len(self.list)
            self.list.append(replace(first, light_group=light_group))
        return self._index[key, light_group]


class _LightGroups:
    """Cycles' light groups (View Layer > Light Groups): the group of a lamp, an emissive object or the world
    (their ``lightgroup``), "" for none or for a name the view layer does not define (with a warning: Cycles
    gives no pass to such a name either)."""

    def __init__(self, view_layer, warnings: list[str]):
        self.defined = {group.name for group in getattr(view_layer, "lightgroups", ())}
        self.warnings = warnings

    def of(self, owner) -> str:
        name = getattr(owner, "lightgroup", "") or ""
        if name and name not in self.defined:
            self.warnings.append(f"'{owner.name}' is in light group '{name}', which View Layer > Light Groups does "
                                 "not list: its light counts as ungrouped.")
            return ""
        return name


def read_material(material, warnings: list[str]) -> Material:
    """Reflectance and emitted radiance from the node tree.

    Principled BSDF: its hemispherical reflectance from Base Color, Roughness, Metallic, IOR, Specular IOR Level
    and Transmission (core.bsdf; an Image Texture feeding Base Color becomes a texture the core averages over each
    element's footprint), Emission Color x Emission Strength; Diffuse BSDF: Color; Emission: Color x Strength (no
    reflection). Anything else: the material's viewport colour, with a warning naming the material.
    """
    if material is None:
        return DEFAULT_MATERIAL
    fallback = Material(material.name, tuple(material.diffuse_color[:3]))
    tree = material.node_tree if getattr(material, "use_nodes", True) else None
    surface = _surface_node(tree)
    if surface is None:
        warnings.append(f"Material '{material.name}': no node setup with a surface shader; using its viewport "
                        "colour.")
        return fallback
    if surface.type == "BSDF_PRINCIPLED":
        base, texture = _colour(surface.inputs["Base Color"], material.name, warnings)
        offset, scale = _principled_reflectance(surface, material.name, warnings)
        emission = np.array(surface.inputs["Emission Color"].default_value[:3]) * \
            surface.inputs["Emission Strength"].default_value
        if texture is not None:
            texture = ReflectanceTexture(offset + scale * texture.pixels, texture.uv_map)
        return Material(material.name, tuple(offset + scale * np.array(base)), tuple(emission), texture)
    if surface.type == "BSDF_DIFFUSE":
        base, texture = _colour(surface.inputs["Color"], material.name, warnings)
        return Material(material.name, base, texture=texture)
    if surface.type == "EMISSION":
        emission = np.array(surface.inputs["Color"].default_value[:3]) * surface.inputs["Strength"].default_value
        return Material(material.name, (0.0, 0.0, 0.0), tuple(emission))
    warnings.append(f"Material '{material.name}': the '{surface.name}' shader is not understood; using its "
                    "viewport colour as a diffuse reflectance.")
    return fallback


def _principled_reflectance(surface, material_name: str, warnings: list[str]) -> tuple[float, float]:
    """(offset, scale): the Principled BSDF's hemispherical reflectance is offset + scale x base colour
    (core.bsdf: the specular layer's Fresnel reflection counts, metals reflect their colour)."""
    value = {name: _scalar(surface.inputs[name], material_name, warnings) for name in
             ("Roughness", "Metallic", "IOR", "Specular IOR Level", "Transmission Weight")}
    if value["Transmission Weight"] > 0:
        warnings.append(f"Material '{material_name}': transmitted light is not followed; only the reflection of its "
                        "surface counts.")
    return principled_reflectance(value["Roughness"], value["Metallic"], value["IOR"], value["Specular IOR Level"],
                                  value["Transmission Weight"])


def _scalar(socket, material_name: str, warnings: list[str]) -> float:
    if socket.is_linked:
        warnings.append(f"Material '{material_name}': '{socket.name}' is driven by a '{socket.links[0].from_node.name}'"
                        " node that is not read; using the socket's own value.")
    return float(socket.default_value)


def _surface_node(tree):
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output] or \
              [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    if not outputs or not outputs[0].inputs["Surface"].is_linked:
        return None
    return outputs[0].inputs["Surface"].links[0].from_node


def _colour(socket, material_name: str, warnings: list[str]):
    """(mean RGB, ReflectanceTexture or None) of a colour socket: its value, or an Image Texture feeding it
    (read through its UV map; a texture coordinate setup we cannot follow gives the image mean with a warning)."""
    if not socket.is_linked:
        return tuple(socket.default_value[:3]), None
    source = socket.links[0].from_node
    if source.type == "TEX_IMAGE" and source.image is not None:
        if not source.image.has_data and tuple(source.image.size) == (0, 0):
            raise SceneError(f"Material '{material_name}': the image '{source.image.name}' cannot be read (file "
                             f"'{source.image.filepath}'; missing or not an image): fix its path (File > External "
                             "Data > Find Missing Files) or remove the Image Texture node.")
        pixels = image_pixels(source.image)
        mean = tuple(pixels.reshape(-1, 3).mean(axis=0))
        vector = source.inputs["Vector"]
        if not vector.is_linked:
            return mean, ReflectanceTexture(pixels)
        if vector.links[0].from_node.type == "UVMAP":
            return mean, ReflectanceTexture(pixels, vector.links[0].from_node.uv_map)
        warnings.append(f"Material '{material_name}': the image '{source.image.name}' is mapped through a "
                        f"'{vector.links[0].from_node.name}' node that is not read; using the image's mean colour.")
        return mean, None
    warnings.append(f"Material '{material_name}': '{socket.name}' is driven by a '{source.name}' node that is not "
                    "read; using the socket's own colour.")
    return tuple(socket.default_value[:3]), None


def image_pixels(image, max_side: int = TEXTURE_MAX_SIDE) -> np.ndarray:
    """(h, w, 3) linear RGB of an image (sRGB byte images linearised), box-filtered down to at most ``max_side``
    texels a side: elements are far larger than texels, and a 4k image would cost 400 MB as float64."""
    width, height = image.size
    pixels = np.empty(width * height * image.channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    rgb = pixels.reshape(height, width, image.channels)[..., :3].astype(np.float64)
    if image.channels == 1:
        rgb = np.repeat(pixels.reshape(height, width, 1), 3, axis=2).astype(np.float64)
    if not image.is_float and image.colorspace_settings.name == "sRGB":
        rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    factor = max(1, int(np.ceil(max(width, height) / max_side)))
    if factor > 1:
        h, w = height // factor * factor, width // factor * factor
        rgb = rgb[:h, :w].reshape(h // factor, factor, w // factor, factor, 3).mean(axis=(1, 3))
    return rgb


def _light(obj, matrix: np.ndarray, light_group: str):
    data = obj.data
    position = tuple(matrix[:3, 3])
    direction = tuple(-matrix[:3, 2] / np.linalg.norm(matrix[:3, 2]))
    color = tuple(data.color)
    if data.type == "SUN":
        return SunLight(obj.name, direction, data.energy, color, data.angle, light_group)
    soft = bool(getattr(data, "use_soft_falloff", False))
    if data.type == "SPOT":
        return SpotLight(obj.name, position, direction, data.energy, data.spot_size, data.spot_blend, color,
                         data.shadow_soft_size, soft, light_group)
    if data.type == "AREA":
        scale_x, scale_y = np.linalg.norm(matrix[:3, 0]), np.linalg.norm(matrix[:3, 1])
        size_y = data.size_y * scale_y if data.shape in ("RECTANGLE", "ELLIPSE") else None
        return AreaLight(obj.name, position, direction, data.energy, data.shape, data.size * scale_x, size_y,
                         tuple(matrix[:3, 0]), color, light_group)
    return PointLight(obj.name, position, data.energy, color, data.shadow_soft_size, soft, light_group)


def _world(scene, warnings: list[str], groups: _LightGroups) -> World:
    world = scene.world
    if world is None:
        return World()
    return World(_world_radiance(world, warnings), groups.of(world))


def _world_radiance(world, warnings: list[str]) -> tuple:
    """The world's constant background radiance: colour x strength of its Background node."""
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        return tuple(world.color)
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output]
    if not outputs or not outputs[0].inputs["Surface"].is_linked:
        return (0.0, 0.0, 0.0)
    background = outputs[0].inputs["Surface"].links[0].from_node
    if background.type != "BACKGROUND":
        warnings.append(f"World '{world.name}': the '{background.name}' node is not read; no world light.")
        return (0.0, 0.0, 0.0)
    colour = background.inputs["Color"]
    if colour.is_linked:
        warnings.append(f"World '{world.name}': a texture drives the background colour; using the socket's own "
                        "colour.")
    strength = background.inputs["Strength"].default_value
    return tuple(np.array(colour.default_value[:3]) * strength)
