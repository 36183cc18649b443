"""Make the sample scenes: ``python sample_blends/make_samples.py [OUT_DIR]`` with the bpy module.

cornell_box.blend: the Cornell box from the graphics.cornell.edu data (mm -> m), reflectances and light radiance as
in Mitsuba 3 (docs/references in the README), the light as an emissive mesh (Emission Strength = radiance) 0.5 mm
below an opening in the ceiling (Cycles' mesh lights emit from both faces; the back face shines out). Walls
are 10 x 10 grids and block faces 5 x 5, so that vertex colours have vertices to live on.
"""
from __future__ import annotations

import sys
from pathlib import Path

import bpy
import numpy as np

MM = 0.001
WHITE = (0.885809, 0.698859, 0.666422)
GREEN = (0.105421, 0.37798, 0.076425)
RED = (0.570068, 0.0430135, 0.0443706)
LIGHT_RADIANCE = (18.387, 13.9873, 6.75357)

# Quads in mm, Cornell box coordinates (y up), as the Cornell data lists them (normals into the box).
CORNELL = {
    "floor": ([[(552.8, 0, 0), (0, 0, 0), (0, 0, 559.2), (549.6, 0, 559.2)]], "white"),
    # the ceiling has an opening under which the light hangs, so the light's back face sees out of the box
    "ceiling": ([[(556, 548.8, 0), (556, 548.8, 559.2), (343, 548.8, 559.2), (343, 548.8, 0)],
                 [(213, 548.8, 0), (213, 548.8, 559.2), (0, 548.8, 559.2), (0, 548.8, 0)],
                 [(343, 548.8, 0), (343, 548.8, 227), (213, 548.8, 227), (213, 548.8, 0)],
                 [(343, 548.8, 332), (343, 548.8, 559.2), (213, 548.8, 559.2), (213, 548.8, 332)]], "white"),
    "back wall": ([[(549.6, 0, 559.2), (0, 0, 559.2), (0, 548.8, 559.2), (556, 548.8, 559.2)]], "white"),
    "right wall": ([[(0, 0, 559.2), (0, 0, 0), (0, 548.8, 0), (0, 548.8, 559.2)]], "green"),
    "left wall": ([[(552.8, 0, 0), (549.6, 0, 559.2), (556, 548.8, 559.2), (556, 548.8, 0)]], "red"),
    "light": ([[(343, 548.3, 227), (343, 548.3, 332), (213, 548.3, 332), (213, 548.3, 227)]], "light"),
}
SHORT_BLOCK_TOP = [(130, 165, 65), (82, 165, 225), (240, 165, 272), (290, 165, 114)]
TALL_BLOCK_TOP = [(423, 330, 247), (265, 330, 296), (314, 330, 456), (472, 330, 406)]


def to_blender(point):
    """Cornell (x, y up, z depth) in mm -> Blender (x, y depth, z up) in m. Cornell's x grows to the viewer's
    left, so x is mirrored too: with the axis swap that makes a rotation, which keeps every face's winding."""
    x, y, z = point
    return ((556.0 - x) * MM, z * MM, y * MM)


def material(name, colour, emission=None):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    if emission:
        peak = max(emission)
        bsdf.inputs["Emission Color"].default_value = (*(c / peak for c in emission), 1.0)
        bsdf.inputs["Emission Strength"].default_value = peak
    mat.diffuse_color = (*colour, 1.0)
    return mat


def grid(quad, cuts):
    """Vertices and faces of a planar quad cut into cuts x cuts quads (bilinear between its corners)."""
    a, b, c, d = (np.array(to_blender(p)) for p in quad)
    t = np.linspace(0.0, 1.0, cuts + 1)
    u, v = np.meshgrid(t, t, indexing="ij")
    points = ((1 - u) * (1 - v))[..., None] * a + (u * (1 - v))[..., None] * b + (u * v)[..., None] * c + \
        ((1 - u) * v)[..., None] * d
    index = np.arange((cuts + 1) ** 2).reshape(cuts + 1, cuts + 1)
    faces = np.stack([index[:-1, :-1], index[1:, :-1], index[1:, 1:], index[:-1, 1:]], -1).reshape(-1, 4)
    return points.reshape(-1, 3), faces


def mesh_object(name, quads, mat, cuts=1):
    vertices, faces = [], []
    for quad in quads:
        points, quad_faces = grid(quad, cuts)
        faces += (quad_faces + len(vertices)).tolist()
        vertices += points.tolist()
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    mesh.materials.append(mat)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def block(top):
    """Four side quads and the top of a block standing on the floor (outward normals)."""
    bottom = [(x, 0.0, z) for x, _, z in top]
    sides = [[bottom[i], bottom[(i + 1) % 4], top[(i + 1) % 4], top[i]] for i in range(4)]
    return [top[::-1]] + sides


def cornell_box(path: Path) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    mats = {"white": material("white", WHITE), "green": material("green", GREEN), "red": material("red", RED),
            "light": material("light", (0.0, 0.0, 0.0), LIGHT_RADIANCE)}
    for name, (quads, mat) in CORNELL.items():
        mesh_object(name, quads, mats[mat], cuts=1 if name == "light" else (4 if name == "ceiling" else 10))
    for name, top in (("short block", SHORT_BLOCK_TOP), ("tall block", TALL_BLOCK_TOP)):
        quads = block(top)
        # the Cornell data lists tops counter-clockwise from above; make every side face outwards
        mesh = mesh_object(name, quads, mats["white"], cuts=5).data
        mesh.update()
        centre = sum((v.co for v in mesh.vertices), start=mesh.vertices[0].co * 0) / len(mesh.vertices)
        if any((p.center - centre).dot(p.normal) < 0 for p in mesh.polygons):
            for p in mesh.polygons:
                if (p.center - centre).dot(p.normal) < 0:
                    p.flip()
    camera_data = bpy.data.cameras.new("Camera")
    camera_data.lens = 35
    camera = bpy.data.objects.new("Camera", camera_data)
    camera.location = (0.278, -0.8, 0.273)
    camera.rotation_euler = (1.5708, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.world = bpy.data.worlds.new("Black")
    scene.world.color = (0.0, 0.0, 0.0)
    if scene.world.node_tree is not None:  # Blender 5 worlds come with a grey Background node
        scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.render.resolution_x = scene.render.resolution_y = 256
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 backup
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent
    out.mkdir(parents=True, exist_ok=True)
    cornell_box(out / "cornell_box.blend")
    print(f"wrote {out / 'cornell_box.blend'}")
