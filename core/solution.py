"""A solved scene and its outputs in Cycles' units.

The baked quantity is "diffuse light without albedo": irradiance / pi (W m^-2 sr^-1, scene-linear), what Cycles'
Diffuse bake with Direct + Indirect and no Color stores (docs/units.md). A solve leaves, for every element side,
the irradiance at its receiver point (``SolvedElements``). At any surface point the light is the direct part,
traced there with shadow rays (core.direct_light), plus the indirect part interpolated from the receivers around it
(core.interpolation: a kernel over receivers the point sees, so no light leaks through walls).
"""
from __future__ import annotations

import copy
import threading
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from .direct_light import DirectLighting
from .gather import final_gather
from .geometry import triangle_unit_normals
from .interpolation import ReceiverField
from .mesh import ElementMesh, weld_vertices
from .raycast import RayCaster
from .scene import Scene
from .solver import ConvergenceStep
from .terminator import ShadowLift
from .geometry import inset
from .surface_probes import inside_closed_geometry, nearest_uncovered, overlap_test

FRONT = 0
_OVERLAPS_LOCK = threading.Lock()


@dataclass
class SolvedElements:
    """What a solve leaves on its n elements, two sides each (the front along the element's normal).

    node_element: (mesh nodes,) the element each leaf of the mesh belongs to (-1 for inner nodes);
    point, normal: (n, 2, 3) each side's receiver point and unit normal; exposed_m2: (n, 2) the area of each side
    that exchanges light (0: the side is buried in closed geometry, dead); irradiance, direct_irradiance: (n, 2, 3)
    total and direct irradiance at the receivers, W m^-2 (no ambient term); reflectance, emitted_exitance: (n, 3);
    area_m2: (n,); reach_m: (n,) how far from its receiver an element's value is interpolated; indirect_irradiance
    (n, 2, 3) or None: what the receivers gather from reflected light, where the solve keeps it apart (else
    outputs take the irradiance minus the direct light evaluated at the receivers).
    """

    node_element: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    exposed_m2: np.ndarray
    irradiance: np.ndarray
    direct_irradiance: np.ndarray
    reflectance: np.ndarray
    emitted_exitance: np.ndarray
    area_m2: np.ndarray
    reach_m: np.ndarray
    indirect_irradiance: np.ndarray | None = None

    @property
    def count(self) -> int:
        return len(self.area_m2)

    @property
    def alive(self) -> np.ndarray:
        """(n, 2) sides that receive and send light."""
        return self.exposed_m2 > 0


@dataclass
class Solution:
    scene: Scene
    mesh: ElementMesh
    elements: SolvedElements
    direct: DirectLighting
    caster: RayCaster
    offset_m: float
    ambient_irradiance: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (3,) or (n, 2, 3)
    history: list[ConvergenceStep] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)
    rays_cast: int = 0
    state: object = None
    warnings: list[str] = field(default_factory=list)
    counts: dict = field(default_factory=dict)
    element_size_m: float = 0.0  # the settings' target element edge length
    _field: ReceiverField | None = field(default=None, init=False, repr=False)
    _indirect: np.ndarray | None = field(default=None, init=False, repr=False)
    _to_mesh: np.ndarray | None = field(default=None, init=False, repr=False)
    _overlap_test: Callable | None = field(default=None, init=False, repr=False)

    @property
    def residual(self) -> float:
        return self.history[-1].residual if self.history else 0.0

    def relit(self, scene: Scene, elements: SolvedElements, direct: DirectLighting, state,
              seconds: dict[str, float]) -> "Solution":
        """The same surfaces and receivers lit by ``scene``'s lights instead (a light group's share, core.bake
        .bake_light_groups): ``elements`` and ``state`` from that lighting's solve; the tables of the geometry
        are shared."""
        lit = Solution(scene, self.mesh, elements, direct, self.caster, self.offset_m, state.ambient(),
                       state.history, seconds, self.caster.rays_cast, state, self.warnings, dict(self.counts),
                       self.element_size_m)
        lit._field, lit._to_mesh, lit._overlap_test = self._receiver_field(), self._scene_to_mesh(), self._overlaps()
        return lit

    def with_indirect(self, indirect_irradiance: np.ndarray) -> "Solution":
        """The same hierarchical solution with each element side's indirect irradiance (n, 2, 3), W m^-2, the
        light it gathers from reflected light, replaced by ``indirect_irradiance`` (its irradiance changed by as
        much) and no ambient term: what a gather over the solution found there (core.gather.gather_at_receivers).
        The tables of the geometry are shared."""
        old = self.elements.indirect_irradiance
        elements = replace(self.elements, indirect_irradiance=indirect_irradiance,
                           irradiance=self.elements.irradiance + indirect_irradiance - old)
        out = copy.copy(self)
        out.elements, out.ambient_irradiance, out._indirect = elements, np.zeros(3), None
        out.counts = dict(self.counts)
        return out

    @property
    def element_count(self) -> int:
        return self.elements.count

    def element_irradiance(self) -> np.ndarray:
        """(n, 3) irradiance H on each element's front, W m^-2: the solve's plus the ambient term for the
        unfinished residual."""
        return self._irradiance()[:, FRONT]

    def element_light(self) -> np.ndarray:
        """(n, 3) irradiance / pi per element front (Cycles' Diffuse Direct + Indirect, no Color)."""
        return self.element_irradiance() / np.pi

    def side_indirect_irradiance(self) -> np.ndarray:
        """(n, 2, 3) indirect irradiance on each element side, W m^-2, ambient term included (0 on dead sides)."""
        return np.pi * self._indirect_light()

    def element_radiosity(self) -> np.ndarray:
        """(n, 3) radiosity B = E + rho H per element front, W m^-2."""
        return self.elements.emitted_exitance + self.elements.reflectance * self.element_irradiance()

    def evaluate(self, scene_triangle: np.ndarray, barycentric: np.ndarray,
                 direct_per_point: bool = False) -> np.ndarray:
        """(m, 3) light at surface points given by scene triangle index and barycentrics in that triangle.

        With ``direct_per_point`` the direct part is computed at each point with shadow rays (arriving by the
        shading normal, core.scene.Scene.shading_normals) and only the indirect part is interpolated; otherwise
        the total is interpolated. Points on "shadow only" triangles (not solved) get NaN; black channels of the
        reflectance get 0, as in Cycles' Diffuse bake without Color (it divides by the albedo).
        """
        scene_triangle = np.asarray(scene_triangle, dtype=np.int64)
        barycentric, points, normals = self.sample_points(scene_triangle, barycentric)
        return self.light_at(scene_triangle, barycentric, points, normals, direct_per_point)

    def light_at(self, scene_triangle: np.ndarray, barycentric: np.ndarray, points: np.ndarray, normals: np.ndarray,
                 direct_per_point: bool = False) -> np.ndarray:
        """``evaluate`` at points ``sample_points`` already placed (its barycentrics, points and face normals)."""
        if not direct_per_point:
            light = self._interpolate(self._total_light(), points, normals, scene_triangle, barycentric)
        else:
            shading = self.scene.shading_normals(scene_triangle, barycentric)
            light = self.direct_light(points, shading, scene_triangle, barycentric) + \
                self.indirect_light(points, normals, scene_triangle, barycentric)
        return self.output_light(light, scene_triangle)

    def sample_points(self, scene_triangle: np.ndarray,
                      barycentric: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where light is evaluated for surface points: (m, 3) barycentrics (those inside closed geometry moved to
        the nearest visible point of their face), (m, 3) world points inset from their piece's edges (so that rays
        from a crease do not start inside the other surface), and (m, 3) unit face normals."""
        barycentric = self._uncovered(scene_triangle, np.asarray(barycentric, dtype=np.float64))
        points = np.einsum("mc,mck->mk", barycentric, self.scene.triangles[scene_triangle])
        normals = triangle_unit_normals(self.scene.triangles[scene_triangle])
        solved, node = self.pieces(scene_triangle, barycentric)
        points[solved] = inset(points[solved], self.mesh.corners(node).mean(axis=1), 4 * self.offset_m)
        return barycentric, points, normals

    def _uncovered(self, scene_triangle: np.ndarray, barycentric: np.ndarray) -> np.ndarray:
        """Barycentrics of the points, those inside closed geometry (a decimated floor's corner under a wall)
        moved to the nearest free point of their triangle (core.surface_probes.nearest_uncovered): a vertex takes
        the light of the nearest visible point of its own face, as a texel is pushed out of geometry, and stays
        dark only when its whole face is hidden."""
        triangles = self.scene.triangles[scene_triangle]
        normals = triangle_unit_normals(triangles)
        # Tested a hair inside the face (as the point is lit): a wall's corner on the floor lies in the floor's
        # plane, where the probe rays graze the floor and meet it from behind.
        points = inset(np.einsum("mc,mck->mk", barycentric, triangles), triangles.mean(axis=1), 4 * self.offset_m)
        inside = np.flatnonzero(inside_closed_geometry(self.caster, self.scene.triangles, points, normals,
                                                       self.offset_m))
        out = barycentric.copy()
        out[inside] = nearest_uncovered(self.caster, self.scene.triangles, triangles[inside], barycentric[inside],
                                        self.offset_m)
        return out

    def output_light(self, light: np.ndarray, scene_triangle: np.ndarray) -> np.ndarray:
        """Light as outputs store it: 0 in the channels where the triangle's reflectance is 0 (Cycles' Diffuse
        bake without Color divides by the albedo, so a black surface bakes black), and never below 0 (the round-off
        of a solve and of interpolation weights, -1e-68 say, is no light)."""
        reflectance = self.scene.reflectance[self.scene.material_index[np.asarray(scene_triangle, dtype=np.int64)]]
        return np.where(reflectance == 0, 0.0, np.maximum(light, 0.0))

    def direct_light(self, points: np.ndarray, normals: np.ndarray, scene_triangle: np.ndarray,
                     barycentric: np.ndarray, samples_per_edge: int | None = None,
                     seed_offset: int = 0, world: bool = True, sources=None) -> np.ndarray:
        """(m, 3) direct light (irradiance / pi) at points by shadow rays; NaN on triangles that were not solved.
        ``seed_offset`` shifts the shadow rays' seed, for points lit in several calls. Shadow rays from
        smooth-shaded triangles start on their smooth surface (core.terminator). ``world`` False leaves the world
        out (a final gather's rays that escape bring it). ``sources``, a list of (light indices, whether the world
        and the emissive surfaces too): (S, m, 3) the light of each apart, each with the rays it has in the
        whole."""
        scene_triangle = np.asarray(scene_triangle, dtype=np.int64)
        solved = self._scene_to_mesh()[scene_triangle] >= 0
        lift = ShadowLift.at(self.scene, scene_triangle[solved], np.asarray(barycentric, dtype=np.float64)[solved],
                             normals[solved])
        parts = [(None, True)] if sources is None else sources
        out = np.full((len(parts), len(points), 3), np.nan)
        points, normals = points[solved], normals[solved]
        for part, (lights, rest) in zip(out, parts):
            part[solved] = self.direct.irradiance(points, normals, samples_per_edge, seed_offset, lift,
                                                  world and rest, lights=lights, emitters=rest) / np.pi
        return out[0] if sources is None else out

    def indirect_light(self, points: np.ndarray, normals: np.ndarray, scene_triangle: np.ndarray,
                       barycentric: np.ndarray) -> np.ndarray:
        """(m, 3) indirect light (irradiance / pi: the total minus what ``direct`` gives at the receivers)
        interpolated at surface points with unit (face) normals; NaN on triangles that were not solved."""
        return self._interpolate(self._indirect_light(), points, normals, scene_triangle, barycentric)

    def reflected_radiosity(self, scene_triangle: np.ndarray, barycentric: np.ndarray, side: np.ndarray,
                            seed_offset: int = 0, gather_samples_per_edge: int = 0,
                            exact_lights: int = 0) -> np.ndarray:
        """(m, 3) reflected radiosity rho H (W m^-2, emission excluded) on the given side (0 front, 1 back) of
        surface points: what a final-gather ray sees where it lands. The first bounce is exact at the point: the
        reflectance there (texture included) x (direct irradiance by one shadow ray to one light chosen by
        importance, after one to each of the ``exact_lights`` brightest there, ``seed_offset`` shifting their
        seed, + the indirect irradiance of the element side under it). So a sunlit patch and the shade beside it
        on one coarse element reflect what each receives (two-pass methods, radiosity paper section 10). With
        ``gather_samples_per_edge`` s > 0 the indirect irradiance is gathered there too, by s^2 rays
        (core.gather.final_gather, the world by its escaping rays, one light chosen where each lands), instead of
        taken from the element. 0 on dead sides, unsolved triangles, and the fronts of faces where they lie on
        another face in their plane (``_overlaps``)."""
        gathered = gather_samples_per_edge > 0
        lit, sides, reflectance, direct = self.landing(scene_triangle, barycentric, side, seed_offset, not gathered,
                                                       exact_lights)
        if gathered:
            on = np.asarray(scene_triangle, dtype=np.int64)[lit]
            points = np.einsum("mc,mck->mk", np.asarray(barycentric, dtype=np.float64)[lit],
                               self.scene.triangles[on])
            normals = self.scene.unit_normals[on] * np.where(sides % 2 == FRONT, 1.0, -1.0)[:, None]
            indirect = np.pi * final_gather(self, self.caster, points[:, None, :], normals, gather_samples_per_edge,
                                            self.offset_m, seed_offset)[0]
        else:
            indirect = np.pi * self._indirect_light().reshape(-1, 3)[sides]
        out = np.zeros((len(np.asarray(side)), 3))
        out[lit] = reflectance * (direct + indirect)
        return out

    def landing(self, scene_triangle: np.ndarray, barycentric: np.ndarray, side: np.ndarray, seed_offset: int = 0,
                world: bool = True, exact_lights: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Where rays land on the given sides (0 front, 1 back) of m surface points: (k,) the points on live
        element sides, (k,) those sides (element x 2 + side), (k, 3) the reflectance there (texture included; 0
        on the fronts of faces lying on another face in their plane, ``_overlaps``), and (k, 3) the direct
        irradiance there, W m^-2, by one shadow ray to one light chosen by importance after one to each of the
        ``exact_lights`` brightest (``seed_offset`` shifting their seed; ``world`` False leaves the world out)."""
        scene_triangle = np.asarray(scene_triangle, dtype=np.int64)
        barycentric = np.asarray(barycentric, dtype=np.float64)
        solved, node = self.pieces(scene_triangle, barycentric)
        element = self.elements.node_element[node]
        face = np.asarray(side, dtype=np.int64)[solved]
        alive = self.elements.alive[element, face]
        lit = np.flatnonzero(solved)[alive]
        triangles = self.scene.triangles[scene_triangle[lit]]
        points = np.einsum("mc,mck->mk", barycentric[lit], triangles)
        front = face[alive] == FRONT
        normals = self.scene.unit_normals[scene_triangle[lit]] * np.where(front, 1.0, -1.0)[:, None]
        direct = self.direct.irradiance(points, normals, 1, seed_offset, world=world, sampled=True,
                                        exact_lights=exact_lights)
        reflectance = self.scene.reflectance_at(scene_triangle[lit], barycentric[lit])
        overlapping = self._overlaps()(scene_triangle[lit[front]], barycentric[lit[front]])
        reflectance[np.flatnonzero(front)[overlapping]] = 0.0
        return lit, element[alive] * 2 + face[alive], reflectance, direct

    def _overlaps(self):
        """``on_another_face(scene_triangle, barycentric)``: (m,) surface points that lie on another face in their
        plane (core.surface_probes.overlap_test of the scene's triangles, built on first use). Cycles renders them
        black, its rays from them meeting the other face at distance zero, as the lightmap bakes them."""
        with _OVERLAPS_LOCK:  # chunks of texels lit side by side share it
            if self._overlap_test is None:
                self._overlap_test = overlap_test(self.scene.triangles, 4 * self.offset_m)
        return self._overlap_test

    def pieces(self, scene_triangle: np.ndarray, barycentric: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Solved mask (m,) of surface points, and for the solved ones the mesh leaf (piece) under each."""
        mesh_triangle = self._scene_to_mesh()[np.asarray(scene_triangle, dtype=np.int64)]
        solved = mesh_triangle >= 0
        node, _ = self.mesh.locate(mesh_triangle[solved], np.asarray(barycentric, dtype=np.float64)[solved])
        return solved, node

    def radiosity_mesh(self, lightings: list | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pieces of the solve's mesh with their light: (V, 3) vertices, (p, 3) triangles, (p, 3, 3) light
        at each piece's corners (interpolated, as ``evaluate`` without direct light per point); with
        ``lightings`` (G solutions of the same surfaces lit by parts of the light), (G, p, 3, 3) the light of
        each."""
        leaves = self.mesh.leaves
        vertices, corner_vertex = weld_vertices(self.mesh, leaves, self.offset_m / 10)
        scene_triangle = np.repeat(self.mesh.triangle_scene[self.mesh.node_triangle[leaves]], 3)
        barycentric = self.mesh.node_bary[leaves].reshape(-1, 3)
        light = np.stack([part.evaluate(scene_triangle, barycentric).reshape(-1, 3, 3)
                          for part in (lightings or [self])])
        return vertices, corner_vertex, light if lightings is not None else light[0]

    def _interpolate(self, values: np.ndarray, points, normals, scene_triangle, barycentric) -> np.ndarray:
        """(m, 3) per-side values (n, 2, 3) interpolated at surface points (NaN where not solved)."""
        solved, node = self.pieces(scene_triangle, barycentric)
        out = np.full((len(solved), 3), np.nan)
        own = self.elements.node_element[node] * 2 + FRONT
        out[solved] = self._receiver_field().interpolate(values.reshape(-1, 3), points[solved], normals[solved],
                                                         own)
        return out

    def _receiver_field(self) -> ReceiverField:
        if self._field is None:
            elements = self.elements
            self._field = ReceiverField(elements.point.reshape(-1, 3), elements.normal.reshape(-1, 3),
                                        np.repeat(elements.reach_m, 2), elements.alive.ravel(), self.caster,
                                        self.offset_m)
        return self._field

    def _irradiance(self) -> np.ndarray:
        """(n, 2, 3) irradiance at every receiver, W m^-2, ambient term included."""
        return self.elements.irradiance + self.ambient_irradiance

    def _total_light(self) -> np.ndarray:
        """(n, 2, 3) irradiance / pi at every receiver, ambient term included."""
        return self._irradiance() / np.pi

    def _indirect_light(self) -> np.ndarray:
        """(n, 2, 3) indirect light at every receiver, over pi, ambient term included (computed once; 0 on dead
        sides): what it gathered from reflected light, or else its irradiance minus what ``direct`` gives there."""
        if self._indirect is None and self.elements.indirect_irradiance is not None:
            indirect = self.elements.indirect_irradiance + self.ambient_irradiance
            self._indirect = np.where(self.elements.alive[..., None], indirect, 0.0) / np.pi
        if self._indirect is None:
            elements = self.elements
            alive = elements.alive.ravel()
            points, normals = elements.point.reshape(-1, 3)[alive], elements.normal.reshape(-1, 3)[alive]
            indirect = np.zeros((2 * elements.count, 3))
            total = self._irradiance().reshape(-1, 3)[alive]
            indirect[alive] = np.maximum(total - self.direct.irradiance(points, normals), 0.0) / np.pi
            self._indirect = indirect.reshape(-1, 2, 3)
        return self._indirect

    def _scene_to_mesh(self) -> np.ndarray:
        """Scene triangle -> mesh triangle (-1 if not solved), built once."""
        if self._to_mesh is None:
            self._to_mesh = self.mesh.scene_to_mesh(len(self.scene.triangles))
        return self._to_mesh
