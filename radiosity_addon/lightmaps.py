"""Lightmaps in Blender: plan the atlas from the exported objects (main thread, before the solve), then write the
UV maps and the image after it.

Each baked mesh gets a new UV map (default "Lightmap") made by xatlas; existing UV maps are never changed, and a UV
map of that name that this add-on did not make is refused. Objects that share a mesh (linked duplicates) share its
UV map but get their own part of the atlas: the first user's part is what the UV map holds, the others carry
``obj["radiosity_lightmap_offset"]``, the UV offset of their copy. Each atlas page is an OpenEXR file (saved next
to the .blend, or where asked, or packed into an unsaved .blend) loaded as a Blender image: the first page takes
the image name, page k the name followed by " k"; when there are several, every object carries
``obj["radiosity_lightmap_page"]``, the page its UVs refer to.
"""
from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..core import SceneError
from ..core.atlas import AtlasLayout, layout_atlas
from .export import Export, ExportedObject

OWNED_UV = "radiosity_lightmap_uv"
OWNED_IMAGE = "radiosity_lightmap"
OFFSET_PROPERTY = "radiosity_lightmap_offset"
PAGE_PROPERTY = "radiosity_lightmap_page"


@dataclass(frozen=True)
class LightmapOptions:
    """uv_map: name of the UV map to make; image_name: of the Blender image and its file; texels_per_metre or
    resolution (one square atlas) sets the density (neither: the preset's); padding: texels between charts;
    max_size: texels a side of an atlas page (more pages when the density needs them); half: 16-bit float EXR
    (else 32-bit); png_exposure: also write an 8-bit sRGB PNG of the light x 2^stops
    (core.image_file.write_png's documented encoding) for engines that want low dynamic range."""

    uv_map: str = "Lightmap"
    image_name: str = "Radiosity Lightmap"
    texels_per_metre: float | None = None
    resolution: int | None = None
    padding: int = 4
    max_size: int = 4096
    half: bool = True
    png_exposure: float | None = None


@dataclass
class LightmapPlan:
    """The objects and their atlas layout; per page, the solved scene triangles it holds and their UVs."""

    objects: list[ExportedObject]
    layout: AtlasLayout
    page_triangles: list[tuple[np.ndarray, np.ndarray]]
    options: LightmapOptions
    warnings: list[str] = field(default_factory=list)

    @property
    def image_names(self) -> list[str]:
        return [page_image_name(self.options.image_name, page) for page in range(self.layout.page_count)]


def page_image_name(image_name: str, page: int) -> str:
    return image_name if page == 0 else f"{image_name} {page + 1}"


def plan_lightmap(export: Export, options: LightmapOptions, default_texels_per_metre: float) -> LightmapPlan:
    """Unwrap and pack every baked mesh object; raises SceneError naming a mesh whose UV map name is taken."""
    warnings, objects = [], []
    for item in export.objects:
        if not item.writable:
            continue
        if not item.same_topology:
            warnings.append(f"Object '{item.name}': its modifiers change the topology, so it gets no lightmap "
                            "(apply them, or bake vertex colours).")
            continue
        mesh = bpy.data.meshes[item.mesh_name]
        if options.uv_map in mesh.uv_layers and mesh.get(OWNED_UV) != options.uv_map:
            raise SceneError(f"Mesh '{mesh.name}' (object '{item.name}') already has a UV map '{options.uv_map}' "
                             "that this add-on did not make; choose another lightmap UV map name.")
        objects.append(item)
    if not objects:
        raise SceneError("Nothing to bake into a lightmap: no visible mesh object is set to 'Bake'.")
    first_user: dict[str, int] = {}
    for index, item in enumerate(objects):
        first_user.setdefault(item.mesh_name, index)
    meshes = [_unwrap_input(export, objects[index]) for index in first_user.values()]
    position = {name: number for number, name in enumerate(first_user)}
    mesh_of_object = [position[item.mesh_name] for item in objects]
    density = options.texels_per_metre if options.texels_per_metre or options.resolution else \
        default_texels_per_metre
    layout = layout_atlas(meshes, mesh_of_object, options.padding, options.max_size, density,
                          None if options.texels_per_metre else options.resolution)
    kept = export.scene_index_of_input()
    pages = [([], []) for _ in range(layout.page_count)]
    for item, corner_uv, page in zip(objects, layout.corner_uv, layout.page):
        scene_triangle = kept[item.first_triangle + np.arange(item.triangle_count)]
        pages[page][0].append(scene_triangle[scene_triangle >= 0])
        pages[page][1].append(corner_uv[scene_triangle >= 0])
    plan = LightmapPlan(objects, layout, [(np.concatenate(t), np.concatenate(u)) for t, u in pages], options,
                        warnings)
    for name in plan.image_names:
        _check_image_name_free(name)
    return plan


def _unwrap_input(export: Export, item: ExportedObject) -> tuple[np.ndarray, np.ndarray]:
    """World-space vertex positions (scaled by the object's lightmap scale) and triangle vertex indices."""
    triangles = export.input_triangles[item.first_triangle:item.first_triangle + item.triangle_count]
    positions = np.zeros((int(item.corner_vertices.max()) + 1, 3))
    positions[item.corner_vertices] = triangles
    scale = getattr(getattr(bpy.data.objects[item.name], "radiosity", None), "lightmap_scale", 1.0)
    return positions * scale, item.corner_vertices


def _check_image_name_free(name: str) -> None:
    image = bpy.data.images.get(name)
    if image is not None and not image.get(OWNED_IMAGE):
        raise SceneError(f"An image '{name}' that this add-on did not make already exists; choose another "
                         "lightmap image name.")


def write_lightmap(plan: LightmapPlan, lights: list[np.ndarray], metadata: dict, folder: str) -> list[dict]:
    """UV maps on the meshes, one EXR file and Blender image per page; returns the report's per-object entries."""
    options, layout = plan.options, plan.layout
    # Every file first: writing may fail, and nothing in the .blend has changed yet.
    paths = [_write_files(options, name, light, metadata, folder) for name, light in zip(plan.image_names, lights)]
    written: dict[str, np.ndarray] = {}
    for item, corner_uv, page in zip(plan.objects, layout.corner_uv, layout.page):
        obj, mesh = bpy.data.objects[item.name], bpy.data.meshes[item.mesh_name]
        _set_property(obj, PAGE_PROPERTY, int(page) if layout.page_count > 1 else None)
        if mesh.name in written:
            obj[OFFSET_PROPERTY] = (corner_uv[0, 0] - written[mesh.name][0, 0]).tolist()
            continue
        _write_uv_map(mesh, options.uv_map, item.corner_loops, corner_uv)
        written[mesh.name] = corner_uv
        _set_property(obj, OFFSET_PROPERTY, None)
    images = [_load_image(name, path, options.image_name, page, pack=not folder) for page, (name, path) in
              enumerate(zip(plan.image_names, paths))]
    _remove_stale_pages(options.image_name, layout.page_count)
    entries = []
    for item, page in zip(plan.objects, layout.page):
        image, path = images[page], paths[page]
        entry = {"name": item.name, "uv_map": options.uv_map, "color_attribute": None,
                 "image": f"(packed) {image.name}" if image.packed_file else path,
                 "resolution": [layout.width, layout.height]}
        if options.png_exposure is not None and folder:
            entry["png"] = os.path.splitext(path)[0] + ".png"
        entries.append(entry)
    return entries


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
    mesh[OWNED_UV] = name


def _write_files(options: LightmapOptions, name: str, light: np.ndarray, metadata: dict, folder: str) -> str:
    """The EXR (and the optional PNG) in ``folder``, or the EXR alone in a temporary folder when the image is to
    be packed; returns the EXR's path."""
    from ..core.image_file import write_exr, write_png
    target = folder or tempfile.mkdtemp(prefix="radiosity_")
    try:
        os.makedirs(target, exist_ok=True)
    except OSError as error:
        raise SceneError(f"Cannot write lightmaps into the folder '{target}': {error.strerror}.") from error
    path = os.path.join(target, bpy.path.clean_name(name) + ".exr")
    write_exr(path, light, options.half, metadata)
    if options.png_exposure is not None and folder:
        write_png(os.path.splitext(path)[0] + ".png", light, options.png_exposure,
                  {"radiosity:encoding": f"sRGB(clamp(light x 2^{options.png_exposure:g}, 0, 1)), 8 bits"})
    return path


def _load_image(name: str, path: str, lightmap_name: str, page: int, pack: bool):
    """The Blender image ``name`` showing the EXR of page ``page`` of the lightmap ``lightmap_name`` (replacing the
    file of the one a previous bake made); packed into the .blend, and the temporary file removed, when
    ``pack``."""
    image = bpy.data.images.get(name)
    if image is None:
        image = bpy.data.images.load(path)
        image.name = name
    else:
        image.filepath = path
        image.source = "FILE"
        image.reload()
    image[OWNED_IMAGE] = lightmap_name
    image[PAGE_PROPERTY] = page
    image.use_fake_user = True  # kept in the saved .blend even before a material uses it
    if pack:
        image.pack()
        os.remove(path)
        os.rmdir(os.path.dirname(path))
    return image


def lightmap_folder(setting: str) -> str:
    """The absolute folder for lightmap files: the setting (Blender's // is the .blend's folder), or "" (pack
    into the .blend) when it is relative and the .blend was never saved."""
    if setting.startswith("//") and not bpy.data.filepath:
        return ""
    return os.path.abspath(bpy.path.abspath(setting or "//"))
