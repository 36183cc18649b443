"""Reflectance textures: a material's base-colour image, averaged over each element's footprint, so a checker
floor reflects (and bleeds) the colour of the squares an element covers rather than the whole image's mean.

Images are (height, width, 3) linear RGB with row 0 at the bottom (Blender's order) and repeat outside [0, 1];
lookups take the nearest texel at s x s stratified points of each element (the centroids of a uniform
subdivision, as the form factors sample patches).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .geometry import triangle_sample_barycentrics

FOOTPRINT_SAMPLES_PER_EDGE = 4


@dataclass(frozen=True)
class ReflectanceTexture:
    """A base-colour image (values in [0, 1)) and the name of the UV map it is read through ("" = the mesh's
    default)."""

    pixels: np.ndarray = field(compare=False, repr=False)
    uv_map: str = ""

    def lookup(self, uv: np.ndarray) -> np.ndarray:
        """(..., 3) nearest-texel colour at (..., 2) UVs, repeating outside [0, 1)."""
        height, width = self.pixels.shape[:2]
        x = np.floor(np.mod(uv[..., 0], 1.0) * width).astype(np.int64) % width
        y = np.floor(np.mod(uv[..., 1], 1.0) * height).astype(np.int64) % height
        return self.pixels[y, x, :3]

    def footprint_mean(self, corner_uv: np.ndarray) -> np.ndarray:
        """(n, 3) mean colour over (n, 3, 2) UV triangles (elements)."""
        bary = triangle_sample_barycentrics(FOOTPRINT_SAMPLES_PER_EDGE)
        return self.lookup(np.einsum("sc,nck->nsk", bary, corner_uv)).mean(axis=1)
