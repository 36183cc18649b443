"""A solved scene and its outputs in Cycles' units.

The baked quantity is "diffuse light without albedo": irradiance / pi (W m^-2 sr^-1, scene-linear), what Cycles'
Diffuse bake with Direct + Indirect and no Color stores (docs/units.md). Per-element values are smoothed to the
element corners by area-weighted nodal averaging (Cohen & Greenberg 1985) among elements that share a welded
vertex and whose normals differ by less than ``SMOOTH_ANGLE_RAD``, so creases stay sharp. Lightmaps weight by
exposed area instead: they resolve the dark footprint under a box texel by texel, so elements buried there must
not darken the corners beside it; a vertex on the footprint's edge keeps the area weight (Cycles' vertex bake
there averages in the dark side).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .direct import DirectLighting
from .mesh import ElementMesh, weld_vertices
from .ragged import concatenated_ranges
from .scene import Scene
from .terminator import ShadowLift
from .solver import ConvergenceStep, RadiosityState
from .texels import inset

SMOOTH_ANGLE_RAD = np.radians(45.0)


@dataclass
class Solution:
    scene: Scene
    mesh: ElementMesh
    state: RadiosityState
    weld_tolerance_m: float
    seconds: dict[str, float] = field(default_factory=dict)
    rays_cast: int = 0
    direct: DirectLighting | None = None
    ambient_irradiance: np.ndarray = field(default_factory=lambda: np.zeros(3))
    _corner_light: np.ndarray | None = field(default=None, init=False, repr=False)
    _corner_indirect: dict = field(default_factory=dict, init=False, repr=False)
    _corner_reflected: np.ndarray | None = field(default=None, init=False, repr=False)
    _lookup_tables: tuple[np.ndarray, np.ndarray] | None = field(default=None, init=False, repr=False)

    @property
    def history(self) -> list[ConvergenceStep]:
        return self.state.history

    @property
    def residual(self) -> float:
        return self.state.residual

    @property
    def element_count(self) -> int:
        return len(self.state.elements.node)

    def element_irradiance(self) -> np.ndarray:
        """(n, 3) irradiance H per element, W m^-2: the solve's plus the ambient term for the unshot residual."""
        return self.state.irradiance + self.ambient_irradiance

    def element_light(self) -> np.ndarray:
        """(n, 3) irradiance / pi per element (Cycles' Diffuse Direct + Indirect, no Color)."""
        return self.element_irradiance() / np.pi

    def element_radiosity(self) -> np.ndarray:
        """(n, 3) radiosity B = E + rho H per element, W m^-2."""
        return self.state.elements.emitted_exitance + self.state.elements.reflectance * self.element_irradiance()

    def corner_light(self) -> np.ndarray:
        """(n, 3, 3) light at each element's corners by area-weighted nodal averaging (computed once)."""
        if self._corner_light is None:
            self._corner_light = self._nodal_average(self.element_light())
        return self._corner_light

    def _corner_indirect_light(self, exposed_weight: bool) -> np.ndarray:
        """(n, 3, 3) indirect light (total minus what ``direct`` gives at the element centroids) at corners."""
        if exposed_weight not in self._corner_indirect:
            elements = self.state.elements
            direct = self.direct.irradiance(elements.centroid, elements.normal, elements.patch)
            self._corner_indirect[exposed_weight] = self._nodal_average(
                (self.element_irradiance() - direct) / np.pi, exposed_weight)
        return self._corner_indirect[exposed_weight]

    def _nodal_average(self, light: np.ndarray, exposed_weight: bool = False) -> np.ndarray:
        elements = self.state.elements
        _, corner_vertex = weld_vertices(self.mesh, elements.node, self.weld_tolerance_m)
        corner_of = corner_vertex.ravel()
        owner = np.repeat(np.arange(len(elements.node)), 3)
        order = np.argsort(corner_of, kind="stable")
        _, group_start, group_size = np.unique(corner_of[order], return_index=True, return_counts=True)
        size_of = np.repeat(group_size, group_size)
        start_of = np.repeat(group_start, group_size)
        # Every (corner, element) pair around the same vertex: the corner's element and each partner element.
        corner = np.repeat(order, size_of)
        partner = owner[order[np.repeat(start_of, size_of) + concatenated_ranges(size_of)]]
        mine = owner[corner]
        smooth = (elements.normal[mine] * elements.normal[partner]).sum(axis=1) >= np.cos(SMOOTH_ANGLE_RAD)
        # With exposed_weight, a tiny share of the area keeps a corner that only buried elements share defined.
        area = elements.exposed_m2 + 1e-6 * elements.area_m2 if exposed_weight else elements.area_m2
        weight = area[partner] * smooth
        total = np.zeros((3 * len(elements.node), 3))
        np.add.at(total, corner, weight[:, None] * light[partner])
        norm = np.bincount(corner, weights=weight, minlength=3 * len(elements.node))
        return (total / norm[:, None]).reshape(-1, 3, 3)

    def evaluate(self, scene_triangle: np.ndarray, barycentric: np.ndarray,
                 direct_per_point: bool = False) -> np.ndarray:
        """(m, 3) light at surface points given by scene triangle index and barycentrics in that triangle.

        With ``direct_per_point`` (and ``direct`` set), the direct part is computed at each point with shadow rays
        (arriving by the shading normal, core.scene.Scene.shading_normals) and only the indirect part is
        interpolated from the element corners; otherwise the element solution is
        interpolated. Points on "shadow only" triangles (not solved) get NaN; black channels of the reflectance
        get 0, as in Cycles' Diffuse bake without Color (it divides by the albedo).
        """
        if self.direct is None or not direct_per_point:
            return self.black_stays_black(self.interpolate(self.corner_light(), scene_triangle, barycentric),
                                          scene_triangle)
        barycentric = np.asarray(barycentric, dtype=np.float64)
        triangles = self.scene.triangles[np.asarray(scene_triangle, dtype=np.int64)]
        points = np.einsum("mc,mck->mk", barycentric, triangles)
        solved, leaf, _ = self._leaves(scene_triangle, barycentric)
        points[solved] = inset(points[solved], self.state.elements.centroid[leaf], 4 * self.direct.offset_m)
        normals = self.scene.shading_normals(np.asarray(scene_triangle, dtype=np.int64), barycentric)
        direct = self.direct_light(points, normals, scene_triangle, barycentric)
        return self.black_stays_black(direct + self.indirect_light(scene_triangle, barycentric), scene_triangle)

    def black_stays_black(self, light: np.ndarray, scene_triangle: np.ndarray) -> np.ndarray:
        """Light with 0 in the channels where the triangle's reflectance is 0: Cycles' Diffuse bake without Color
        divides by the albedo, so a black surface bakes black."""
        reflectance = self.scene.reflectance[self.scene.material_index[np.asarray(scene_triangle, dtype=np.int64)]]
        return np.where(reflectance == 0, 0.0, light)

    def direct_light(self, points: np.ndarray, normals: np.ndarray, scene_triangle: np.ndarray,
                     barycentric: np.ndarray, samples_per_edge: int | None = None,
                     seed_offset: int = 0) -> np.ndarray:
        """(m, 3) direct light (irradiance / pi) at points by shadow rays; the point's own patch (found from its
        triangle and barycentrics) is not counted as an emitter. NaN on triangles that were not solved.
        ``seed_offset`` shifts the shadow rays' seed, for points lit in several calls. Shadow rays from
        smooth-shaded triangles start on their smooth surface (core.terminator)."""
        solved, leaf, _ = self._leaves(scene_triangle, barycentric)
        lift = ShadowLift.at(self.scene, np.asarray(scene_triangle, dtype=np.int64)[solved],
                             np.asarray(barycentric, dtype=np.float64)[solved], normals[solved])
        out = np.full((len(points), 3), np.nan)
        out[solved] = self.direct.irradiance(points[solved], normals[solved], self.state.elements.patch[leaf],
                                             samples_per_edge, seed_offset, lift) / np.pi
        return out

    def indirect_light(self, scene_triangle: np.ndarray, barycentric: np.ndarray,
                       exposed_weight: bool = False) -> np.ndarray:
        """(m, 3) indirect light (total minus direct at the element centroids), interpolated from the corners
        (averaged by exposed area with ``exposed_weight``: for lightmap texels, see the module's docstring)."""
        return self.interpolate(self._corner_indirect_light(exposed_weight), scene_triangle, barycentric)

    def reflected_radiosity(self, scene_triangle: np.ndarray, barycentric: np.ndarray) -> np.ndarray:
        """(m, 3) reflected radiosity rho H (W m^-2, emission excluded), interpolated from the element corners:
        what a final-gather ray sees where it lands."""
        if self._corner_reflected is None:
            elements = self.state.elements
            self._corner_reflected = self._nodal_average(elements.reflectance * self.element_irradiance())
        return self.interpolate(self._corner_reflected, scene_triangle, barycentric)

    def interpolate(self, corner_values: np.ndarray, scene_triangle: np.ndarray,
                    barycentric: np.ndarray) -> np.ndarray:
        """(m, k) linear interpolation of (n, 3, k) per-element corner values at surface points; NaN on
        triangles that were not solved."""
        solved, leaf, local = self._leaves(scene_triangle, barycentric)
        out = np.full((len(solved), corner_values.shape[-1]), np.nan)
        out[solved] = np.einsum("mc,mck->mk", local, corner_values[leaf])
        return out

    def _leaves(self, scene_triangle, barycentric) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Solved mask (m,), and for the solved points their element row and barycentrics in the element."""
        to_mesh, position = self._lookups()
        mesh_triangle = to_mesh[np.asarray(scene_triangle, dtype=np.int64)]
        solved = mesh_triangle >= 0
        node, local = self.mesh.locate(mesh_triangle[solved], np.asarray(barycentric, dtype=np.float64)[solved])
        return solved, position[node], local

    def _lookups(self) -> tuple[np.ndarray, np.ndarray]:
        """Scene triangle -> mesh triangle (-1 if not solved) and mesh node -> element row, built once."""
        if self._lookup_tables is None:
            to_mesh = np.full(len(self.scene.triangles), -1)
            to_mesh[self.mesh.triangle_scene] = np.arange(len(self.mesh.triangle_scene))
            position = np.full(len(self.mesh.node_bary), -1)
            position[self.state.elements.node] = np.arange(self.element_count)
            self._lookup_tables = (to_mesh, position)
        return self._lookup_tables

    def radiosity_mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The element mesh with its light: (V, 3) vertices, (n, 3) triangles, (n, 3, 3) corner light."""
        vertices, corner_vertex = weld_vertices(self.mesh, self.state.elements.node, self.weld_tolerance_m)
        return vertices, corner_vertex, self.corner_light()
