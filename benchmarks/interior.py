"""Interior benchmark scene: a 6 x 5 x 3 m room with furniture-like boxes and one area light in the ceiling."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from core import AreaLight, Material, Scene  # noqa: E402
from shapes import box_faces  # noqa: E402

# (lower corner, upper corner, material) of solid blocks standing in the room
FURNITURE = [
    ((1.0, 1.0, 0.0), (2.6, 1.9, 0.75), 1),   # table
    ((1.2, 2.3, 0.0), (1.7, 2.8, 0.45), 2),   # chair
    ((2.0, 2.3, 0.0), (2.5, 2.8, 0.45), 2),   # chair
    ((0.0, 3.8, 0.0), (2.4, 4.2, 2.0), 3),    # shelf against the back wall
    ((4.3, 0.4, 0.0), (5.6, 2.4, 0.5), 1),    # bed / sofa
    ((4.6, 3.6, 0.0), (5.6, 4.6, 1.1), 2),    # cabinet
]


def interior_scene() -> Scene:
    room = box_faces((0, 0, 0), (6, 5, 3))
    triangles, material = [np.concatenate(room)], [np.zeros(12, int)]
    for lo, hi, mat in FURNITURE:
        faces = box_faces(lo, hi, inward=False)
        faces = faces[:4] + faces[5:]  # standing on the floor: no bottom face
        triangles.append(np.concatenate(faces))
        material.append(np.full(10, mat))
    materials = [Material("plaster", (0.7, 0.68, 0.65)), Material("wood", (0.45, 0.3, 0.18)),
                 Material("fabric", (0.2, 0.35, 0.6)), Material("painted", (0.75, 0.2, 0.15))]
    light = AreaLight("ceiling light", (3.0, 2.5, 2.99), (0.0, 0.0, -1.0), power_w=400.0, shape="RECTANGLE",
                      size_m=1.2, size_y_m=0.6)
    return Scene(np.concatenate(triangles), np.concatenate(material), materials, lights=[light],
                 object_names=["room"])
