"""Lightmap atlases: each mesh is cut into charts and packed into its own block by xatlas; blocks are then
packed side by side into atlas pages (images) of at most a maximum size, as many as the texel density needs.

A block per mesh (rather than one xatlas pack over all meshes) lets objects that share mesh data (linked
duplicates) keep one UV layout yet own separate lightmap space: each user of the mesh gets its own copy of the
block, and the UV map stores the first user's placement while the others carry an offset.

UVs follow Blender's convention: (0, 0) is the lower-left corner of the image, texel (x, y) has its centre at
((x + 0.5) / width, (y + 0.5) / height).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SettingsError
from .geometry import triangle_areas
from .texels import rasterize

OVERLAP_TOLERANCE = 0.01  # share of an object's texel centres that may fall on another object's


@dataclass
class ChartBlock:
    """One mesh unwrapped: (t, 3, 2) corner UVs in texels inside a ``width`` x ``height`` block."""

    corner_texels: np.ndarray
    width: int
    height: int


def unwrap(positions_m: np.ndarray, triangle_vertices: np.ndarray, texels_per_metre: float,
           padding_texels: int) -> ChartBlock:
    """Charts of a triangle mesh (world-scale (V, 3) positions, (t, 3) vertex indices) packed by xatlas at the
    given texel density, with ``padding_texels`` between charts and around the block's border."""
    import xatlas
    atlas = xatlas.Atlas()
    atlas.add_mesh(np.ascontiguousarray(positions_m, dtype=np.float32),
                   np.ascontiguousarray(triangle_vertices, dtype=np.uint32))
    pack = xatlas.PackOptions()
    pack.texels_per_unit = float(texels_per_metre)
    pack.padding = int(padding_texels)
    pack.bilinear = True
    pack.resolution = 0
    atlas.generate(xatlas.ChartOptions(), pack)
    if atlas.atlas_count != 1:
        raise SettingsError(f"The lightmap charts of one mesh need {atlas.atlas_count} atlases; lower the "
                            "texel density.")
    _, indices, uvs = atlas[0]
    # xatlas keeps the input's triangle order; pad the block so charts never touch a neighbouring block.
    width, height = atlas.width + 2 * padding_texels, atlas.height + 2 * padding_texels
    corner_texels = uvs[indices].astype(np.float64) * [atlas.width, atlas.height] + padding_texels
    return ChartBlock(corner_texels, width, height)


def pack_blocks(sizes: np.ndarray, max_size: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Shelf packing of (n, 2) block sizes (width, height, texels) into as many ``max_size`` pages as needed:
    (n, 2) lower-left offsets, (n,) page of each block, and the width and height every page shares. Blocks go
    tallest first, in rows as wide as the widest block or the square root of the total area (at most
    ``max_size``); a block wider or taller than ``max_size`` raises SettingsError."""
    sizes = np.asarray(sizes, dtype=np.int64).reshape(-1, 2)
    offsets, page = np.zeros_like(sizes), np.zeros(len(sizes), dtype=np.int64)
    if len(sizes) == 0:
        return offsets, page, 0, 0
    if sizes.max() > max_size:
        width, height = sizes[np.argmax(sizes.max(axis=1))]
        raise SettingsError(f"One mesh's lightmap charts need {width} x {height} texels, over the maximum atlas "
                            f"size of {max_size}; lower the texel density or raise the maximum size.")
    row_width = min(max_size, max(int(sizes[:, 0].max()), int(np.ceil(np.sqrt((sizes[:, 0] * sizes[:, 1]).sum())))))
    x = y = row_height = width = height = current = 0
    for index in np.lexsort((np.arange(len(sizes)), -sizes[:, 1])):  # one step per object, not per texel
        w, h = sizes[index]
        if x + w > row_width:
            x, y, row_height = 0, y + row_height, 0
        if y + h > max_size:
            x = y = row_height = 0
            current += 1
        offsets[index], page[index] = (x, y), current
        x, row_height = x + w, max(row_height, h)
        width, height = max(width, x), max(height, y + row_height)
    return offsets, page, int(width), int(height)


@dataclass
class AtlasLayout:
    """Where every object's triangles sit: per object its page (one image each) and (t, 3, 2) corner UVs in [0, 1]
    of that page; every page is ``width`` x ``height`` texels, so a UV offset moves a block between pages alike."""

    corner_uv: list[np.ndarray]
    page: np.ndarray
    width: int
    height: int
    texels_per_metre: float

    @property
    def page_count(self) -> int:
        return int(self.page.max(initial=-1)) + 1


def layout_atlas(meshes: list[tuple[np.ndarray, np.ndarray]], mesh_of_object: list[int], padding_texels: int,
                 max_size: int, texels_per_metre: float | None = None, resolution: int | None = None) -> AtlasLayout:
    """Unwrap each mesh once and give each object a copy of its mesh's block.

    ``meshes``: (positions_m, triangle_vertices) per distinct mesh; ``mesh_of_object``: the mesh of each object.
    Either the density is given (pages of up to ``max_size`` texels a side, as many as needed), or a square
    ``resolution`` that the density is chosen to fill in one page (largest density, in steps of 10%, that fits)."""
    if texels_per_metre is not None:
        return _layout(meshes, mesh_of_object, padding_texels, max_size, texels_per_metre)
    if not resolution or resolution <= 0:
        raise SettingsError("Give the lightmap either a texel density or a resolution.")
    area_m2 = sum(float(triangle_areas(positions[triangles]).sum()) for positions, triangles in
                  (meshes[index] for index in mesh_of_object))
    density = np.sqrt(0.5 * resolution ** 2 / max(area_m2, 1e-12))
    while density * np.sqrt(area_m2) >= 1.0:
        try:
            layout = _layout(meshes, mesh_of_object, padding_texels, resolution, density)
        except SettingsError:
            layout = None
        if layout is not None and layout.page_count == 1:
            to_canvas = np.array([layout.width, layout.height]) / resolution
            return AtlasLayout([uv * to_canvas for uv in layout.corner_uv], layout.page, resolution, resolution,
                               density)
        density *= 0.9
    raise SettingsError(f"The objects do not fit a {resolution} x {resolution} lightmap with {padding_texels} "
                        "texels of padding; raise the resolution.")


def _layout(meshes, mesh_of_object, padding_texels, max_size, texels_per_metre) -> AtlasLayout:
    blocks = [unwrap(positions, triangles, texels_per_metre, padding_texels) for positions, triangles in meshes]
    sizes = np.array([(blocks[m].width, blocks[m].height) for m in mesh_of_object])
    offsets, page, width, height = pack_blocks(sizes, max_size)
    corner_uv = [(blocks[m].corner_texels + offset) / [width, height] for m, offset in zip(mesh_of_object, offsets)]
    return AtlasLayout(corner_uv, page, width, height, float(texels_per_metre))


def overlapping_share(corner_uv: np.ndarray, width: int, height: int) -> float:
    """The share of a UV map's area that lies on top of other faces of the same map (0 when no faces overlap; 0.5
    for a mirrored copy on the same UVs): one minus the texel centres its faces cover over the texels their areas
    add up to. Chart borders cost up to about one texel row per chart, so small shares are discretisation."""
    texels = rasterize(corner_uv, width, height)
    faces_texels = triangle_areas(np.pad(corner_uv, [(0, 0), (0, 0), (0, 1)])).sum() * width * height
    return float(max(0.0, 1.0 - texels.centre_inside.sum() / max(faces_texels, 1e-12)))


def pages_without_overlap(corner_uvs: list[np.ndarray], width: int, height: int,
                          tolerance: float = OVERLAP_TOLERANCE) -> np.ndarray:
    """Pages for objects baked on UV maps they already have ((t, 3, 2) UVs each, in [0, 1]): an object joins the
    first page where the texel centres its triangles cover are free (up to ``tolerance`` of its own, for centres on
    a shared chart border), else opens a new one; (n,) page per object. Linked duplicates, which share a UV map,
    and objects unwrapped each onto the whole square thus get pages of their own."""
    occupied: list[np.ndarray] = []
    page = np.zeros(len(corner_uvs), dtype=np.int64)
    for index, corner_uv in enumerate(corner_uvs):
        texels = rasterize(corner_uv, width, height)
        covered = texels.pixel[texels.centre_inside]
        page[index] = next((number for number, taken in enumerate(occupied)
                            if taken[covered].sum() <= tolerance * len(covered)), len(occupied))
        if page[index] == len(occupied):
            occupied.append(np.zeros(width * height, dtype=bool))
        occupied[page[index]][covered] = True
    return page
