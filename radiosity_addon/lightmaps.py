"""Lightmaps in Blender: plan the atlas from the exported objects (main thread, before the solve), then write the
UV maps and the image after it.

Each baked mesh gets a new UV map (default "Lightmap") made by xatlas; existing UV maps are never changed, and a UV
map of that name that this add-on did not make is refused. Objects that share a mesh (linked duplicates) share its
UV map but get their own part of the atlas: the first user's part is what the UV map holds, the others carry
``obj["radiosity_lightmap_offset"]``, the UV offset of their copy. Each atlas page is an OpenEXR file (saved next
to the .blend, or where asked, or packed into an unsaved .blend) loaded as a Blender image: the first page takes
the image name, page k the name followed by " k"; when there are several, every object carries
``obj["radiosity_lightmap_page"]``, the page its UVs refer to. With ``existing_uv_map`` the objects' own UV map
is baked as it is, each object on the first page where its texels are free.
"""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

import bpy
import numpy as np

from ..core import OutputError, SceneError
from ..core.atlas import (AtlasLayout, AtlasSize, chart_areas, layout_atlas, modifier_uv_problem,
                          overlapping_share, pages_without_overlap, uv_area)
from ..core.geometry import triangle_areas
from ..core.image_file import HALF_MAX, check_image, write_exr, write_png
from ..core.staged_files import StagedFiles
from .export import Export, ExportedObject, local_by_name, loop_triangles, world_positions
from .settings import UserSettings, light_group_output

OWNED_UV = "radiosity_lightmap_uv"
OWNED_IMAGE = "radiosity_lightmap"
OFFSET_PROPERTY = "radiosity_lightmap_offset"
PAGE_PROPERTY = "radiosity_lightmap_page"
SMALL_CHART_TEXELS = 4.0  # an object whose median chart covers fewer texels (2 x 2) gets a warning
SELF_OVERLAP_WARNING = 0.1  # overlapping share of an existing UV map worth a warning (above chart-border slack)
NOTHING_TO_BAKE = "Nothing to bake into a lightmap: no visible mesh object is set to 'Bake'."


@dataclass
class LightmapPlan:
    """The objects and their atlas layout; per page, the solved scene triangles it holds and their UVs; the user's
    settings (settings.UserSettings: UV map and image names, file format); per mesh, the UV map to write ((t, 3)
    loops of the original mesh and their (t, 3, 2) UVs); per object, the UV offset of its copy of a shared mesh's
    block (None for the mesh's first user); the light groups whose pages are written apart too."""

    objects: list[ExportedObject]
    layout: AtlasLayout
    page_triangles: list[tuple[np.ndarray, np.ndarray]]
    user: UserSettings
    mesh_uvs: dict[str, tuple[np.ndarray, np.ndarray]]
    uv_offsets: list[np.ndarray | None]
    chart_texels: list[np.ndarray]
    warnings: list[str] = field(default_factory=list)
    light_groups: tuple[str, ...] = ()

    @property
    def image_names(self) -> list[str]:
        return [page_image_name(self.user.lightmap_image, page) for page in range(self.layout.page_count)]

    def for_light_group(self, group: str) -> LightmapPlan:
        """The same pages under the light group's image name (settings.light_group_output)."""
        return replace(self, user=replace(self.user, lightmap_image=light_group_output(self.user.lightmap_image,
                                                                                       group)))


def page_image_name(image_name: str, page: int) -> str:
    return image_name if page == 0 else f"{image_name} {page + 1}"


def plan_lightmap(context, export: Export, user: UserSettings, size: AtlasSize,
                  light_groups: tuple[str, ...] = ()) -> LightmapPlan:
    """Unwrap and pack every baked mesh object; raises SceneError naming a mesh whose UV map name is taken.
    ``light_groups``: those whose light is written apart too, as pages of their own (LightmapPlan.for_light_group).

    A mesh is unwrapped as its first user renders it when its modifiers keep the topology; otherwise its original
    mesh is unwrapped and the UV map reaches the rendered mesh through the modifiers, as any UV map does (what
    Cycles bakes too). Objects whose modifiers repeat the UVs (Array, Mirror, Solidify), drop or squash them would
    share or lack texels: they get no lightmap, with a warning naming them."""
    if user.lightmap_existing_uv:
        return _plan_on_existing_uv_map(context, export, user, size, light_groups)
    objects = _lightmap_objects(export, user.lightmap_uv_map)
    warnings = []
    while True:
        if not objects:
            raise SceneError(" ".join([NOTHING_TO_BAKE] + warnings))
        layout, mesh_uvs, uv_offsets = _unwrap(export, objects, size)
        rendered_uv = _rendered_uvs(context, objects, layout, mesh_uvs, uv_offsets, user.lightmap_uv_map)
        problems = _uv_problems(export, objects, layout, mesh_uvs, rendered_uv)
        if not problems:
            break
        warnings += [f"Object '{objects[index].name}' gets no lightmap: {problem}; apply them, or bake vertex "
                     "colours." for index, problem in problems.items()]
        objects = [item for index, item in enumerate(objects) if index not in problems]
    charts = _chart_texels(rendered_uv, layout)
    return checked(LightmapPlan(objects, layout, _page_triangles(export, objects, rendered_uv, layout), user,
                                 mesh_uvs, uv_offsets, charts, warnings + _small_chart_warnings(objects, charts),
                                 light_groups))


def _plan_on_existing_uv_map(context, export: Export, user: UserSettings, size: AtlasSize,
                             light_groups: tuple[str, ...]) -> LightmapPlan:
    """The plan for baking onto a UV map the objects already have, as their modifiers carry it to the rendered
    mesh; the UV map is read, never changed. Objects whose UVs would share texels (linked duplicates, meshes each
    unwrapped onto the whole square) get separate pages; all pages have the resolution asked for, or the size the
    density needs for the object that needs most (at most the maximum size)."""
    objects = [item for item in export.objects if item.writable]
    if not objects:
        raise SceneError(NOTHING_TO_BAKE)
    uv_map = user.lightmap_uv_map
    meshes, blender_objects = local_by_name(bpy.data.meshes), local_by_name(bpy.data.objects)
    lacking = [item.name for item in objects if uv_map not in meshes[item.mesh_name].uv_layers]
    if lacking:
        raise SceneError(f"Object(s) {', '.join(map(repr, lacking))} have no UV map '{uv_map}' to bake the "
                         "lightmap onto; add one, or let the bake make a new UV map.")
    depsgraph = context.evaluated_depsgraph_get()
    rendered_uv = [_evaluated_uvs(depsgraph, blender_objects[item.name], item, uv_map) for item in objects]
    dropped = [item.name for item, uv in zip(objects, rendered_uv) if uv is None]
    if dropped:
        raise SceneError(f"The modifiers of {', '.join(map(repr, dropped))} do not keep the UV map "
                         f"'{uv_map}'; apply them, or let the bake make a new UV map.")
    areas_m2 = np.array([_area_m2(export, item) * item.lightmap_scale ** 2 for item in objects])
    areas_uv = np.array([max(uv_area(uv), 1e-12) for uv in rendered_uv])
    side = size.existing_uv_side(areas_m2, areas_uv)
    page = pages_without_overlap(rendered_uv, side, side)
    layout = AtlasLayout(rendered_uv, page, side, side, float(side * np.sqrt(areas_uv.sum() / areas_m2.sum())))
    charts = _chart_texels(rendered_uv, layout)
    warnings = _existing_uv_warnings(objects, rendered_uv, uv_map, side) + _small_chart_warnings(objects, charts)
    return checked(LightmapPlan(objects, layout, _page_triangles(export, objects, rendered_uv, layout), user,
                                 {}, [None] * len(objects), charts, warnings, light_groups))


def _chart_texels(rendered_uv: list[np.ndarray], layout: AtlasLayout) -> list[np.ndarray]:
    """Per object, the area of each chart of its rendered UVs in texels^2 (core.atlas.chart_areas)."""
    return [chart_areas(corner_uv * [layout.width, layout.height]) for corner_uv in rendered_uv]


def _small_chart_warnings(objects, chart_texels: list[np.ndarray]) -> list[str]:
    """One warning per object whose median chart covers under SMALL_CHART_TEXELS texels: its charts hold less
    than a texel's light each, so its lightmap mixes its faces' light with the padding's."""
    warnings = []
    for item, charts in zip(objects, chart_texels):
        if len(charts) and np.median(charts) < SMALL_CHART_TEXELS:
            warnings.append(f"Object '{item.name}': its {len(charts)} lightmap charts are small (median "
                            f"{np.median(charts):.1f} texels, under 2 x 2); raise its Lightmap Scale or the "
                            "Texels per Metre, or bake it to colour attributes.")
    return warnings


def _existing_uv_warnings(objects, rendered_uv, uv_map: str, side: int) -> list[str]:
    """What a user's own UV map does that costs texels: faces outside the 0-1 square, faces on top of others."""
    warnings = []
    for item, corner_uv in zip(objects, rendered_uv):
        if corner_uv.min() < -1e-6 or corner_uv.max() > 1.0 + 1e-6:
            warnings.append(f"Object '{item.name}': its UV map '{uv_map}' reaches outside the 0-1 square; faces "
                            "there get no lightmap texels.")
        share = overlapping_share(corner_uv, side, side)
        if share > SELF_OVERLAP_WARNING:
            warnings.append(f"Object '{item.name}': faces of its UV map '{uv_map}' lie on top of each other "
                            f"({share:.0%} of its UV area), so they share texels.")
    return warnings


def _page_triangles(export: Export, objects, rendered_uv, layout: AtlasLayout) -> list:
    """Per page, the solved scene triangles it holds and their (t, 3, 2) UVs."""
    kept = export.scene_index_of_input()
    pages = [([], []) for _ in range(layout.page_count)]
    for item, corner_uv, page in zip(objects, rendered_uv, layout.page):
        scene_triangle = kept[item.first_triangle + np.arange(item.triangle_count)]
        pages[page][0].append(scene_triangle[scene_triangle >= 0])
        pages[page][1].append(corner_uv[scene_triangle >= 0])
    return [(np.concatenate(triangles), np.concatenate(uvs)) for triangles, uvs in pages]


def checked(plan: LightmapPlan) -> LightmapPlan:
    """The plan; raises SceneError naming an image name (its own or a light group's) that an image this add-on did
    not make holds."""
    for item in [plan] + [plan.for_light_group(group) for group in plan.light_groups]:
        for name in item.image_names:
            _check_image_name_free(name)
    return plan


def _lightmap_objects(export: Export, uv_map: str) -> list[ExportedObject]:
    """The baked mesh objects; raises SceneError naming a mesh whose lightmap UV map name is taken."""
    objects = [item for item in export.objects if item.writable]
    meshes = local_by_name(bpy.data.meshes)
    for item in objects:
        mesh = meshes[item.mesh_name]
        if uv_map in mesh.uv_layers and mesh.get(OWNED_UV) != uv_map:
            raise SceneError(f"Mesh '{mesh.name}' (object '{item.name}') already has a UV map '{uv_map}' "
                             "that this add-on did not make; choose another lightmap UV map name.")
    return objects


def _unwrap(export: Export, objects: list[ExportedObject], size: AtlasSize):
    """The atlas layout (one block per mesh, a copy per object), the UV map of each mesh and each object's offset
    from its mesh's first user."""
    first_user: dict[str, int] = {}
    for index, item in enumerate(objects):
        first_user.setdefault(item.mesh_name, index)
    blender_objects = local_by_name(bpy.data.objects)
    sources = [_unwrap_input(export, objects[index], blender_objects[objects[index].name])
               for index in first_user.values()]
    position = {name: number for number, name in enumerate(first_user)}
    layout = layout_atlas([(positions, vertices) for positions, vertices, _ in sources],
                          [position[item.mesh_name] for item in objects], size)
    mesh_uvs = {name: (sources[position[name]][2], layout.corner_uv[index]) for name, index in first_user.items()}
    uv_offsets = [None if first_user[item.mesh_name] == index else
                  layout.corner_uv[index][0, 0] - layout.corner_uv[first_user[item.mesh_name]][0, 0]
                  for index, item in enumerate(objects)]
    return layout, mesh_uvs, uv_offsets


def _unwrap_input(export: Export, item: ExportedObject, obj) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World-space vertex positions (scaled by the object's lightmap scale), (t, 3) triangle vertex indices and
    the (t, 3) loops of the original mesh they stand for: the rendered triangles when the modifiers keep the
    topology, else the original mesh's."""
    scale = item.lightmap_scale
    if item.same_topology:
        triangles = export.input_triangles[item.first_triangle:item.first_triangle + item.triangle_count]
        positions = np.zeros((int(item.corner_vertices.max()) + 1, 3))
        positions[item.corner_vertices] = triangles
        return positions * scale, item.corner_vertices, item.corner_loops
    vertices, loops = loop_triangles(obj.data)
    return world_positions(obj.data, np.array(obj.matrix_world)) * scale, vertices, loops


def _area_m2(export: Export, item: ExportedObject) -> float:
    return float(triangle_areas(export.input_triangles[item.first_triangle:item.first_triangle +
                                                       item.triangle_count]).sum())


def _rendered_uvs(context, objects, layout: AtlasLayout, mesh_uvs, uv_offsets, uv_map: str) -> list:
    """Per object, the (t, 3, 2) lightmap UVs of its rendered triangles: the layout's where the modifiers keep
    the topology; else what the modifiers make of the UV map (None where they drop it). The UV maps are written
    for the evaluation and put back as they were."""
    baked = [corner_uv if item.same_topology else None for item, corner_uv in zip(objects, layout.corner_uv)]
    changed = [index for index, item in enumerate(objects) if not item.same_topology]
    if not changed:
        return baked
    meshes = {objects[index].mesh_name for index in changed}
    blender_objects = local_by_name(bpy.data.objects)
    with _uv_maps_set(meshes, uv_map, mesh_uvs):
        depsgraph = context.evaluated_depsgraph_get()
        for index in changed:
            corner_uv = _evaluated_uvs(depsgraph, blender_objects[objects[index].name], objects[index], uv_map)
            offset = uv_offsets[index] if uv_offsets[index] is not None else 0.0
            baked[index] = None if corner_uv is None else corner_uv + offset
    return baked


def _evaluated_uvs(depsgraph, obj, item: ExportedObject, uv_map: str) -> np.ndarray | None:
    """(t, 3, 2) UVs of the object's rendered triangles in the UV map as its modifiers leave it (None: dropped)."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        layer = mesh.uv_layers.get(uv_map)
        if layer is None or len(mesh.loops) <= item.corner_loops.max():
            return None
        uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
        layer.data.foreach_get("uv", uv)
    finally:
        evaluated.to_mesh_clear()
    return uv.reshape(-1, 2).astype(np.float64)[item.corner_loops]


@contextmanager
def _uv_maps_set(mesh_names, uv_map: str, mesh_uvs):
    """Temporarily give these meshes the planned lightmap UV map (a previous bake's is restored after, a new
    one removed, and the active UV maps kept)."""
    saved, meshes = [], local_by_name(bpy.data.meshes)
    for name in mesh_names:
        mesh = meshes[name]
        layer = mesh.uv_layers.get(uv_map)
        previous = None
        if layer is not None:
            previous = np.empty(len(mesh.loops) * 2, dtype=np.float32)
            layer.data.foreach_get("uv", previous)
        active = mesh.uv_layers.active_index
        render = next((l.name for l in mesh.uv_layers if l.active_render), None)
        saved.append((mesh, previous, active, render))
        _write_uv_map(mesh, uv_map, *mesh_uvs[name])
        mesh.update()
    try:
        yield
    finally:
        for mesh, previous, active, render in saved:
            if previous is None:
                mesh.uv_layers.remove(mesh.uv_layers[uv_map])
            else:
                mesh.uv_layers[uv_map].data.foreach_set("uv", previous)
            mesh.uv_layers.active_index = active
            if render is not None:
                mesh.uv_layers[render].active_render = True
            mesh.update()


def _uv_problems(export: Export, objects, layout: AtlasLayout, mesh_uvs, rendered_uv) -> dict[int, str]:
    """Object index -> why its rendered lightmap UVs cannot be baked, for those that cannot."""
    problems = {}
    for index, item in enumerate(objects):
        uv_per_m2 = (layout.texels_per_metre * item.lightmap_scale) ** 2 / (layout.width * layout.height)
        problem = None if item.same_topology else modifier_uv_problem(
            rendered_uv[index], mesh_uvs[item.mesh_name][1], _area_m2(export, item), uv_per_m2)
        if problem:
            problems[index] = problem
    return problems


def _check_image_name_free(name: str) -> None:
    image = bpy.data.images.get(name)
    if image is not None and not image.get(OWNED_IMAGE):
        raise SceneError(f"An image '{name}' that this add-on did not make already exists; choose another "
                         "lightmap image name.")


def write_lightmap(plan: LightmapPlan, lights: list[np.ndarray], metadata: dict, folder: str,
                   staged: StagedFiles) -> tuple[list[dict], list[str]]:
    """UV maps on the meshes, one EXR file and Blender image per page; returns the report's per-object entries and
    warnings. The files are staged in ``staged`` (they replace earlier ones when it is committed); the images
    read them from their final paths after that."""
    user, layout = plan.user, plan.layout
    # Every file first: writing may fail, and nothing in the .blend has changed yet.
    files = [_write_files(user, name, light, metadata, folder, staged) for name, light in
             zip(plan.image_names, lights)]
    meshes, blender_objects = local_by_name(bpy.data.meshes), local_by_name(bpy.data.objects)
    for name, (loops, corner_uv) in plan.mesh_uvs.items():
        _write_uv_map(meshes[name], user.lightmap_uv_map, loops, corner_uv)
        meshes[name][OWNED_UV] = user.lightmap_uv_map
    for item, offset, page in zip(plan.objects, plan.uv_offsets, layout.page):
        obj = blender_objects[item.name]
        _set_property(obj, PAGE_PROPERTY, int(page) if layout.page_count > 1 else None)
        _set_property(obj, OFFSET_PROPERTY, None if offset is None else offset.tolist())
    images = [_load_image(name, file, user.lightmap_image, page) for page, (name, file) in
              enumerate(zip(plan.image_names, files))]
    _remove_stale_pages(user.lightmap_image, layout.page_count)
    entries = []
    for item, page, charts in zip(plan.objects, layout.page, plan.chart_texels):
        image, path = images[page], files[page].path
        entry = {"name": item.name, "uv_map": user.lightmap_uv_map, "color_attribute": None,
                 "image": f"(packed) {image.name}" if image.packed_file else path,
                 "resolution": [layout.width, layout.height], "charts": len(charts),
                 "median_chart_texels": round(float(np.median(charts)), 2) if len(charts) else 0.0}
        if user.lightmap_png and folder:
            entry["png"] = os.path.splitext(path)[0] + ".png"
        entries.append(entry)
    warnings = [f"Lightmap image '{file.name}': its light reaches above {HALF_MAX:g}, more than half floats hold; "
                "written as 32-bit floats." for file in files if file.widened]
    return entries, warnings


def _set_property(obj, name: str, value) -> None:
    if value is not None:
        obj[name] = value
    elif name in obj:
        del obj[name]


def _remove_stale_pages(image_name: str, page_count: int) -> None:
    """Remove the page images an earlier bake of this image made beyond this bake's pages (ours, not the user's)."""
    for image in page_images(image_name):
        if image.get(PAGE_PROPERTY, 0) >= page_count:
            bpy.data.images.remove(image)


def page_images(image_name: str) -> list:
    """The Blender images of a baked lightmap's pages, in page order (empty if none was baked)."""
    images = [image for image in bpy.data.images if image.get(OWNED_IMAGE) == image_name]
    return sorted(images, key=lambda image: image.get(PAGE_PROPERTY, 0))


def _write_uv_map(mesh, name: str, corner_loops: np.ndarray, corner_uv: np.ndarray) -> None:
    layer = mesh.uv_layers.get(name) or mesh.uv_layers.new(name=name, do_init=False)
    uv = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    uv[corner_loops.ravel()] = corner_uv.reshape(-1, 2)
    layer.data.foreach_set("uv", uv.ravel())


@dataclass(frozen=True)
class _PageFile:
    """A page's EXR: ``path`` where it will be, ``source`` where it is now (a staged temporary, or the file in a
    temporary folder when the image is packed into the .blend); ``widened``: written as 32-bit floats because
    half floats could not hold its light."""

    name: str
    path: str
    source: str
    packed: bool
    widened: bool


def _write_files(user: UserSettings, name: str, light: np.ndarray, metadata: dict, folder: str,
                 staged: StagedFiles) -> _PageFile:
    """The EXR (and the optional PNG) staged in ``folder``, or the EXR alone in a temporary folder when the image
    is to be packed."""
    half = user.lightmap_half and float(np.max(light, initial=0.0)) <= HALF_MAX
    if not folder:
        path = os.path.join(tempfile.mkdtemp(prefix="radiosity_"), bpy.path.clean_name(name) + ".exr")
        write_exr(path, light, half, metadata)
        return _PageFile(name, path, path, True, half != user.lightmap_half)
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as error:
        raise OutputError(f"Cannot write lightmaps into the folder '{folder}': {error.strerror}.") from error
    path = os.path.join(folder, bpy.path.clean_name(name) + ".exr")
    source = staged.stage(path, lambda temporary: write_exr(temporary, light, half, metadata),
                          lambda temporary: check_image(temporary, light))
    if user.lightmap_png:
        exposure = user.lightmap_png_exposure
        encoding = {"radiosity:encoding": f"sRGB(clamp(light x 2^{exposure:g}, 0, 1)), 8 bits"}
        staged.stage(os.path.splitext(path)[0] + ".png",
                     lambda temporary: write_png(temporary, light, exposure, encoding),
                     lambda temporary: check_image(temporary, light))
    return _PageFile(name, path, source, False, half != user.lightmap_half)


def _load_image(name: str, file: _PageFile, lightmap_name: str, page: int):
    """The Blender image ``name`` showing page ``page`` of the lightmap ``lightmap_name`` from ``file.path``
    (replacing the file of the one a previous bake made). Blender reads image files when their pixels are first
    needed: the image is opened on the staged file and pointed at its final path without reading it. A packed
    image is read into the .blend now, and its temporary file removed."""
    image = bpy.data.images.get(name)
    if image is None:
        image = bpy.data.images.load(file.source)
        image.name = name
    image.filepath_raw = file.path
    image.source = "FILE"
    image.reload()
    image[OWNED_IMAGE] = lightmap_name
    image[PAGE_PROPERTY] = page
    image.use_fake_user = True  # kept in the saved .blend even before a material uses it
    if file.packed:
        image.pack()
        os.remove(file.path)
        os.rmdir(os.path.dirname(file.path))
    return image


def lightmap_folder(setting: str) -> str:
    """The absolute folder for lightmap files: the setting (Blender's // is the .blend's folder), or "" (pack
    into the .blend) when it is relative and the .blend was never saved."""
    if setting.startswith("//") and not bpy.data.filepath:
        return ""
    return os.path.abspath(bpy.path.abspath(setting or "//"))
