"""Light at mesh corners the solved triangles do not hold: a mesh whose modifiers changed its topology keeps its
original corners, which lie on or near the rendered surface but on none of its triangles.

Each corner casts two rays along its normal line, one from ``reach_m`` in front of it looking back and one from
``reach_m`` behind it looking forward, and takes the light at the hit nearer to the corner on the object's solved
triangles (direct light traced at that point, indirect interpolated: core.solution.Solution.evaluate). So a
surface up to ``reach_m`` on either side is found even when the corner lies inside it; a corner whose normal line
meets none of the triangles stays black.
"""
from __future__ import annotations

import numpy as np

from .geometry import lengths
from .raycast import RayCaster


def projected_light(solution, triangles: np.ndarray, points: np.ndarray, normals: np.ndarray,
                    reach_m: float) -> np.ndarray:
    """(m, 3) light at (m, 3) world points with unit normals, taken where their normal lines meet the given
    solved scene triangles nearest to them (rays from ``reach_m`` out on either side)."""
    caster = RayCaster(solution.scene.triangles[triangles], threads=1)
    best = np.full(len(points), np.inf)
    light = np.zeros((len(points), 3))
    try:
        for sign in (1.0, -1.0):
            hit, bary = caster.first_hit(points + sign * reach_m * normals, -sign * normals)
            found = np.flatnonzero(hit >= 0)
            hit_points = np.einsum("mc,mck->mk", bary[found], solution.scene.triangles[triangles[hit[found]]])
            distance = lengths(hit_points - points[found])
            nearer = distance < best[found]
            closer = found[nearer]
            best[closer] = distance[nearer]
            light[closer] = solution.evaluate(triangles[hit[closer]], bary[closer], direct_per_point=True)
    finally:
        caster.close()
    return np.nan_to_num(light)
