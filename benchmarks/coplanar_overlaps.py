"""Texels on faces that another object's face covers in the same plane, facing the same way (two arcades'
single-sided ceilings running into each other at a corner). Cycles bakes and renders such a pair black: the rays
from one face hit the other at distance zero (benchmarks/coplanar_render.py). The baker gives them no light either
(core.surface_probes.other_face_test); the benchmarks give the error against Cycles with and without these texels,
so that the rest of the scene is measured apart from them. A texel counts where any point of its footprint does:
Cycles' samples spread over the texel's square, so a texel beside such a pair bakes partly black too."""
from __future__ import annotations

import numpy as np

from radiosity_baker.core.surface_probes import inside_any_triangle, triangle_planes
from radiosity_baker.core.texels import footprint_barycentrics, footprint_inside, footprint_steps, rasterize

PLANE_TOLERANCE_M = 1e-3
FOOTPRINT_SAMPLES_PER_EDGE = 4


def coplanar_overlap_texels(scene, scene_triangle: np.ndarray, corner_uv: np.ndarray, width: int,
                            height: int) -> np.ndarray:
    """(height, width) True for texels (centre inside a triangle of the page: ``scene_triangle`` (t,) with UVs
    ``corner_uv`` (t, 3, 2)) with a point of their footprint (k x k points, k = FOOTPRINT_SAMPLES_PER_EDGE; those
    in the texel's own triangle, where Cycles' samples land) inside a triangle of another object in the same plane
    (within PLANE_TOLERANCE_M) with the same facing."""
    triangles = scene.triangles
    _, plane_of, normals = triangle_planes(triangles, PLANE_TOLERANCE_M)
    texels = rasterize(np.asarray(corner_uv, dtype=np.float64), width, height)
    inside = texels.centre_inside
    steps = footprint_steps(texels, corner_uv)[inside]
    footprint = footprint_barycentrics(texels.barycentric[inside], steps, FOOTPRINT_SAMPLES_PER_EDGE)
    in_triangle = footprint_inside(texels.barycentric[inside], steps, FOOTPRINT_SAMPLES_PER_EDGE).ravel()
    per_texel = footprint.shape[1]
    tri = np.repeat(np.asarray(scene_triangle)[texels.triangle[inside]], per_texel)
    points = np.einsum("mc,mck->mk", footprint.reshape(-1, 3), triangles[tri])
    overlap = np.zeros(len(tri), dtype=bool)
    for plane in np.unique(plane_of[tri]):  # one step per plane, over the other objects' triangles in it
        here = np.flatnonzero(plane_of[tri] == plane)
        for obj in np.unique(scene.object_index[tri[here]]):
            mine = here[scene.object_index[tri[here]] == obj]
            others = np.flatnonzero((plane_of == plane) & (scene.object_index != obj))
            if len(others):
                overlap[mine] = inside_any_triangle(points[mine], normals[tri[mine]], triangles[others],
                                                    PLANE_TOLERANCE_M)
    image = np.zeros(width * height, dtype=bool)
    image[texels.pixel[inside][(overlap & in_triangle).reshape(-1, per_texel).any(axis=1)]] = True
    return image.reshape(height, width)
