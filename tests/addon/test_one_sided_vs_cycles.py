"""Single-sided surfaces reflect from both sides, as in Cycles: a column in shadow, lit only by sunlight bounced
off the back of a single-sided floor, against Cycles' bake on the same UV map, with the floor turned over as a
control."""
import bpy
import numpy as np
import pytest

from blender_setup import add_light, cycles_lightmap_bake, grid_plane, lightmap_bake, uv_coverage

SIZE = 256
SAMPLES = 512


def column_under_a_canopy(floor_faces_up: bool):
    """A 0.4 x 0.4 x 2 m column on a 10 x 10 m floor, under a 1.6 x 1.6 m canopy 3 m up that shades it from a sun
    straight above: the column's light all comes off the floor around the canopy's shadow. The floor's normal
    points up, or down (the sunlit side is then its back)."""
    floor = grid_plane("Floor", 10.0, 8, colour=(0.8, 0.8, 0.8))
    if not floor_faces_up:
        floor.rotation_euler = (np.pi, 0.0, 0.0)  # the same plane, turned over
    grid_plane("Canopy", 1.6, 2, location=(0.0, 0.0, 3.0), colour=(0.5, 0.5, 0.5))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, 1.0))
    column = bpy.context.active_object
    column.name = "Column"
    column.scale = (0.4, 0.4, 2.0)
    bpy.ops.object.transform_apply(scale=True)
    material = bpy.data.materials.new("column material")
    material.use_nodes = True
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    column.data.materials.append(material)
    add_light("SUN", (0.0, 0.0, 6.0), 3.0, angle=0.0)
    return column


def column_sides(column, light: np.ndarray, reference: np.ndarray, moved: np.ndarray):
    """Our and Cycles' mean light over the column's four sides (their texels, centres inside a chart)."""
    mask = uv_coverage([column], "Lightmap", SIZE, SIZE) & ~moved
    return light[mask].mean(axis=0), reference[mask].mean(axis=0), int(mask.sum())


@pytest.mark.parametrize("floor_faces_up", [True, False], ids=["floor facing up", "floor turned over"])
def test_a_column_lit_off_the_back_of_a_single_sided_floor_matches_cycles(empty_scene, extension, tmp_path,
                                                                          floor_faces_up):
    """The column's mean light within 12% of Cycles (2 x 512 spp; the top, which sees only the canopy's
    underside, counts with the sides), whichever way the floor faces. With one-sided elements the turned-over
    floor sent nothing and the column came out black. Measured: +8.1% with the floor facing up, +9.0% turned
    over (Medium; the two orientations within 1% of each other)."""
    column = column_under_a_canopy(floor_faces_up)
    bake, _, _ = lightmap_bake("MEDIUM", tmp_path, lightmap_resolution=SIZE, lightmap_padding=2)
    page, = bake.lightmaps
    first, _ = cycles_lightmap_bake([column], "Lightmap", SIZE, SIZE, samples=SAMPLES, seed=1)
    second, _ = cycles_lightmap_bake([column], "Lightmap", SIZE, SIZE, samples=SAMPLES, seed=2)
    ours, reference, texels = column_sides(column, page.light.astype(np.float64), 0.5 * (first + second),
                                           page.moved)
    assert texels > 500
    assert reference.mean() > 0.05  # the bounce is real light: about a tenth of the sunlit floor's
    assert ours == pytest.approx(reference, rel=0.12)
