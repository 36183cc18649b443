"""Make the sample scenes: ``python sample_blends/make_samples.py [OUT_DIR]`` with the bpy module.

room.blend: a 5 x 4 x 2.6 m room with a window in one wall, a sun shining through it and a blue sky, a point
light, a spot light and an area light, a floor with a packed 64 x 64 checker image texture, a shelf made by Array
and Bevel modifiers, two chairs that share one mesh (linked duplicates) and a low-poly ball shaded smooth in the
sunlight.

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


def principled(name, colour):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    mat.diffuse_color = (*colour, 1.0)
    return mat


def checker_material(name, dark, light, size=64, squares=8):
    """A Principled material whose base colour is a packed size x size checker image (linear values)."""
    mat = principled(name, tuple(0.5 * (np.array(dark) + np.array(light))))
    image = bpy.data.images.new(f"{name} checker", size, size, float_buffer=True)
    board = ((np.arange(size)[:, None] * squares // size + np.arange(size)[None, :] * squares // size) % 2)
    rgba = np.where(board[..., None] == 1, [*light, 1.0], [*dark, 1.0]).astype(np.float32)
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    texture = mat.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    texture.interpolation = "Closest"
    mat.node_tree.links.new(texture.outputs["Color"], mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    return mat


def box_object(name, lo, hi, mat):
    """An axis-aligned box (outward normals) as a mesh object with UVs from Blender's cube primitive."""
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    lo, hi = np.array(lo), np.array(hi)
    obj.scale = tuple(hi - lo)
    obj.location = tuple(0.5 * (lo + hi))
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    obj.data.materials.append(mat)
    return obj


def smooth_sphere(name, centre, radius, mat, segments=12, rings=6):
    """A low-poly UV sphere shaded smooth (the terminator test of smooth shading), made from its vertices so
    the face order is the same every time."""
    polar = np.pi * np.arange(1, rings) / rings
    around = 2 * np.pi * np.arange(segments) / segments
    ring = [(np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)) for p in polar for a in around]
    vertices = [tuple(centre + radius * np.array(v)) for v in [(0, 0, 1), *ring, (0, 0, -1)]]
    index = lambda r, k: 1 + r * segments + k % segments
    faces = [(0, index(0, k), index(0, k + 1)) for k in range(segments)]
    faces += [(index(r, k), index(r + 1, k), index(r + 1, k + 1), index(r, k + 1))
              for r in range(rings - 2) for k in range(segments)]
    faces += [(index(rings - 2, k + 1), index(rings - 2, k), len(vertices) - 1) for k in range(segments)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    mesh.polygons.foreach_set("use_smooth", [True] * len(faces))
    mesh.materials.append(mat)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


ROOM = (5.0, 4.0, 2.6)
WINDOW = (1.2, 2.8, 0.9, 2.1)  # y from, y to, z from, z to, in the +x wall


def room(path: Path) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    x, y, z = ROOM
    y0, y1, z0, z1 = WINDOW
    walls = principled("plaster", (0.75, 0.72, 0.68))
    quads = {
        "walls": [[(0, 0, 0), (0, 0, z), (0, y, z), (0, y, 0)],          # -x, facing +x
                  [(0, 0, 0), (x, 0, 0), (x, 0, z), (0, 0, z)],          # -y, facing +y
                  [(0, y, 0), (0, y, z), (x, y, z), (x, y, 0)],          # +y, facing -y
                  [(x, 0, 0), (x, y0, 0), (x, y0, z), (x, 0, z)],        # +x wall around the window
                  [(x, y1, 0), (x, y, 0), (x, y, z), (x, y1, z)],
                  [(x, y0, 0), (x, y1, 0), (x, y1, z0), (x, y0, z0)],
                  [(x, y0, z1), (x, y1, z1), (x, y1, z), (x, y0, z)]],
        "ceiling": [[(0, 0, z), (x, 0, z), (x, y, z), (0, y, z)]],
    }
    for name, faces in quads.items():
        vertices = [p for face in faces for p in face]
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(vertices, [], [[4 * i + k for k in range(4)] for i in range(len(faces))])
        mesh.materials.append(walls)
        mesh.update()
        centre = np.array([x / 2, y / 2, z / 2])
        for polygon in mesh.polygons:  # every face looks into the room
            if np.dot(centre - np.array(polygon.center), np.array(polygon.normal)) < 0:
                polygon.flip()
        obj = bpy.data.objects.new(name, mesh)
        scene.collection.objects.link(obj)
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(x / 2, y / 2, 0.0))
    floor = bpy.context.active_object
    floor.name = floor.data.name = "floor"
    floor.scale = (x, y, 1.0)
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    floor.data.materials.append(checker_material("checker floor", (0.05, 0.05, 0.05), (0.8, 0.8, 0.8)))
    shelf = box_object("shelf", (0.1, 0.5, 0.0), (0.5, 0.9, 1.6), principled("wood", (0.45, 0.28, 0.15)))
    array = shelf.modifiers.new("Array", "ARRAY")
    array.count, array.relative_offset_displace = 3, (0.0, 1.1, 0.0)
    bevel = shelf.modifiers.new("Bevel", "BEVEL")
    bevel.width, bevel.segments = 0.02, 2
    red = principled("red fabric", (0.6, 0.08, 0.06))
    chair = box_object("chair", (2.0, 1.5, 0.0), (2.5, 2.0, 0.45), red)
    twin = chair.copy()  # a linked duplicate: same mesh data
    twin.name = "chair twin"
    twin.location = (chair.location[0] + 1.0, chair.location[1] + 0.8, chair.location[2])
    scene.collection.objects.link(twin)
    box_object("table", (2.1, 2.1, 0.7), (3.3, 2.9, 0.76), principled("table top", (0.5, 0.5, 0.52)))
    smooth_sphere("ball", np.array([3.5, 1.6, 0.2]), 0.2, principled("blue ball", (0.2, 0.45, 0.7)))
    lights = [("sun", "SUN", (0, 0, 0), 8.0, {"angle": np.radians(1.0)}, (np.radians(60), 0.0, np.radians(90))),
              ("bulb", "POINT", (1.0, 3.2, 2.2), 60.0, {"shadow_soft_size": 0.05}, (0.0, 0.0, 0.0)),
              ("spot", "SPOT", (4.5, 0.4, 2.4), 150.0, {"spot_size": np.radians(50), "spot_blend": 0.2,
                                                       "shadow_soft_size": 0.05}, (np.radians(30), 0.0, 0.0)),
              ("panel", "AREA", (2.7, 2.5, 2.55), 80.0, {"shape": "RECTANGLE", "size": 0.6, "size_y": 0.3},
               (0.0, 0.0, 0.0))]
    for group in ("daylight", "lamps"):  # Cycles' light groups, which --light-groups bakes apart
        bpy.context.view_layer.lightgroups.add(name=group)
    for name, kind, location, energy, data, rotation in lights:
        light = bpy.data.lights.new(name, kind)
        light.energy = energy
        for key, value in data.items():
            setattr(light, key, value)
        obj = bpy.data.objects.new(name, light)
        obj.location, obj.rotation_euler = location, rotation
        obj.lightgroup = "daylight" if kind == "SUN" else "lamps"
        scene.collection.objects.link(obj)
    scene.world = bpy.data.worlds.new("Sky")
    scene.world.lightgroup = "daylight"
    scene.world.use_nodes = True
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.35, 0.5, 0.8, 1.0)
    background.inputs["Strength"].default_value = 1.0
    camera_data = bpy.data.cameras.new("Camera")
    camera_data.lens = 18
    camera = bpy.data.objects.new("Camera", camera_data)
    camera.location, camera.rotation_euler = (0.4, 3.7, 1.5), (np.radians(80), 0.0, np.radians(-121.4))
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y = 320, 240
    bpy.context.preferences.filepaths.save_version = 0
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent
    out.mkdir(parents=True, exist_ok=True)
    for name, make in (("cornell_box", cornell_box), ("room", room)):
        make(out / f"{name}.blend")
        print(f"wrote {out / f'{name}.blend'}")
