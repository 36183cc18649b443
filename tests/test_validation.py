"""Every bad input raises SceneError (a bad setting: SettingsError) with a message naming the offending object,
material, light or setting, in plain numbers."""
import numpy as np
import pytest

from core import (AreaLight, BakeCancelled, BakeSettings, Material, PointLight, Scene, SceneError, SettingsError,
                  SpotLight, SunLight, World, bake)
from core.memory import MemoryLimitError
from core.scene import MAX_EMISSION
from shapes import quad

FLOOR = quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0))
LAMP = PointLight("Lamp", (0.5, 0.5, 1.0), 10.0)


def make(triangles=FLOOR, materials=(Material("Floor"),), lights=(LAMP,), world=World(), **kwargs):
    triangles = np.asarray(triangles, dtype=np.float64)
    return Scene(triangles, np.zeros(len(triangles), int), list(materials), lights=list(lights), world=world,
                 object_names=["Plane"], **kwargs)


def test_nan_vertex_names_the_object():
    bad = FLOOR.copy()
    bad[1, 2, 0] = np.nan
    with pytest.raises(SceneError, match="Object 'Plane'.*NaN"):
        make(bad)


def test_infinite_vertex_names_the_object():
    bad = FLOOR.copy()
    bad[0, 0, 2] = np.inf
    with pytest.raises(SceneError, match="'Plane'"):
        make(bad)


@pytest.mark.parametrize("offset", [-0.1, 1.5, np.nan])
def test_shadow_terminator_offset_outside_zero_one_names_the_object(offset):
    with pytest.raises(SceneError, match="Object 'Plane'.*Shadow Terminator Geometry Offset"):
        make(terminator_offset=[0.1, offset])


@pytest.mark.parametrize("reflectance", [(1.01, 0.5, 0.5), (0.5, 1.2, 0.5), (-0.1, 0.5, 0.5)])
def test_reflectance_outside_zero_one_names_the_material(reflectance):
    with pytest.raises(SceneError, match="Material 'Brick'.*reflectance"):
        make(materials=[Material("Brick", reflectance)])


@pytest.mark.parametrize("make_bad, match", [
    (lambda: make(materials=[Material("Glow", (0.5,) * 3, (np.inf, 0.0, 0.0))]), r"Material 'Glow'.*\(inf, 0, 0\)"),
    (lambda: make(materials=[Material("Glow", (0.5,) * 3, (2 * MAX_EMISSION, 0.0, 0.0))]),
     "Material 'Glow'.*unbounded"),
    (lambda: make(lights=[PointLight("Bulb", (0, 0, 1), 1e30)]), "Light 'Bulb'.*1e[+]30"),
    (lambda: make(lights=[SunLight("Sun", (0, 0, -1), np.inf)]), "Light 'Sun'.*inf"),
    (lambda: make(world=World((0.0, 0.0, 1e300))), "World background.*unbounded"),
])
def test_unbounded_emission_is_refused_by_name(make_bad, match):
    """Beyond MAX_EMISSION float32 light could overflow to inf and reach a file."""
    with pytest.raises(SceneError, match=match):
        make_bad()


def test_messages_print_plain_numbers():
    with pytest.raises(SceneError) as caught:
        make(materials=[Material("Brick", (np.float64(1.5), 0.5, 0.5))])
    assert "np.float64" not in str(caught.value) and "(1.5, 0.5, 0.5)" in str(caught.value)


def test_material_index_below_zero_names_the_object_and_index():
    with pytest.raises(SceneError, match="Object 'Plane': a triangle refers to material -1"):
        Scene(FLOOR, [0, -1], [Material("Floor")], lights=[LAMP], object_names=["Plane"])


@pytest.mark.parametrize("name, value", [("triangles", np.zeros((2, 3, 2))), ("triangle_uv", np.zeros((2, 3, 3))),
                                         ("triangles", [["a", "b", "c"]])])
def test_wrongly_shaped_arrays_are_scene_errors(name, value):
    arguments = {"triangles": FLOOR, "material_index": [0, 0], "materials": [Material("Floor")], "lights": [LAMP]}
    arguments[name] = value
    with pytest.raises(SceneError, match=name):
        Scene(**arguments)


def test_negative_emission_names_the_material():
    with pytest.raises(SceneError, match="Material 'Glow'.*emitted radiance"):
        make(materials=[Material("Glow", (0.5,) * 3, (-1.0, 0.0, 0.0))])


@pytest.mark.parametrize("light", [
    PointLight("Bulb", (0, 0, 1), -5.0),
    SpotLight("Spot", (0, 0, 1), (0, 0, -1), -1.0, np.radians(45)),
    SunLight("Sun", (0, 0, -1), -2.0),
    AreaLight("Panel", (0, 0, 1), (0, 0, -1), -3.0),
])
def test_negative_power_names_the_light(light):
    with pytest.raises(SceneError, match=f"Light '{light.name}'.*power"):
        make(lights=[light])


def test_bad_area_light_shape_and_size():
    with pytest.raises(SceneError, match="Light 'Panel'.*shape"):
        make(lights=[AreaLight("Panel", (0, 0, 1), (0, 0, -1), 3.0, shape="TRIANGLE")])
    with pytest.raises(SceneError, match="Light 'Panel'.*size"):
        make(lights=[AreaLight("Panel", (0, 0, 1), (0, 0, -1), 3.0, size_m=0.0)])


def test_zero_direction_names_the_light():
    with pytest.raises(SceneError, match="Light 'Sun'.*direction"):
        make(lights=[SunLight("Sun", (0, 0, 0), 2.0)])


def test_empty_scene():
    with pytest.raises(SceneError, match="empty"):
        make(np.zeros((0, 3, 3)))


def test_scene_without_light():
    with pytest.raises(SceneError, match="no light"):
        make(lights=[])


def test_negative_world_names_the_world():
    with pytest.raises(SceneError, match="World"):
        make(world=World((-1.0, 0.0, 0.0)))


def test_zero_area_triangles_are_dropped_and_counted():
    degenerate = np.array([[[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 0, 0], [0, 0, 0], [0, 0, 0]]], dtype=float)
    scene = make(np.concatenate([FLOOR, degenerate]))
    assert scene.dropped_triangles == 2
    assert len(scene.triangles) == 2
    assert scene.triangle_source.tolist() == [0, 1]


def test_only_degenerate_triangles_is_nothing_to_bake():
    with pytest.raises(SceneError, match="Nothing to bake"):
        make(np.zeros((2, 3, 3)))


@pytest.mark.parametrize("setting, value", [("element_size_m", 0.0), ("patch_size_m", -1.0),
                                            ("residual_threshold", float("nan")), ("adaptive_passes", -1), ("seed", -1),
                                            ("form_factors", "radiant"), ("solver", "magic")])
def test_bad_setting_names_the_setting(setting, value):
    with pytest.raises(SettingsError, match=f"'{setting}'"):
        BakeSettings(**{setting: value})


def test_world_light_with_the_default_seed():
    """Regression: seed 0 once gave the world sampler a negative seed."""
    solution = bake(make(lights=[], world=World((1.0, 1.0, 1.0))), BakeSettings(patch_size_m=1, element_size_m=0.5))
    assert solution.element_light() == pytest.approx(1.0)  # an open plane under a white sky: pi L / pi


def test_direct_solver_refuses_too_many_patches():
    scene = make(quad((0, 0, 0), (10, 0, 0), (10, 10, 0), (0, 10, 0)))
    with pytest.raises(SceneError, match="direct solver is limited"):
        bake(scene, BakeSettings(solver="direct", patch_size_m=0.1, element_size_m=0.1))


def test_cancelled_bake_raises_bake_cancelled():
    calls = []

    def cancelled():
        calls.append(1)
        return len(calls) > 3

    room = np.concatenate([FLOOR, quad((0, 0, 1), (0, 1, 1), (1, 1, 1), (1, 0, 1))])
    with pytest.raises(BakeCancelled):
        bake(make(room), BakeSettings(patch_size_m=0.25, element_size_m=0.125, residual_threshold=1e-6),
             cancelled=cancelled)


@pytest.mark.parametrize("setting", ["element_size_m", "patch_size_m"])
def test_a_bake_over_the_memory_limit_is_refused_before_allocating(setting):
    """Micrometre elements (or emitter pieces) on a 1 m^2 floor are 1e12 pieces: refused by the estimate, naming
    the setting, not by numpy running out of memory."""
    glow = Material("Glow", (0.5, 0.5, 0.5), (1.0, 1.0, 1.0))
    scene = make(materials=[glow])
    with pytest.raises(MemoryLimitError, match=setting):
        bake(scene, BakeSettings(**{setting: 1e-6, "solver": "hierarchical", "max_memory_gb": 8.0}))
