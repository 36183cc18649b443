"""Helpers for add-on tests with the bpy module: load the extension package, build scenes, bake with Cycles."""
from __future__ import annotations

import ctypes
import os
import resource
import runpy
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def load_extension():
    """The repository root imported as the package ``radiosity_baker`` (as Blender imports the extension)."""
    return runpy.run_path(str(ROOT / "radiosity_addon" / "__main__.py"), run_name="loader")["load_package"]()


def run_cli(*args, file_size_limit: int | None = None, honour_permissions: bool = False,
            python: Path | str = sys.executable) -> tuple[int, str]:
    """(exit code, stderr) of ``python -m radiosity_addon bake ARGS`` (by default on this process's Python and
    its bpy); with ``file_size_limit`` no file the bake
    writes may grow past that many bytes (a write beyond it fails with EFBIG, as on a full disk); with
    ``honour_permissions`` a bake run as root obeys file modes as any user does (CAP_DAC_OVERRIDE and
    CAP_DAC_READ_SEARCH leave its capability bounding set, so that a read-only folder is read-only to it)."""
    def limit_file_size():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (file_size_limit, file_size_limit))

    def drop_permission_overrides():
        libc = ctypes.CDLL(None, use_errno=True)
        for capability in (1, 2):  # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH (linux/capability.h)
            if libc.prctl(24, capability, 0, 0, 0) != 0:  # PR_CAPBSET_DROP
                raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP)")

    def prepare():
        if file_size_limit:
            limit_file_size()
        if honour_permissions and os.geteuid() == 0:
            drop_permission_overrides()
    result = subprocess.run([str(python), "-m", "radiosity_addon", "bake", *map(str, args)], cwd=ROOT,
                            capture_output=True, text=True, timeout=600, preexec_fn=prepare)
    return result.returncode, result.stderr


def save_scene(path: Path, with_light=True, with_mesh=True) -> Path:
    """A 2 m floor of 4 x 4 quads under a 1 m roof of 2 x 2, lit by a 100 W point lamp, saved at ``path``."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if with_mesh:
        grid_plane("Floor", 2.0, 4)
        grid_plane("Roof", 1.0, 2, location=(0, 0, 1.0))
    if with_light:
        add_light("POINT", (0.5, 0.5, 2.0), 100.0)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def make_sample(name: str, folder: Path) -> Path:
    """Make the sample scene ``name`` (cornell_box, room) with sample_blends/make_samples.py into ``folder``."""
    runpy.run_path(str(ROOT / "sample_blends" / "make_samples.py"), run_name="samples")[name](folder / f"{name}.blend")
    return folder / f"{name}.blend"


def make_cornell_box(folder: Path) -> Path:
    return make_sample("cornell_box", folder)


def corner_colors(mesh, name: str) -> np.ndarray:
    """(loops, 3) RGB of a CORNER colour attribute."""
    attribute = mesh.color_attributes[name]
    rgba = np.empty(len(attribute.data) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", rgba)
    return rgba.reshape(-1, 4)[:, :3].astype(np.float64)


def converged_cycles(scene, samples: int, seed: int = 1) -> None:
    """Cycles on the CPU as a converged reference: exactly ``samples`` per texel (no adaptive sampling, which
    stops at a noise threshold), enough bounces for multiple reflection to finish (the default 4 diffuse bounces
    cut off ~10% of the red light in the Cornell box, whose white walls reflect 89% of it) and no clamping."""
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.seed = seed
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.max_bounces = scene.cycles.diffuse_bounces = 64
    scene.cycles.sample_clamp_direct = scene.cycles.sample_clamp_indirect = 0.0


def cycles_vertex_bake(objects, samples: int, name: str = "Cycles", seed: int = 1) -> None:
    """Cycles' Diffuse bake (Direct + Indirect, no Color) into a new FLOAT_COLOR corner attribute of each object."""
    import bpy
    scene = bpy.context.scene
    converged_cycles(scene, samples, seed)
    for obj in scene.objects:
        obj.select_set(False)
    for obj in objects:
        attribute = obj.data.color_attributes.new(name, "FLOAT_COLOR", "CORNER")
        obj.data.color_attributes.active_color = attribute
        obj.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT"}, target="VERTEX_COLORS")


def grid_plane(name: str, size: float, cuts: int, location=(0.0, 0.0, 0.0), colour=(0.5, 0.5, 0.5)):
    """A size x size plane of cuts x cuts quads facing +Z, with a Principled material of the given base colour."""
    import bpy
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=cuts, y_subdivisions=cuts, size=size, location=location)
    obj = bpy.context.active_object
    obj.name = name
    material = bpy.data.materials.new(f"{name} material")
    material.use_nodes = True
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*colour, 1.0)
    obj.data.materials.append(material)
    return obj


def add_light(kind: str, location, energy: float, **data):
    import bpy
    bpy.ops.object.light_add(type=kind, location=location)
    light = bpy.context.active_object
    light.data.energy = energy
    for key, value in data.items():
        setattr(light.data, key, value)
    return light


def cycles_lightmap_bake(objects, uv_map: str, width: int, height: int, samples: int, margin: int = 0,
                         passes=("DIRECT", "INDIRECT"), seed: int = 1):
    """Cycles' Diffuse bake (Direct + Indirect by default, no Color) of the objects into one new float image on the
    given UV map; returns (height, width, 3) light (row 0 at the bottom) and the seconds the bake took. The image
    node is added to (and removed from) every material of the objects."""
    import time

    import bpy
    scene = bpy.context.scene
    converged_cycles(scene, samples, seed)
    scene.render.bake.margin = margin
    image = bpy.data.images.new("cycles bake", width, height, alpha=False, float_buffer=True)
    nodes = []
    for material in {slot.material for obj in objects for slot in obj.material_slots if slot.material}:
        node = material.node_tree.nodes.new("ShaderNodeTexImage")
        node.image = image
        material.node_tree.nodes.active = node
        nodes.append((material, node))
    for obj in scene.objects:
        obj.select_set(obj in objects)
    bpy.context.view_layer.objects.active = objects[0]
    started = time.perf_counter()
    bpy.ops.object.bake(type="DIFFUSE", pass_filter=set(passes), uv_layer=uv_map, margin=margin)
    seconds = time.perf_counter() - started
    for material, node in nodes:
        material.node_tree.nodes.remove(node)
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    return pixels.reshape(height, width, 4)[..., :3].astype(np.float64), seconds


def lightmap_bake(quality: str, folder, **settings) -> tuple:
    """Our lightmap bake of the open file through the job API, as the operator runs it (prepare, solve, apply),
    with the given UserSettings keywords (lightmap_resolution=64, target="BOTH", ...): (the job, whose
    ``lightmaps`` are its pages and ``export`` the exported scene; the report; the seconds prepare and solve
    took)."""
    import time

    import bpy
    from radiosity_baker.radiosity_addon import job
    from radiosity_baker.radiosity_addon.settings import UserSettings
    started = time.perf_counter()
    settings = {"target": "LIGHTMAP", **settings}
    bake = job.prepare(bpy.context, UserSettings(quality=quality.upper(), **settings), str(folder))
    job.solve(bake, lambda fraction, message: None, lambda: False)
    seconds = time.perf_counter() - started
    return bake, job.write_outputs(bake), seconds


def triangle_uvs(mesh, uv_map: str) -> np.ndarray:
    """(t, 3, 2) UVs of the mesh's triangle corners in the given UV map."""
    mesh.calc_loop_triangles()
    loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers[uv_map].data.foreach_get("uv", uv)
    return uv.reshape(-1, 2)[loops].reshape(-1, 3, 2).astype(np.float64)


EDGE_MARGIN_TEXELS = 0.01


def uv_coverage(objects, uv_map: str, width: int, height: int) -> np.ndarray:
    """(height, width) texels whose centre lies inside a triangle of the objects' UV map, more than
    EDGE_MARGIN_TEXELS from its edges: what Cycles bakes on the same triangle as we do. (xatlas puts chart
    borders through texel centres, which Cycles' rasteriser may leave to neither side, and a centre on an edge
    inside a chart may go to the triangle on the other side, a differently lit face.)"""
    from radiosity_baker.core.geometry import triangle_areas
    from radiosity_baker.core.texels import rasterize
    covered = np.zeros(width * height, dtype=bool)
    for obj in objects:
        corner_uv = triangle_uvs(obj.data, uv_map)
        texels = rasterize(corner_uv, width, height)
        corners = np.concatenate([corner_uv * [width, height], np.zeros(corner_uv.shape[:2] + (1,))], axis=2)
        opposite = np.linalg.norm(corners[:, [1, 2, 0]] - corners[:, [2, 0, 1]], axis=2)  # edge facing corner k
        heights = 2 * triangle_areas(corners)[:, None] / np.maximum(opposite, 1e-12)
        distance = texels.barycentric * heights[texels.triangle]  # texels from each edge
        strictly = texels.centre_inside & (distance.min(axis=1) > EDGE_MARGIN_TEXELS)
        covered[texels.pixel[strictly]] = True
    return covered.reshape(height, width)


def empty_black_scene():
    """Factory settings with an empty scene and a black world (Blender 5's worlds come with a grey Background)."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.world = bpy.data.worlds.new("Black")
    scene.world.color = (0.0, 0.0, 0.0)
    if scene.world.node_tree is not None:
        scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    return scene


def quad_room(diffuse: bool) -> list[str]:
    """A 2 m room whose six walls are single quads (Blender planes: every vertex on a corner or an edge of the
    room), a red and a green wall, a 0.6 m block on the floor and a 60 W lamp, in a new empty scene with a black
    world; Blender's default Principled BSDF, or with ``diffuse`` its Specular IOR Level 0. Returns the names of
    the objects."""
    import bpy
    empty_black_scene()
    walls = {"floor": ((0, 0, -1), (0, 0, 0)), "ceiling": ((0, 0, 1), (np.pi, 0, 0)),
             "left": ((-1, 0, 0), (0, np.pi / 2, 0)), "right": ((1, 0, 0), (0, -np.pi / 2, 0)),
             "back": ((0, 1, 0), (np.pi / 2, 0, 0)), "front": ((0, -1, 0), (-np.pi / 2, 0, 0))}
    colours = {"left": (0.6, 0.1, 0.1), "right": (0.1, 0.6, 0.1)}
    for name, (location, rotation) in walls.items():
        bpy.ops.mesh.primitive_plane_add(size=2, location=location, rotation=rotation)
        bpy.context.active_object.name = name
        material = principled_material(name, colours.get(name, (0.7, 0.7, 0.7)), diffuse)
        bpy.context.active_object.data.materials.append(material)
    bpy.ops.mesh.primitive_cube_add(size=0.6, location=(0.3, 0.2, -0.7), rotation=(0, 0, 0.4))
    bpy.context.active_object.name = "block"
    bpy.context.active_object.data.materials.append(principled_material("block", (0.7, 0.7, 0.7), diffuse))
    add_light("POINT", (-0.3, -0.2, 0.7), 60.0)
    return list(walls) + ["block"]


def thick_walled_room(floor_size: float) -> None:
    """quad_room's 2 m room, its lamp and materials (diffuse), but with walls, ceiling and base as closed boxes
    0.3 m thick, and a floor of one quad ``floor_size`` wide at z = -1: wider than 2 m, its corners lie inside the
    walls (a decimated floor, as imported assets have)."""
    import bpy
    empty_black_scene()
    boxes = {"left": ((-1.3, -1.3, -1.3), (-1.0, 1.3, 1.3)), "right": ((1.0, -1.3, -1.3), (1.3, 1.3, 1.3)),
             "back": ((-1.0, 1.0, -1.3), (1.0, 1.3, 1.3)), "front": ((-1.0, -1.3, -1.3), (1.0, -1.0, 1.3)),
             "ceiling": ((-1.0, -1.0, 1.0), (1.0, 1.0, 1.3)), "base": ((-1.0, -1.0, -1.3), (1.0, 1.0, -1.05))}
    colours = {"left": (0.6, 0.1, 0.1), "right": (0.1, 0.6, 0.1)}
    for name, (low, high) in boxes.items():
        low, high = np.array(low), np.array(high)
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=tuple((low + high) / 2), scale=tuple(high - low))
        bpy.context.active_object.name = name
        bpy.ops.object.transform_apply(scale=True)
        material = principled_material(name, colours.get(name, (0.7, 0.7, 0.7)), True)
        bpy.context.active_object.data.materials.append(material)
    bpy.ops.mesh.primitive_plane_add(size=floor_size, location=(0, 0, -1))
    bpy.context.active_object.name = "floor"
    bpy.context.active_object.data.materials.append(principled_material("floor", (0.7, 0.7, 0.7), True))
    add_light("POINT", (-0.3, -0.2, 0.7), 60.0)


def principled_material(name: str, colour, diffuse: bool):
    """A material of Blender's default Principled BSDF with the given base colour; with ``diffuse`` its Specular
    IOR Level 0."""
    import bpy
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    principled = material.node_tree.nodes["Principled BSDF"]
    principled.inputs["Base Color"].default_value = (*colour, 1.0)
    if diffuse:
        principled.inputs["Specular IOR Level"].default_value = 0.0
    return material
