"""Lightmap atlases: each mesh is cut into charts and packed into its own block by xatlas; blocks are then
packed side by side into atlas pages (images) of at most a maximum size, as many as the texel density needs.

A block per mesh (rather than one xatlas pack over all meshes) lets objects that share mesh data (linked
duplicates) keep one UV layout yet own separate lightmap space: each user of the mesh gets its own copy of the
block, and the UV map stores the first user's placement while the others carry an offset.

UVs follow Blender's convention: (0, 0) is the lower-left corner of the image, texel (x, y) has its centre at
((x + 0.5) / width, (y + 0.5) / height).
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass

import numpy as np
import xatlas

from .errors import SettingsError
from .geometry import triangle_areas
from .texels import rasterize

OVERLAP_TOLERANCE = 0.01  # share of an object's texel centres that may fall on another object's
ATLAS_SETTLE_S = 0.01  # how long an xatlas atlas is kept after generate() before it is freed (see SettlingAtlases)
ATLAS_HELD_MAX = 16  # atlases kept at once, each with its idle worker threads


@dataclass
class ChartBlock:
    """One mesh unwrapped: (t, 3, 2) corner UVs in texels inside a ``width`` x ``height`` block."""

    corner_texels: np.ndarray
    width: int
    height: int


def chart_areas(corner_texels: np.ndarray) -> np.ndarray:
    """(c,) the area in texels^2 of each chart of a UV map ((t, 3, 2) corner UVs in texels): charts are the
    triangles joined through corners at the same UV (connected components, found by propagating the smallest
    corner label with pointer jumping)."""
    if len(corner_texels) == 0:
        return np.zeros(0)
    _, corner = np.unique(corner_texels.reshape(-1, 2), axis=0, return_inverse=True)
    corner = corner.reshape(-1, 3)
    label = np.arange(corner.max() + 1)
    while True:
        joined = label.copy()
        np.minimum.at(joined, corner.ravel(), np.repeat(label[corner].min(axis=1), 3))
        joined = joined[joined]
        if np.array_equal(joined, label):
            break
        label = joined
    _, chart = np.unique(label[corner[:, 0]], return_inverse=True)
    return np.bincount(chart.ravel(), weights=triangle_areas(np.pad(corner_texels, [(0, 0), (0, 0), (0, 1)])))


class SettlingAtlases:
    """Keeps each xatlas atlas for ATLAS_SETTLE_S after its generate() before freeing it.

    xatlas's thread pool (TaskScheduler::~TaskScheduler) wakes its workers to shut down without holding their
    mutex. A worker that has just finished the last task and is between checking its wake-up flag and sleeping
    misses that wake-up, and freeing the atlas then waits forever in std::thread::join. A worker needs microseconds
    to fall asleep, so freeing an atlas only once it has rested closes the window. Use as a context manager: on exit
    it waits for the youngest atlas to rest and frees them all."""

    def __init__(self):
        self._held = deque()  # (monotonic time from which the atlas may be freed, atlas), oldest first

    def __enter__(self) -> SettlingAtlases:
        return self

    def __exit__(self, *exc_info) -> None:
        self._free(keep=0)

    def hold(self, atlas: xatlas.Atlas) -> None:
        """Keep ``atlas``, whose generate() has just returned, until it has rested; free those that have."""
        self._held.append((time.monotonic() + ATLAS_SETTLE_S, atlas))
        self._free(keep=ATLAS_HELD_MAX)

    def _free(self, keep: int) -> None:
        """Free rested atlases; wait for the oldest to rest while more than ``keep`` are held."""
        while self._held:
            wait_s = self._held[0][0] - time.monotonic()
            if wait_s > 0:
                if len(self._held) <= keep:
                    return
                time.sleep(wait_s)
            self._held.popleft()


def unwrap(positions_m: np.ndarray, triangle_vertices: np.ndarray, texels_per_metre: float,
           padding_texels: int, atlases: SettlingAtlases) -> ChartBlock:
    """Charts of a triangle mesh (world-scale (V, 3) positions, (t, 3) vertex indices) packed by xatlas at the
    given texel density, with ``padding_texels`` between charts and around the block's border. The atlas goes to
    ``atlases`` to be freed safely."""
    pack = xatlas.PackOptions()
    pack.texels_per_unit = float(texels_per_metre)
    pack.padding = int(padding_texels)
    pack.bilinear = True
    pack.resolution = 0
    atlas = xatlas.Atlas()
    try:
        atlas.add_mesh(np.ascontiguousarray(positions_m, dtype=np.float32),
                       np.ascontiguousarray(triangle_vertices, dtype=np.uint32))
        atlas.generate(xatlas.ChartOptions(), pack)
    finally:
        atlases.hold(atlas)
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


@dataclass(frozen=True)
class AtlasSize:
    """How large a lightmap's pages are: ``resolution`` > 0 asks for one square page of that many texels a side,
    filled by the largest density that fits it; else the pages are as large as ``texels_per_metre`` needs, at most
    ``max_size`` texels a side, as many as needed. ``padding``: texels between charts and around blocks."""

    texels_per_metre: float
    resolution: int
    padding: int
    max_size: int

    def existing_uv_side(self, areas_m2: np.ndarray, areas_uv: np.ndarray) -> int:
        """The square page side for objects baked on their own UV maps ((n,) surface areas in m^2 and UV areas in
        units of the square): the resolution asked for, or the side at which the object that needs most gets the
        density (at least 8 texels, at most the maximum size)."""
        if self.resolution:
            return self.resolution
        need = self.texels_per_metre * np.sqrt(areas_m2 / np.maximum(areas_uv, 1e-12)).max()
        return int(np.clip(np.ceil(need), 8, self.max_size))


def atlas_size(texels_per_metre: float, resolution: int, preset_texels_per_metre: float, padding: int,
               max_size: int) -> AtlasSize:
    """The one place a lightmap's size is decided, from a user's settings: a density (texels_per_metre > 0) or a
    resolution (> 0), never both; neither takes the preset's density. Raises SettingsError naming the settings
    that conflict."""
    if texels_per_metre > 0 and resolution > 0:
        raise SettingsError(f"The lightmap has both a texel density ({texels_per_metre:g} per metre) and a "
                            f"resolution ({resolution}); set one of them to 0.")
    if resolution > max_size:
        raise SettingsError(f"The lightmap resolution {resolution} is above the maximum size {max_size}; raise "
                            "the maximum size or lower the resolution.")
    if padding < 1:
        raise SettingsError(f"The lightmap padding must be at least 1 texel, got {padding}.")
    density = texels_per_metre if texels_per_metre > 0 else preset_texels_per_metre
    return AtlasSize(float(density), int(resolution), int(padding), int(max_size))


def uv_area(corner_uv: np.ndarray) -> float:
    """The summed area of (t, 3, 2) UV triangles, in units of the whole UV square."""
    return float(triangle_areas(np.pad(corner_uv, [(0, 0), (0, 0), (0, 1)])).sum())


def modifier_uv_problem(rendered_uv: np.ndarray | None, mesh_uv: np.ndarray, rendered_m2: float,
                        uv_per_m2: float) -> str | None:
    """Why an object's lightmap UVs, as its topology-changing modifiers carry them to the rendered mesh
    ((t, 3, 2), or None where they drop the UV map), cannot be baked, or None: the modifiers drop the UV map;
    repeat it so that copies overlap (the rendered UV area exceeds the mesh's ``mesh_uv`` by over 10%); or squash
    it (under a quarter of the UV area its rendered surface of ``rendered_m2`` needs at ``uv_per_m2``)."""
    if rendered_uv is None:
        return "its modifiers do not keep UV maps"
    if uv_area(rendered_uv) > 1.1 * uv_area(mesh_uv):
        return "its modifiers repeat its UV map (as Array, Mirror and Solidify do), so copies would share texels"
    if uv_area(rendered_uv) < 0.25 * rendered_m2 * uv_per_m2:
        return "its modifiers squash its UV map (as Wireframe does), so its faces would cover no texels"
    return None


def layout_atlas(meshes: list[tuple[np.ndarray, np.ndarray]], mesh_of_object: list[int],
                 size: AtlasSize) -> AtlasLayout:
    """Unwrap each mesh once and give each object a copy of its mesh's block.

    ``meshes``: (positions_m, triangle_vertices) per distinct mesh; ``mesh_of_object``: the mesh of each object.
    Either pages of up to ``size.max_size`` texels a side at the size's density, as many as needed, or one square
    page of ``size.resolution`` that the density is chosen to fill (largest density, in steps of 10%, that fits)."""
    if not size.resolution:
        return _layout(meshes, mesh_of_object, size.padding, size.max_size, size.texels_per_metre)
    resolution, padding_texels = size.resolution, size.padding
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
    with SettlingAtlases() as atlases:
        blocks = [unwrap(positions, triangles, texels_per_metre, padding_texels, atlases)
                  for positions, triangles in meshes]
    sizes = np.array([(blocks[m].width, blocks[m].height) for m in mesh_of_object])
    offsets, page, width, height = pack_blocks(sizes, max_size)
    corner_uv = [(blocks[m].corner_texels + offset) / [width, height] for m, offset in zip(mesh_of_object, offsets)]
    return AtlasLayout(corner_uv, page, width, height, float(texels_per_metre))


def overlapping_share(corner_uv: np.ndarray, width: int, height: int) -> float:
    """The share of a UV map's area that lies on top of other faces of the same map (0 when no faces overlap; 0.5
    for a mirrored copy on the same UVs): one minus the texel centres its faces cover over the texels their areas
    add up to. Chart borders cost up to about one texel row per chart, so small shares are discretisation."""
    texels = rasterize(corner_uv, width, height)
    faces_texels = uv_area(corner_uv) * width * height
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
