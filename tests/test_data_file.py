"""Data-only files (core.data_file): a solution written and read back lights points as the one in memory, and no
file, however crafted, runs code when read."""
import json
import pickle
from pathlib import Path

import numpy as np
import pytest

from core import BakeSettings, Material, PointLight, Scene, SceneError, SunLight, World, bake
from core.data_file import data_writer, read_data, read_header
from core.scene import AreaLight, SpotLight
from core.solution_file import FORMAT, VERSION, load_solution, save_solution
from core.texture import ReflectanceTexture
from shapes import box_faces, quad


class _Touch:
    """A pickle payload: unpickling it creates the file ``marker`` (any code could run there instead)."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return Path.touch, (self.marker,)


def lit_room() -> Scene:
    """A closed textured room with a block, an emissive panel and every kind of lamp, the world (which nothing lets in)."""
    faces = box_faces((0, 0, 0), (3, 2, 2.5))
    block = np.concatenate(box_faces((1, 0.5, 0), (1.6, 1.1, 0.8), inward=False))
    panel = quad((1.2, 0.8, 2.49), (1.8, 0.8, 2.49), (1.8, 1.2, 2.49), (1.2, 1.2, 2.49))[:, [0, 2, 1]]
    triangles = np.concatenate(faces + [block, panel])
    material = np.r_[np.zeros(12, int), np.ones(len(block), int), [2, 2]]
    pixels = np.stack([*np.meshgrid(np.linspace(0.2, 0.8, 8), np.linspace(0.1, 0.6, 8)), np.full((8, 8), 0.4)], -1)
    materials = [Material("walls", (0.6,) * 3, texture=ReflectanceTexture(pixels)), Material("block", (0.3, 0.5, 0.7)),
                 Material("glow", (0.0,) * 3, (2.0, 1.5, 1.0))]
    uv = triangles[..., :2] / 3.0
    lights = [PointLight("lamp", (0.5, 1.5, 2.0), 60.0, radius_m=0.05),
              SpotLight("spot", (2.5, 0.3, 2.2), (-0.3, 0.2, -1.0), 90.0, 0.8),
              AreaLight("area", (0.6, 0.4, 2.4), (0.0, 0.0, -1.0), 40.0, size_m=0.3),
              SunLight("sun", (0.3, 0.2, -1.0), 2.0)]
    return Scene(triangles, material, materials, lights=lights, world=World((0.1, 0.2, 0.3)), triangle_uv=uv)


def test_a_solution_read_back_lights_points_as_the_one_in_memory(tmp_path):
    """Every output reads a solution through evaluate and direct light; the copy read from the file (its
    ray-casting scene rebuilt from the triangles) gives the same values bit for bit, emitters, texture, lamps
    and world included."""
    solution = bake(lit_room(), BakeSettings(patch_size_m=1.0, element_size_m=0.5))
    path = str(tmp_path / "room.solution")
    save_solution(solution, path)
    read = load_solution(path)
    rng = np.random.default_rng(3)
    triangle = rng.integers(0, len(solution.scene.triangles) - 2, 500)
    barycentric = rng.dirichlet((1, 1, 1), 500)
    assert np.array_equal(read.evaluate(triangle, barycentric, direct_per_point=True),
                          solution.evaluate(triangle, barycentric, direct_per_point=True))
    assert read.direct.emitter_count == solution.direct.emitter_count > 0
    assert read.scene is read.direct.scene  # shared parts stay shared


def test_a_planted_pickle_is_refused_and_runs_nothing(tmp_path):
    """A pickle where a solution should be, whose loading would create a file, is refused by name and creates
    nothing."""
    marker, path = tmp_path / "ran", tmp_path / "planted.solution"
    path.write_bytes(pickle.dumps({"format": FORMAT, "version": VERSION, "solution": _Touch(marker)}))
    with pytest.raises(SceneError, match="planted.solution"):
        load_solution(str(path))
    assert not marker.exists()


def test_an_npz_holding_a_pickled_array_is_refused_and_runs_nothing(tmp_path):
    """A well-formed data file whose array member is an object array (a pickle inside the .npz) is refused."""
    marker, path = tmp_path / "ran", tmp_path / "crafted.solution"
    header = {"format": FORMAT, "version": VERSION}
    with open(path, "wb") as file:
        np.savez(file, header=np.frombuffer(json.dumps(header).encode(), np.uint8),
                 content=np.frombuffer(json.dumps({"array": 0}).encode(), np.uint8),
                 array_0=np.array([_Touch(marker)], dtype=object))
    with pytest.raises(SceneError, match="crafted.solution"):
        load_solution(str(path))
    assert not marker.exists()


def test_a_file_naming_a_type_outside_its_list_is_refused(tmp_path):
    """Content that names a class the reader did not list (here one the writer knew) is refused, naming it."""
    path = str(tmp_path / "other")
    data_writer({"format": "f", "version": 1}, {"lamp": SunLight("sun", (0, 0, -1), 1.0)}, (SunLight,))(path)
    assert read_data(path, "f", 1, "test file", (SunLight,))[1]["lamp"] == SunLight("sun", (0, 0, -1), 1.0)
    with pytest.raises(SceneError, match="'SunLight'"):
        read_data(path, "f", 1, "test file", (PointLight,))


def test_a_file_setting_a_dunder_attribute_is_refused(tmp_path):
    """Content that would set ``__class__`` (or any name that is not a plain attribute) on an object is refused."""
    path = tmp_path / "dunder"
    header = {"format": "f", "version": 1}
    content = {"object": "SunLight", "fields": {"__class__": {"object": "SunLight", "fields": {}}}}
    with open(path, "wb") as file:
        np.savez(file, header=np.frombuffer(json.dumps(header).encode(), np.uint8),
                 content=np.frombuffer(json.dumps(content).encode(), np.uint8))
    with pytest.raises(SceneError, match="__class__"):
        read_data(str(path), "f", 1, "test file", (SunLight,))


def test_values_keep_their_types_and_sharing(tmp_path):
    """Tuples, sets, dicts with any keys, numpy scalars, NaN and arrays come back as they went; an array or list
    held twice is one object after reading, as before writing."""
    shared = np.arange(6, dtype=np.float32).reshape(2, 3)
    items = [1, 2]
    content = {"tuple": (1, "a"), "set": {3, 4}, (0, 1): "tuple key", 5: np.float64(0.25), "nan": float("nan"),
               "a": shared, "b": shared, "items": [items, items], "none": None, "flag": True}
    path = str(tmp_path / "values")
    data_writer({"format": "f", "version": 1, "note": "hi"}, content, ())(path)
    header, read = read_data(path, "f", 1, "test file", ())
    assert header["note"] == "hi" and read_header(path, "f", 1, "test file") == header
    assert read["tuple"] == (1, "a") and read["set"] == {3, 4} and read[(0, 1)] == "tuple key"
    assert type(read[5]) is np.float64 and read[5] == 0.25 and np.isnan(read["nan"])
    assert read["a"] is read["b"] and read["a"].dtype == np.float32 and np.array_equal(read["a"], shared)
    assert read["items"][0] is read["items"][1] and read["none"] is None and read["flag"] is True


def test_another_version_or_format_is_named(tmp_path):
    path = str(tmp_path / "old")
    data_writer({"format": FORMAT, "version": VERSION - 1}, {}, ())(path)
    with pytest.raises(SceneError, match="version 2; this baker reads version 3"):
        load_solution(path)
    data_writer({"format": "radiosity-relight", "version": VERSION}, {}, ())(path)
    with pytest.raises(SceneError, match="is not a saved radiosity solution"):
        load_solution(path)
