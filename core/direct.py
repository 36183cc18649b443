"""Direct light at arbitrary surface points: analytic lights plus emissive patches, both with shadow rays.

Outputs evaluate the direct part here, point by point, and interpolate only the smooth indirect part between
elements (radiosity paper, section 10: ray tracing for what is sharp, radiosity for what is diffuse). So a shadow
edge or a corner is as sharp as the sampling, whatever the element size.
"""
from __future__ import annotations

import numpy as np

from .lights import direct_irradiance
from .mesh import Elements
from .raycast import RayCaster
from .scene import Scene
from .shooting import Patches, RayCastRows


class DirectLighting:
    """Irradiance (W m^-2) straight from the lights and from emissive patches (their emitted exitance only)."""

    def __init__(self, scene: Scene, caster: RayCaster, patches: Patches, patch_emission: np.ndarray,
                 offset_m: float, samples_per_edge: int, seed: int):
        self.scene, self.caster, self.offset_m = scene, caster, offset_m
        self.samples_per_edge, self.seed = samples_per_edge, seed
        self.emitters = np.flatnonzero(patch_emission.max(axis=1) > 0)
        self.emission = patch_emission[self.emitters]
        self.patches = patches
        self._rows = {samples_per_edge: RayCastRows(caster, patches, samples_per_edge, offset_m)}

    def irradiance(self, points: np.ndarray, normals: np.ndarray, own_patch: np.ndarray | None = None,
                   samples_per_edge: int | None = None, seed_offset: int = 0, lift=None) -> np.ndarray:
        """(m, 3) direct irradiance at points with unit normals; ``own_patch`` (m,) excludes each point's patch;
        ``samples_per_edge`` overrides the shadow-ray count (s^2 per light and emitter); ``seed_offset`` is added
        to the bake's seed; ``lift`` (core.terminator.ShadowLift) starts the shadow rays towards lamps and
        emissive patches from smooth-shaded points on their smooth surface (core.terminator)."""
        samples = samples_per_edge or self.samples_per_edge
        total = direct_irradiance(self.scene, self.caster, points, normals, self.offset_m, samples,
                                  self.seed + seed_offset, lift)
        if samples not in self._rows:
            self._rows[samples] = RayCastRows(self.caster, self.patches, samples, self.offset_m)
        rows = self._rows[samples]
        if len(self.emitters):
            count = len(points)
            receivers = Elements(node=np.arange(count), patch=np.full(count, -1) if own_patch is None else own_patch,
                                 corners=None, centroid=points, normal=normals, area_m2=None, reflectance=None,
                                 emitted_exitance=None, exposed_m2=None)
            for start in range(0, len(self.emitters), 64):
                block = self.emitters[start:start + 64]
                total += rows.block(block, receivers, lift) @ self.emission[start:start + 64]
        return total
