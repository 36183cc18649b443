"""Vertex colours against Cycles' own vertex bake (Diffuse, Direct + Indirect, no Color, 2 x 1024 samples with two
seeds: their mean is the reference and their difference its noise, removed from the squared error), at Medium:

- a room whose walls are single quads, where every vertex sits on a corner or an edge of the room;
- in that room, a block and its linked duplicate in another place (each gets its own mesh and light);
- a floor of one quad whose corners lie inside the room's thick walls (they take the light of the room's corners).

The bounds are the issue's (4% relative RMSE, no corner off by more than 15%). The materials are purely diffuse
(Principled BSDF with Specular IOR Level 0). Measured on bpy 5.2.3: the room 2.5% and 9.1%, the block and its
twin 1.8% / 0.8% and 4.6% / 8.5%, the buried floor's corners at most 5.0% off. With Blender's default specular
layer the room is 6.9% and too bright by 5.4% on the mean: the bake reflects that layer's light as a diffuse
surface would (core.bsdf), which a corner, seeing its neighbours at grazing angles, shows most
(docs/benchmarks.md). Interpolation from the elements instead of the gather measured 7.8%."""
import bpy
import numpy as np

from blender_setup import corner_colors, cycles_vertex_bake, quad_room, thick_walled_room


def _against_cycles(objects) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per corner of the objects: our light, the two-seed Cycles reference and the reference's noise variance."""
    bakes = []
    for seed in (1, 2):
        cycles_vertex_bake(objects, 1024, f"Cycles {seed}", seed)
        bakes.append(np.concatenate([corner_colors(obj.data, f"Cycles {seed}") for obj in objects]))
    ours = np.concatenate([corner_colors(obj.data, "Radiosity") for obj in objects])
    return ours, (bakes[0] + bakes[1]) / 2, np.mean((bakes[0] - bakes[1]) ** 2) / 4


def _relative_rmse(ours, reference, noise) -> float:
    return float(np.sqrt(max(np.mean((ours - reference) ** 2) - noise, 0.0)) / reference.mean())


def _corner_errors(ours, reference) -> np.ndarray:
    return np.abs(ours - reference).mean(axis=1) / reference.mean(axis=1)


def _bake_medium() -> None:
    bpy.context.scene.radiosity.quality = "MEDIUM"
    assert bpy.ops.radiosity.bake() == {"FINISHED"}


def test_corners_of_a_room_of_single_quads_match_cycles(extension):
    names = quad_room(diffuse=True)
    _bake_medium()
    ours, reference, noise = _against_cycles([bpy.data.objects[name] for name in names])
    dark = reference.mean(axis=1) < 1e-6  # the block's bottom, resting on the floor: black in both
    assert len(ours) == 48 and dark.sum() == 4 and np.abs(ours[dark]).max() < 1e-6
    assert _relative_rmse(ours, reference, noise) <= 0.04
    assert _corner_errors(ours[~dark], reference[~dark]).max() <= 0.15


def test_linked_duplicates_each_match_cycles(extension):
    """The block and a linked duplicate of it nearer the lamp: after the bake each has its own mesh, and each
    one's corners are within the bounds of Cycles baking the two (as separate meshes, which Cycles needs)."""
    quad_room(diffuse=True)
    block = bpy.data.objects["block"]
    twin = block.copy()
    twin.name, twin.location = "block twin", (-0.55, -0.55, -0.7)
    bpy.context.scene.collection.objects.link(twin)
    _bake_medium()
    assert twin.data != block.data
    ours, reference, noise = _against_cycles([block, twin])
    for corners in (slice(0, 24), slice(24, 48)):
        lit = reference[corners].mean(axis=1) > 1e-6  # the bottom's 4 corners rest on the floor: black in both
        assert lit.sum() == 20 and np.abs(ours[corners][~lit]).max() < 1e-6
        assert _relative_rmse(ours[corners][lit], reference[corners][lit], noise) <= 0.04
        assert _corner_errors(ours[corners][lit], reference[corners][lit]).max() <= 0.15


def test_floor_corners_buried_in_walls_take_the_light_of_the_rooms_corners(extension):
    """A 2.4 m floor quad whose corners lie 0.2 m inside the walls on each side: each corner takes the light of
    the nearest visible point of its face, the room's corner, which Cycles bakes at the corners of the same floor
    scaled to 2 m. (The corners moved a quarter of the way to their triangle's centroid were 54% too bright.)"""
    thick_walled_room(2.4)
    _bake_medium()
    floor = bpy.data.objects["floor"]
    ours = corner_colors(floor.data, "Radiosity")
    floor.scale = (2.0 / 2.4, 2.0 / 2.4, 1.0)
    _, reference, _ = _against_cycles([floor])
    assert _corner_errors(ours, reference).max() <= 0.15
