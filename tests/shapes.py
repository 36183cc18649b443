"""Test geometry: boxes, quads and spheres as (T, 3, 3) triangle arrays, and scenes built of them."""
from __future__ import annotations

import numpy as np

from core import Material, Scene, SunLight
from core.bake import ray_offset_m


def quad(a, b, c, d) -> np.ndarray:
    """Two triangles of the planar quad a-b-c-d (counter-clockwise seen from the front)."""
    a, b, c, d = (np.asarray(p, dtype=np.float64) for p in (a, b, c, d))
    return np.stack([np.stack([a, b, c]), np.stack([a, c, d])])


def box_faces(lo=(0, 0, 0), hi=(1, 1, 1), inward=True) -> list[np.ndarray]:
    """Six faces of an axis-aligned box as lists of 2 triangles: -x, +x, -y, +y, -z (floor), +z (ceiling).

    ``inward`` orients normals into the box (a room); otherwise out of it (a solid block).
    """
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    faces = [
        quad((x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)),  # -x, normal +x
        quad((x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)),  # +x, normal -x
        quad((x0, y0, z0), (x0, y0, z1), (x1, y0, z1), (x1, y0, z0)),  # -y, normal +y
        quad((x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)),  # +y, normal -y
        quad((x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)),  # floor, normal +z
        quad((x0, y0, z1), (x0, y1, z1), (x1, y1, z1), (x1, y0, z1)),  # ceiling, normal -z
    ]
    return faces if inward else [f[:, ::-1] for f in faces]


def uv_sphere(radius: float, bands_z: np.ndarray, segments: int, ring_height: float = 0.05, inward: bool = True):
    """Triangles of a sphere cut into latitude bands at the given z values (z from -r to r), each band made of
    rings of about ``ring_height`` and ``segments`` around.

    Returns (triangles, band index per triangle). Normals face the centre when ``inward``.
    """
    tris, band = [], []
    angles = np.linspace(0, 2 * np.pi, segments + 1)
    edges = [np.linspace(lo, hi, int(np.ceil((hi - lo) / ring_height)) + 1)
             for lo, hi in zip(bands_z[:-1], bands_z[1:])]
    rings = [(b, z0, z1) for b, e in enumerate(edges) for z0, z1 in zip(e[:-1], e[1:])]
    for b, z0, z1 in rings:
        r0, r1 = np.sqrt(max(radius ** 2 - z0 ** 2, 0)), np.sqrt(max(radius ** 2 - z1 ** 2, 0))
        for a0, a1 in zip(angles[:-1], angles[1:]):
            p00 = (r0 * np.cos(a0), r0 * np.sin(a0), z0)
            p01 = (r0 * np.cos(a1), r0 * np.sin(a1), z0)
            p10 = (r1 * np.cos(a0), r1 * np.sin(a0), z1)
            p11 = (r1 * np.cos(a1), r1 * np.sin(a1), z1)
            for t in ((p00, p10, p11), (p00, p11, p01)):
                t = np.array(t)
                if np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0])) > 1e-12:
                    tris.append(t if inward else t[::-1])
                    band.append(b)
    return np.array(tris), np.array(band)


def sunlit_arcade() -> Scene:
    """A 12 x 4 m arcade floor (reflectance 0.01) under a ceiling 3 m up (0.7) and a black back wall, open on one
    side to a 12 x 8 m ground (0.8) under a sun of 3 W/m^2 straight above: the floor's light all comes off the
    ceiling, which the sunlit ground lights from beside the arcade. Material order: ground, floor, ceiling, wall."""
    ground = quad((-6, 0, 0), (6, 0, 0), (6, 8, 0), (-6, 8, 0))
    floor = quad((-6, -4, 0), (6, -4, 0), (6, 0, 0), (-6, 0, 0))
    ceiling = quad((-6, -4, 3), (-6, 0, 3), (6, 0, 3), (6, -4, 3))
    wall = quad((-6, -4, 0), (-6, -4, 3), (6, -4, 3), (6, -4, 0))
    return Scene(np.concatenate([ground, floor, ceiling, wall]), [0, 0, 1, 1, 2, 2, 3, 3],
                 [Material(name, (value,) * 3) for name, value in
                  (("ground", 0.8), ("floor", 0.01), ("ceiling", 0.7), ("wall", 0.0))],
                 lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])


def floor_under_near_sheet(floor: np.ndarray, facing: str) -> tuple[Scene, float]:
    """The given floor (triangles in z = 0 about the origin) in a level 1 km across (a far marker sets the scene's
    size, so the ray offset is 2 cm), under a sun straight above (3 W/m^2), with a sheet 1 m square lying over its
    middle a little tilted: 0.2 to 0.8 of the ray offset above the floor, facing "down" (a single-sided shell) or
    "up". All grey (0.5); triangles in the order floor, marker (2), sheet (2). Returns the scene and its offset."""
    marker = quad((999.9, -0.05, 0), (1000, -0.05, 0), (1000, 0.05, 0), (999.9, 0.05, 0))
    sun = SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)
    grey = [Material("grey", (0.5,) * 3)]
    offset = ray_offset_m(Scene(np.concatenate([floor, marker]), np.zeros(len(floor) + 2, int), grey, lights=[sun]))
    low, high = 0.2 * offset, 0.8 * offset
    corners = [(-0.5, -0.5, low), (0.5, -0.5, high), (0.5, 0.5, high), (-0.5, 0.5, low)]
    sheet = quad(*(corners if facing == "up" else corners[::-1]))
    triangles = np.concatenate([floor, marker, sheet])
    return Scene(triangles, np.zeros(len(triangles), int), grey, lights=[sun]), offset


def sheet_before_sunlit_wall(gap_m: float = 0.03) -> Scene:
    """A 6 x 3 m wall facing -y (reflectance 0.5) in a sun of 3 W/m^2 at 45 degrees, over a black ground (4 m
    deep), with a single-sided sheet 1.2 m square (0.5) hanging ``gap_m`` in front of it, 0.9 to 2.1 m up and facing
    away from it. Triangles in the order wall, ground, sheet (2 each)."""
    wall = quad((-3, 0, 0), (3, 0, 0), (3, 0, 3), (-3, 0, 3))
    ground = quad((-3, -4, 0), (3, -4, 0), (3, 0, 0), (-3, 0, 0))
    y = -gap_m
    sheet = quad((-0.6, y, 0.9), (0.6, y, 0.9), (0.6, y, 2.1), (-0.6, y, 2.1))
    return Scene(np.concatenate([wall, ground, sheet]), [0, 0, 1, 1, 0, 0],
                 [Material("grey", (0.5,) * 3), Material("black", (0.0,) * 3)],
                 lights=[SunLight("sun", (0.0, 1.0, -1.0), strength_w_m2=3.0)])


def soffit_into_open_block(gap_m: float) -> Scene:
    """A soffit 4 x 2 m facing down 3 m up (reflectance 0.7), tessellated into 0.25 m squares as imported meshes
    are, over a sunlit ground (0.8, a sun of 3 W/m^2 straight above). Its last 2.5 m run into an open block
    (0.6: single-sided faces facing out, its bottom ``gap_m`` under the soffit, its far end and long sides
    missing), so that part lies in a slot lit only through its narrow openings. Triangles in the order ground
    (2), soffit, block."""
    ground = quad((-6, -4, 0), (6, -4, 0), (6, 4, 0), (-6, 4, 0))
    soffit = np.concatenate([quad((x, y, 3), (x, y + 0.25, 3), (x + 0.25, y + 0.25, 3), (x + 0.25, y, 3))
                             for x in np.arange(-2, 2, 0.25) for y in np.arange(-1, 1, 0.25)])
    near_end, bottom, top = (box_faces((-0.5, -1, 3 - gap_m), (2.5, 1, 3.5), inward=False)[k] for k in (0, 4, 5))
    triangles = np.concatenate([ground, soffit, near_end, bottom, top])
    materials = [0] * 2 + [1] * len(soffit) + [2] * 6
    return Scene(triangles, materials, [Material(name, (value,) * 3) for name, value in
                                        (("ground", 0.8), ("soffit", 0.7), ("block", 0.6))],
                 lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=3.0)])
