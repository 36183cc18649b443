"""Light from a near, unevenly lit surface against the closed form for a point over a parallel rectangle: the
classic solvers' near-field links (core.nearfield) and the hierarchical solver's element links."""
import numpy as np
import pytest

from core import BakeCancelled, BakeSettings, Material, Scene, SunLight, bake
from shapes import quad

FLOOR_REFLECTANCE = 0.5
RECEIVER_HEIGHT_M = 0.2
RECEIVER_X_M = -0.1


def corner_factor(a, b, height):
    """Differential area to a parallel a x b rectangle, the area above one of its corners at ``height`` (Howell
    B-3): 1/(2 pi) [A/sqrt(1+A^2) atan(B/sqrt(1+A^2)) + B/sqrt(1+B^2) atan(A/sqrt(1+B^2))], A = a/h, B = b/h;
    signed (negative a or b: the rectangle on the other side), so rectangles add up from corners."""
    x, y = np.abs(a) / height, np.abs(b) / height
    unsigned = (x / np.hypot(1, x) * np.arctan(y / np.hypot(1, x))
                + y / np.hypot(1, y) * np.arctan(x / np.hypot(1, y))) / (2 * np.pi)
    return np.sign(a) * np.sign(b) * unsigned


def rectangle_factor(points, x0, x1, y0, y1):
    """Differential areas facing down at ``points`` (m, 3) to the floor rectangle [x0, x1] x [y0, y1] at z = 0."""
    x, y, h = points.T
    return (corner_factor(x1 - x, y1 - y, h) - corner_factor(x0 - x, y1 - y, h)
            - corner_factor(x1 - x, y0 - y, h) + corner_factor(x0 - x, y0 - y, h))


def half_lit_floor():
    """A 2 m floor whose x < 0 half lies in the shadow of a black roof under a vertical sun, and a small black
    receiver facing down 0.2 m above the shadowed half, 0.1 m from the shadow edge. The floor's radiosity is
    rho S on the lit half and 0 in the shadow; nothing else reflects."""
    floor = quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    roof = quad((-1.5, -1.5, 1), (-1.5, 1.5, 1), (0, 1.5, 1), (0, -1.5, 1))
    x0, x1, h = RECEIVER_X_M - 0.05, RECEIVER_X_M + 0.05, RECEIVER_HEIGHT_M
    receiver = quad((x0, -0.05, h), (x0, 0.05, h), (x1, 0.05, h), (x1, -0.05, h))
    triangles = np.concatenate([floor, roof, receiver])
    materials = [Material("floor", (FLOOR_REFLECTANCE,) * 3), Material("black", (0.0,) * 3)]
    scene = Scene(triangles, np.array([0, 0, 1, 1, 1, 1]), materials,
                  lights=[SunLight("sun", (0.0, 0.0, -1.0), strength_w_m2=1.0)])
    return scene, 4


@pytest.mark.parametrize("solver", ["hierarchical", "progressive"])
def test_receiver_over_a_shadow_edge_sees_the_lit_half_not_the_patch_mean(solver):
    # The floor is two triangles, each part lit, part shadowed. Sent as patch (or cluster) means, the receiver
    # would get about rho S / 2 F(floor); element by element it gets rho S F(point -> lit half), Howell's closed
    # form. Exact: the floor elements split at the shadow edge, and nothing occludes the receiver.
    scene, _ = half_lit_floor()
    solution = bake(scene, BakeSettings(patch_size_m=4.0, element_size_m=0.25, residual_threshold=1e-4,
                                        solver=solver))
    elements = solution.elements
    receiver = (np.abs(elements.point[:, 0, 2] - RECEIVER_HEIGHT_M) < 1e-9) & elements.alive[:, 0]
    assert receiver.any()
    measured = elements.irradiance[receiver, 0]
    centroids = elements.point[receiver, 0]
    expected = FLOOR_REFLECTANCE * rectangle_factor(centroids, 0, 1, -1, 1)
    patch_means = FLOOR_REFLECTANCE / 2 * rectangle_factor(centroids, -1, 1, -1, 1)
    assert np.all(np.abs(patch_means - expected) > 0.4 * expected)  # the test tells the two apart
    # The hierarchical solver links the far parts of the floor as clusters, sampled (measured: 0.1% off).
    tolerance = 5e-3 if solver == "hierarchical" else 1e-3
    np.testing.assert_allclose(measured, expected[:, None].repeat(3, axis=1), rtol=tolerance)


def test_esc_while_linking_near_elements_cancels_the_bake():
    scene, _ = half_lit_floor()
    stage = {"message": ""}

    def progress(fraction, message):
        stage["message"] = message
    with pytest.raises(BakeCancelled, match="linking near elements"):
        bake(scene, BakeSettings(patch_size_m=4.0, element_size_m=0.25, solver="progressive"), progress,
             cancelled=lambda: stage["message"].startswith("Near-field"))
