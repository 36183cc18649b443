"""Form factors against Howell's catalogue and closed forms (values and sources in docs/references.md).

Tolerances: ray-cast (Lambert's exact kernel x shadow rays) within 0.5%; hemicube within 1% at resolution 128,
with its error falling as the resolution grows.
"""
import numpy as np
import pytest

from core.formfactor import hemicube_delta_form_factors, point_to_polygon
from formfactor_setup import area_form_factor, disk, disk_outline
from shapes import quad


def parallel(a, b, gap):
    """Receiver a x b rectangle on z = 0 facing up, source directly above at z = gap facing down."""
    return (quad((0, 0, 0), (a, 0, 0), (a, b, 0), (0, b, 0)),
            quad((0, 0, gap), (0, b, gap), (a, b, gap), (a, 0, gap)))


def perpendicular(width_from, width_to, edge=1.0):
    """Receiver on the floor (y in [0, width_from]), source on the wall y = 0 (z in [0, width_to]), common edge
    along x of length ``edge``."""
    return (quad((0, 0, 0), (edge, 0, 0), (edge, width_from, 0), (0, width_from, 0)),
            quad((0, 0, 0), (0, 0, width_to), (edge, 0, width_to), (edge, 0, 0)))


# (name, receiver, source, Howell value, element size, patch size)
CASES = [
    ("unit squares, gap 1 (C-11)", *parallel(1, 1, 1), 0.199825, 0.1, 0.125),
    ("squares 0.1 at gap 0.05", *parallel(0.1, 0.1, 0.05), 0.415253, 0.01, 0.0125),
    ("1 x 1.5 rectangles at gap 0.5", *parallel(1, 1.5, 0.5), 0.475576, 0.1, 0.125),
    ("perpendicular unit squares (C-14)", *perpendicular(1, 1), 0.200044, 0.04, 0.25),
    ("perpendicular 1 -> 2", *perpendicular(1, 2), 0.232853, 0.04, 0.25),
    ("perpendicular 2 -> 1", *perpendicular(2, 1), 0.116426, 0.04, 0.25),
    ("coaxial disks r 1, gap 1", disk(1, 0, 48), disk(1, 1, 48, facing_up=False), 0.381966, 0.25, 0.5),
    ("coaxial disks r 0.5 -> 1, gap 2", disk(0.5, 0, 48), disk(1, 2, 48, facing_up=False), 0.192236, 0.25, 0.5),
]


@pytest.mark.parametrize("name, receiver, source, expected, element, patch", CASES, ids=[c[0] for c in CASES])
def test_ray_cast_matches_howell_within_half_percent(name, receiver, source, expected, element, patch):
    value = area_form_factor(receiver, source, "raycast", element, patch)
    assert value == pytest.approx(expected, rel=0.005)


HEMICUBE_CASES = [c for c in CASES if not c[0].startswith("perpendicular 2")]


@pytest.mark.parametrize("name, receiver, source, expected, element, patch", HEMICUBE_CASES,
                         ids=[c[0] for c in HEMICUBE_CASES])
def test_hemicube_matches_howell_within_one_percent_at_resolution_128(name, receiver, source, expected, element,
                                                                      patch):
    value = area_form_factor(receiver, source, "hemicube", max(element, patch), patch, hemicube_resolution=128)
    assert value == pytest.approx(expected, rel=0.01)


def test_hemicube_error_falls_with_resolution():
    receiver, source = parallel(1, 1, 1)
    errors = [abs(area_form_factor(receiver, source, "hemicube", 0.125, 0.125, hemicube_resolution=r) / 0.199825 - 1)
              for r in (4, 16, 128)]
    assert errors[2] < errors[1] < errors[0]


def test_hemicube_delta_form_factors_sum_to_one():
    for resolution in (16, 64, 256):
        assert hemicube_delta_form_factors(resolution)[1].sum() == pytest.approx(1.0, abs=2.0 / resolution ** 2 * 10)


@pytest.mark.parametrize("polygon, expected", [
    (np.array([[-0.5, -0.5, 1], [0.5, -0.5, 1], [0.5, 0.5, 1], [-0.5, 0.5, 1]]), 0.239456),  # Howell, unit square
    (disk_outline(1.0, 1.0, 512), 0.5),  # coaxial disk, radius = height
    (disk_outline(0.5, 2.0, 512), 0.25 / 4.25),  # general: r^2 / (h^2 + r^2)
])
def test_point_to_polygon_differential_cases(polygon, expected):
    value = point_to_polygon(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), polygon[None])[0]
    assert value == pytest.approx(expected, rel=1e-3)


def test_polygon_below_the_horizon_is_clipped():
    """A unit square seen edge-on from a point in its plane, tilted so half lies below: only the upper half counts."""
    upper = np.array([[-1, 1, 0], [1, 1, 0], [1, 1, 1], [-1, 1, 1.0]])
    straddling = np.array([[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1.0]])
    point, normal = np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]])
    assert point_to_polygon(point, normal, straddling[None])[0] == pytest.approx(
        point_to_polygon(point, normal, upper[None])[0], rel=1e-12)
    assert point_to_polygon(point, normal, (upper * [1, 1, -1])[None])[0] == 0.0
