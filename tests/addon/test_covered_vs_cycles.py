"""Covered surfaces against Cycles on the same UV map (issue 56): sloped wall tops a few centimetres under roof
slabs, and the covered half of a roof tile under the next. Cycles' paths from such a point meet the cover at once;
ours must not carry the sun in from beside the cover."""
import bmesh
import bpy
import numpy as np
import pytest

from blender_setup import add_light, cycles_lightmap_bake, grid_plane, lightmap_bake, principled_material, uv_coverage

SLOPE = np.radians(30.0)
SAMPLES = 256
BOX_FACES = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
UP = np.array([0.0, -np.sin(SLOPE), np.cos(SLOPE)])       # the sloped top's normal
ALONG = np.array([0.0, np.cos(SLOPE), np.sin(SLOPE)])     # up the slope
ACROSS = np.array([1.0, 0.0, 0.0])


def mesh_object(name, vertices, faces, material):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in vertices], [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.collection.objects.link(obj)
    mesh.materials.append(material)
    return obj


def rectangle(centre, half_across, half_along):
    return [centre + a * half_across * ACROSS + b * half_along * ALONG for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]


def wall_under_slab(x, gap_m, closed, material):
    """A 3 m long, 0.5 m thick, 2 m high wall whose top slopes 30 degrees, under a slab parallel to the top,
    ``gap_m`` above it along its normal, overhanging by 0.5 m all round: a single-sided sheet or a 10 cm box."""
    rise = 0.5 * np.tan(SLOPE)
    wall = mesh_object(f"wall {x:g}", [(x - 1.5, -0.25, 0), (x + 1.5, -0.25, 0), (x + 1.5, 0.25, 0), (x - 1.5, 0.25, 0),
                                       (x - 1.5, -0.25, 2), (x + 1.5, -0.25, 2), (x + 1.5, 0.25, 2 + rise),
                                       (x - 1.5, 0.25, 2 + rise)], BOX_FACES, material)
    underside = rectangle(np.array([x, 0.0, 2 + rise / 2]) + gap_m * UP, 2.0, 0.25 / np.cos(SLOPE) + 0.5)
    if closed:
        mesh_object(f"slab {x:g}", underside + [c + 0.1 * UP for c in underside], BOX_FACES, material)
    else:
        mesh_object(f"slab {x:g}", underside, [(0, 1, 2, 3)], material)
    return wall


def top_texels(obj, width, height):
    """The texels of the object's faces that face up (its sloped top)."""
    copy = obj.copy()
    copy.data = obj.data.copy()
    bpy.context.collection.objects.link(copy)
    mesh = bmesh.new()
    mesh.from_mesh(copy.data)
    bmesh.ops.delete(mesh, geom=[face for face in mesh.faces if face.normal.z < 0.5], context="FACES")
    mesh.to_mesh(copy.data)
    mesh.free()
    texels = uv_coverage([copy], "Lightmap", width, height)
    bpy.data.objects.remove(copy)
    return texels


def test_sloped_wall_tops_under_slabs_and_overlapping_tiles_read_as_cycles(empty_scene, extension, tmp_path):
    """Six walls under slabs 2, 5 and 10 cm above their sloped tops (single-sided and closed), two roof tiles
    overlapping by half 3 cm apart, sun from above and a blue sky, at 6 texels per metre (17 cm texels), Medium.
    No texel of a wall top or of the lower tile is over twice Cycles (2 x 256 spp) plus 10% of the page's mean
    level (the issue's bound for a leak), and each wall top's mean is within 0.05 (5% of the sunlit level) of
    Cycles'. Measured: wall tops 0.015-0.132 against Cycles' 0.015-0.122 on bpy 5.2 and 0.010-0.118 on 4.2 (whose
    Cycles reads 0.004 darker here); a wall top reading the sun would hold about 0.8. Under the 2 cm single-sided
    slab it read 0.061 before the cover passes (core.adaptive_elements) split the slab's underside elements that
    are half over the wall top and half over the sunlit ground. The largest excess left, +0.029 (5.2) and +0.034
    (4.2) under the 5 cm single-sided slab, is on wall-top elements covered all over, which each receive at one
    point a few centimetres from the opening."""
    grey = principled_material("grey", (0.6, 0.6, 0.6), True)
    grid_plane("Ground", 40.0, 8, location=(6.0, 0, 0), colour=(0.6, 0.6, 0.6))
    walls = [wall_under_slab(-10.0 + 5 * k, gap, closed, grey)
             for k, (closed, gap) in enumerate((c, g) for c in (False, True) for g in (0.02, 0.05, 0.10))]
    tiles = [mesh_object(f"tile {k}", rectangle(np.array([20.0, 0.0, 1.0]) + shift * ALONG + lift * UP, 0.5, 0.25),
                         [(0, 1, 2, 3)], grey) for k, (shift, lift) in enumerate(((0.0, 0.0), (0.25, 0.03)))]
    sun = add_light("SUN", (0, 0, 10), 3.0, angle=np.radians(1.0))
    sun.rotation_euler = (np.radians(15.0), np.radians(10.0), 0)
    world = bpy.context.scene.world
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.4, 0.6, 1)
    bake, _, _ = lightmap_bake("MEDIUM", tmp_path, texels_per_metre=6.0, lightmap_padding=2)
    page, = bake.lightmaps
    height, width = page.light.shape[:2]
    ours = page.light.astype(np.float64).mean(axis=-1)
    compared = walls + [tiles[0]]
    first, _ = cycles_lightmap_bake(compared, "Lightmap", width, height, SAMPLES, seed=1)
    second, _ = cycles_lightmap_bake(compared, "Lightmap", width, height, SAMPLES, seed=2)
    cycles = (0.5 * (first + second)).mean(axis=-1)
    level = ours[page.covered].mean()
    for obj in walls:
        top = top_texels(obj, width, height) & ~page.moved
        assert top.sum() >= 40
        assert np.all(ours[top] <= 2 * cycles[top] + 0.1 * level), obj.name
        assert ours[top].mean() == pytest.approx(cycles[top].mean(), abs=0.05), obj.name
    tile = uv_coverage([tiles[0]], "Lightmap", width, height) & ~page.moved
    assert np.all(ours[tile] <= 2 * cycles[tile] + 0.1 * level)
