"""Random small scenes and settings through the core: only the documented errors may come out, and a bake that
runs gives finite, non-negative light that conserves energy.

Energy: surfaces receive the sources' power S and what they reflect, and reflect at most rho_max of what they
receive, so they receive at most S / (1 - rho_max) in all. S is at most each lamp's power, the irradiance of a
sun or the world (pi L) over all surfaces, and each emitter's pi L from both faces.

RADIOSITY_FUZZ_EXAMPLES sets the number of examples (default 300, derandomised so that CI runs the same ones;
the longer documented run: RADIOSITY_FUZZ_EXAMPLES=1200 pytest tests/test_fuzz.py, about 5 minutes);
RADIOSITY_FUZZ_RANDOM=1 draws new examples each run.
"""
import os

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, event, given, settings, strategies as st  # noqa: E402

from core import (AreaLight, BakeError, BakeSettings, Material, PointLight, Scene, SpotLight, SunLight,  # noqa: E402
                  World, bake)
from core.scene import MAX_REFLECTANCE  # noqa: E402

EXAMPLES = int(os.environ.get("RADIOSITY_FUZZ_EXAMPLES", "300"))
RANDOM = os.environ.get("RADIOSITY_FUZZ_RANDOM") == "1"

coordinate = st.floats(-2.0, 2.0, allow_nan=False)
vertex = st.tuples(coordinate, coordinate, coordinate)
unit = st.floats(0.0, 1.0)
colour = st.tuples(unit, unit, unit)
power = st.one_of(st.just(0.0), st.floats(1e-3, 1e3))
direction = st.tuples(coordinate, coordinate, coordinate)


@st.composite
def triangles(draw):
    """1 to 12 triangles, some degenerate (a repeated vertex or all three in a line)."""
    count = draw(st.integers(1, 12))
    corners = np.array(draw(st.lists(st.tuples(vertex, vertex, vertex), min_size=count, max_size=count)))
    for index in draw(st.lists(st.integers(0, count - 1), max_size=3)):
        corners[index, 2] = corners[index, draw(st.integers(0, 1))]
    return corners


materials = st.lists(st.builds(Material, st.sampled_from(["Red", "White", "Grey"]),
                               st.one_of(colour, st.just((1.0, 1.0, 1.0))),
                               st.one_of(st.just((0.0, 0.0, 0.0)), st.tuples(power, power, power))),
                     min_size=1, max_size=3)
lights = st.lists(st.one_of(
    st.builds(PointLight, st.just("Bulb"), vertex, power, color=colour),
    st.builds(SpotLight, st.just("Spot"), vertex, direction, power, st.floats(0.1, np.pi)),
    st.builds(SunLight, st.just("Sun"), direction, st.floats(0.0, 10.0)),
    st.builds(AreaLight, st.just("Panel"), vertex, direction, power, size_m=st.floats(0.01, 2.0)),
), max_size=3)
bake_settings = st.fixed_dictionaries(dict(
    patch_size_m=st.floats(0.25, 3.0), element_size_m=st.floats(0.25, 3.0),
    solver=st.sampled_from(["hierarchical", "progressive", "direct"]), light_samples_per_edge=st.integers(1, 3),
    adaptive_passes=st.integers(0, 1), seed=st.integers(0, 1000)))


def power_bound(scene: Scene, solution) -> np.ndarray:
    """(3,) the most power the surfaces can receive from the sources (module docstring), W."""
    area = float(solution.elements.area_m2.sum()) * 2  # both sides
    bound = np.zeros(3)
    for light in scene.lights:
        colour_ = np.asarray(light.color)
        bound += colour_ * (light.strength_w_m2 * area if isinstance(light, SunLight) else light.power_w)
    bound += np.pi * np.asarray(scene.world.radiance) * area
    emitted = scene.emitted_radiance[scene.material_index] * 2 * np.pi
    bound += (emitted * 0.5 * np.linalg.norm(np.cross(scene.triangles[:, 1] - scene.triangles[:, 0],
                                                      scene.triangles[:, 2] - scene.triangles[:, 0]),
                                             axis=1)[:, None]).sum(axis=0)
    return bound


@settings(max_examples=EXAMPLES, deadline=None, derandomize=not RANDOM,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(triangles(), materials, lights, colour, bake_settings, st.data())
def test_random_scenes_raise_only_documented_errors_and_conserve_energy(corners, materials_, lights_, world,
                                                                        settings_, data):
    material_index = data.draw(st.lists(st.integers(0, len(materials_) - 1), min_size=len(corners),
                                        max_size=len(corners)))
    try:
        scene = Scene(corners, material_index, materials_, lights=lights_, world=World(world))
        solution = bake(scene, BakeSettings(**settings_))
    except BakeError as error:
        event(f"refused: {type(error).__name__}")
        return
    event("baked")
    bary = np.full((len(scene.triangles), 3), 1.0 / 3.0)
    receivers = np.flatnonzero(~scene.casts_only)
    for per_point in (False, True):
        light = solution.evaluate(receivers, bary[receivers], direct_per_point=per_point)
        assert np.isfinite(light).all() and (light >= 0).all()
    elements = solution.elements
    received = (elements.exposed_m2[..., None] * elements.irradiance).sum(axis=(0, 1))
    rho = min(float(np.max(scene.reflectance)), MAX_REFLECTANCE)
    assert (received <= 1.01 * power_bound(scene, solution) / (1 - rho) + 1e-9).all()
