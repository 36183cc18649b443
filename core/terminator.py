"""Shadow rays from smooth-shaded triangles start on the smooth surface the shading normals imply, as in Cycles.

A low-poly sphere shaded smooth has shading normals that face a light the flat triangle itself turns away from; a
shadow ray from the flat triangle then hits the mesh's own facets, and the terminator turns into a jagged staircase.
Cycles (kernel/light/sample.h: shadow_ray_smooth_surface_offset, shadow_ray_offset; Hanika 2021, "Hacking the shadow
terminator", Ray Tracing Gems II, ch. 4) lifts the origin of such grazing shadow rays onto a parabolic surface
through the corners, tangent to their normals. We do the same, so a smooth low-poly mesh bakes the light Cycles
bakes, with each object's "Shadow Terminator > Geometry Offset" (Blender's default 0.1; 0 turns it off). Applied to
the shadow rays towards lamps and emissive patches; the world's rays (which Cycles mostly traces as BSDF samples)
still start from the flat triangle. Concave lifts (which would put the origin below the triangle, where Cycles skips
the triangle itself and we cannot) are left out.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import triangle_unit_normals


@dataclass(frozen=True)
class ShadowLift:
    """Per point: ``lift`` (m, 3) to the smooth surface, unit ``shading`` and ``geometric`` normals (m, 3) and
    the ``cutoff`` (m,), its object's geometry offset."""

    lift: np.ndarray
    shading: np.ndarray
    geometric: np.ndarray
    cutoff: np.ndarray

    @classmethod
    def at(cls, scene, scene_triangle: np.ndarray, barycentric: np.ndarray, shading: np.ndarray):
        """The lift at surface points of a core.Scene, or None when every point is on a flat triangle or on an
        object whose offset is 0."""
        triangles, cutoff = scene.triangles[scene_triangle], scene.terminator_offset[scene_triangle]
        lift = smooth_surface_lift(triangles, scene.corner_normals[scene_triangle], barycentric)
        lift[cutoff <= 0] = 0.0
        return cls(lift, shading, triangle_unit_normals(triangles), cutoff) if lift.any() else None

    def __getitem__(self, rows) -> "ShadowLift":
        return ShadowLift(self.lift[rows], self.shading[rows], self.geometric[rows], self.cutoff[rows])

    def origins(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(m, s, 3) origins of shadow rays along (m, s, 3) unit directions, lifted (lifted_origins)."""
        return lifted_origins(origins, directions, self.lift, self.shading, self.geometric, self.cutoff)


def smooth_surface_lift(triangles_m: np.ndarray, corner_normals: np.ndarray,
                        barycentric: np.ndarray) -> np.ndarray:
    """(m, 3) lift (metres, along the interpolated normal) from points on (m, 3, 3) triangles with (m, 3, 3) unit
    corner normals to the smooth surface they imply: the larger of the parabolic patch's height and the lowest
    of the corners' linear envelopes (Hanika 2021); zero on flat triangles."""
    V, N = triangles_m, corner_normals
    u, v = barycentric[:, 0], barycentric[:, 1]
    point = np.einsum("mc,mck->mk", barycentric, V)
    normal = np.einsum("mc,mck->mk", barycentric, N)
    dot = lambda x, y: np.einsum("mk,mk->m", x, y)
    a = dot(N[:, 2] - N[:, 0], V[:, 0] - V[:, 2])
    b = dot(N[:, 2] - N[:, 1], V[:, 1] - V[:, 2])
    c = dot(N[:, 1] - N[:, 0], V[:, 1] - V[:, 0])
    parabolic = a * u * (u - 1) + (a + b + c) * u * v + b * v * (v - 1)
    envelope = np.full(len(point), np.inf)
    for k in range(3):  # each corner's tangent plane, raised to its two other corners
        others = [j for j in range(3) if j != k]
        rise = np.maximum.reduce([dot(V[:, j] - V[:, k], N[:, k]) for j in others] + [np.zeros(len(point))])
        envelope = np.minimum(envelope, np.maximum(dot(V[:, k] - point, N[:, k]) + rise, 0.0))
    height = np.maximum(envelope, 0.5 * parabolic)
    agree = dot(normal, triangle_unit_normals(V)) > 0  # corner normals turned against the winding: no lift
    return normal * np.where(agree, np.maximum(height, 0.0), 0.0)[:, None]


def lifted_origins(origins: np.ndarray, directions: np.ndarray, lift: np.ndarray, shading_normals: np.ndarray,
                   geometric_normals: np.ndarray, cutoff: np.ndarray) -> np.ndarray:
    """(m, s, 3) shadow-ray origins moved by the share of each point's (m, 3) lift that Cycles applies to a ray
    along each (m, s, 3) unit direction: all of it once the direction grazes the flat triangle (its cosine with
    the geometric normal below the (m,) cutoff), fading to none above it (shadow_ray_offset)."""
    cos_shading = np.abs(np.einsum("msk,mk->ms", directions, shading_normals))
    cos_geometric = np.einsum("msk,mk->ms", directions, geometric_normals)
    cutoff = np.maximum(cutoff, 1e-12)[:, None]
    amount = np.where(cos_shading < cutoff, np.clip(2.0 - (cos_geometric + cos_shading) / cutoff, 0.0, 1.0),
                      np.clip(1.0 - cos_geometric / cutoff, 0.0, 1.0))
    return origins + amount[..., None] * lift[:, None, :]
