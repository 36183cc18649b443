"""The Cornell box sample baked to vertex colours against a Cycles vertex-colour bake (Diffuse, Direct + Indirect,
no Color, 1024 samples per vertex).

Measured at Medium quality (bpy 5.2.3): per-surface means within 0-6% of Cycles on the walls, floor and blocks;
relative RMSE over their vertices 6-12% per surface, most of it at concave corners where Cycles samples a point and
we interpolate element averages. The ceiling is left out: its vertices on the rim of the light's opening sit
0.5 mm from the light's back face, a point value no element average can reproduce. The issue's goal is 5% RMSE;
this test guards what is reached now.
"""
import bpy
import numpy as np
import pytest

from blender_setup import corner_colors, cycles_vertex_bake, make_cornell_box

COMPARED = ["floor", "back wall", "left wall", "right wall", "short block", "tall block"]


def test_cornell_box_matches_cycles(tmp_path, extension):
    bpy.ops.wm.open_mainfile(filepath=str(make_cornell_box(tmp_path)))
    bpy.context.scene.radiosity.quality = "MEDIUM"
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    objects = [bpy.data.objects[name] for name in COMPARED]
    cycles_vertex_bake(objects, samples=1024)
    ours = {o.name: corner_colors(o.data, "Radiosity") for o in objects}
    cycles = {o.name: corner_colors(o.data, "Cycles") for o in objects}
    for name in COMPARED:
        assert ours[name].mean(axis=0) == pytest.approx(cycles[name].mean(axis=0), rel=0.08), name
    everything_ours, everything_cycles = np.concatenate(list(ours.values())), np.concatenate(list(cycles.values()))
    assert np.sqrt(np.mean((everything_ours - everything_cycles) ** 2)) <= 0.12 * everything_cycles.mean()
