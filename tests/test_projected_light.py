"""Corners off the solved surface (a mesh whose modifiers changed its topology) take the light of the nearest
surface point along their normal: a lone floor under a sun overhead of strength S holds S / pi everywhere
(irradiance / pi; nothing else in the scene, so no indirect light)."""
import numpy as np
import pytest

from core import BakeSettings, Material, Scene, SunLight, bake
from core.projected_light import projected_light
from shapes import quad

STRENGTH = 3.0


def test_corners_above_and_below_the_floor_take_its_light_and_those_beside_it_stay_black():
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    scene = Scene(floor, np.zeros(2, int), [Material("grey", (0.5,) * 3)],
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=STRENGTH)])
    solution = bake(scene, BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    points = np.array([[0.2, 0.3, 0.01], [-0.5, 0.1, -0.02], [0.9, -0.9, 0.0], [3.0, 0.0, 0.0]])
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    light = projected_light(solution, np.arange(2), points, normals, reach_m=0.1)
    assert light[:3] == pytest.approx(STRENGTH / np.pi, rel=1e-3)
    assert light[3] == pytest.approx(0.0, abs=1e-12)  # its normal line misses the floor
