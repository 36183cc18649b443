"""Direct light at arbitrary surface points: analytic lights, the world and emissive surfaces, with shadow rays.

Outputs evaluate the direct part here, point by point, and interpolate only the smooth indirect part between
elements (radiosity paper, section 10: ray tracing for what is sharp, radiosity for what is diffuse). So a shadow
edge or a corner is as sharp as the sampling, whatever the element size.

Emissive surfaces are their own sources, whatever the solver: the emissive triangles, cut into pieces of at most
``emitter_size_m`` and grouped into face clusters (core.clusters), each seen through the link form factors
(core.links: Lambert's exact factor times s x s shadow rays for a piece on its own).
"""
from __future__ import annotations

import numpy as np

from .cluster_tree import build_tree
from .clusters import SAMPLES, cluster_pieces
from .analytic_lights import direct_irradiance, sampled_irradiance
from .links import LinkSources, link_factors
from .mesh import build_mesh, node_reflectance
from .raycast import RayCaster
from .scene import Scene

POINTS_PER_STEP = 1 << 14


class DirectLighting:
    """Irradiance (W m^-2) straight from the lights, the world and emissive surfaces (their emitted exitance
    only, from the front of their faces)."""

    def __init__(self, scene: Scene, caster: RayCaster, emitter_size_m: float, offset_m: float,
                 samples_per_edge: int, seed: int):
        self.scene, self.caster, self.offset_m = scene, caster, offset_m
        self.samples_per_edge, self.seed = samples_per_edge, seed
        emissive = scene.emissive & ~scene.casts_only
        self.sources, self.exitance = None, np.zeros((0, 3))
        if emissive.any():
            mesh = build_mesh(scene, emitter_size_m, emitter_size_m, np.flatnonzero(emissive))
            clusters = cluster_pieces(mesh, scene, caster, emitter_size_m, offset_m,
                                      node_reflectance(mesh, scene, mesh.leaves))
            front = np.zeros((clusters.count, 2, SAMPLES))
            front[:, 0] = (clusters.area_m2 / SAMPLES)[:, None]  # emitters shine from the front of their faces
            tree = build_tree(clusters.centroid, clusters.low, clusters.high, clusters.normal, front,
                              clusters.sample_point, clusters.sample_normal)
            self.sources, self.exitance = LinkSources.of(tree, clusters, offset_m), clusters.emitted_exitance
            self.leaves, self.front_class = tree.leaf_of, tree.side_class[:, 0]

    @property
    def emitter_count(self) -> int:
        return len(self.exitance)

    def irradiance(self, points: np.ndarray, normals: np.ndarray, samples_per_edge: int | None = None,
                   seed_offset: int = 0, lift=None, world: bool = True, sampled: bool = False,
                   exact_lights: int = 0, lights=None, emitters: bool = True) -> np.ndarray:
        """(m, 3) direct irradiance at points with unit normals; ``samples_per_edge`` overrides the shadow-ray
        count (s^2 per light and emitter); ``seed_offset`` is added to the bake's seed; ``lift``
        (core.terminator.ShadowLift) starts the shadow rays towards lamps and emissive surfaces from smooth-shaded
        points on their smooth surface (core.terminator); ``world`` False leaves the world out; ``sampled``:
        one shadow ray per point to each of its ``exact_lights`` brightest analytic lights and one to one of the
        others, chosen by importance (core.analytic_lights.sampled_irradiance; unbiased, noisier), with one
        sample per edge. Not sampled, ``lights`` (indices into the scene's) leaves the other lights out, and
        ``emitters`` False the emissive surfaces, each part with the rays it has in the whole."""
        samples = samples_per_edge or self.samples_per_edge
        if sampled:
            total = sampled_irradiance(self.scene, self.caster, points, normals, self.offset_m,
                                       self.seed + seed_offset, world, exact_lights)
        else:
            total = direct_irradiance(self.scene, self.caster, points, normals, self.offset_m, samples,
                                      self.seed + seed_offset, lift, world, lights)
        if self.sources is None or not emitters:
            return total
        count = self.emitter_count
        step = max(1, POINTS_PER_STEP // count)
        for start in range(0, len(points), step):  # every point with every emitter, a block of points at a time
            rows = np.arange(start, min(start + step, len(points)))
            point, emitter = np.repeat(rows, count), np.tile(np.arange(count), len(rows))
            factor, _, _ = link_factors(self.sources, self.caster, points[point], normals[point],
                                        self.leaves[emitter], samples, self.offset_m,
                                        None if lift is None else lift[point])
            front = factor[np.arange(len(point)), self.front_class[emitter]][:, None]  # they shine from the front
            total[rows] += (front * self.exitance[emitter]).reshape(len(rows), count, 3).sum(axis=1)
        return total
