"""Area-to-area form factors computed by the solver's own row code, for comparison with Howell's catalogue."""
from __future__ import annotations

import numpy as np

from core.mesh import build_mesh, elements_of
from core.raycast import RayCaster
from core.scene import Material, Scene
from core.formfactor_rows import HemicubeRows, Patches, RayCastRows, row_blocks


def area_form_factor(receiver: np.ndarray, source: np.ndarray, method: str, element_size_m: float,
                     patch_size_m: float, hemicube_resolution: int = 128, samples_per_edge: int = 2) -> float:
    """F(receiver -> source) = sum_e A_e sum_(p in source) F(e -> p) / A_receiver, both given as (T, 3, 3)."""
    triangles = np.concatenate([receiver, source])
    scene = Scene(triangles, np.zeros(len(triangles), int), [Material("m", (0.5,) * 3, (1.0,) * 3)])
    mesh = build_mesh(scene, patch_size_m, element_size_m)
    elements = elements_of(mesh, scene)
    patches = Patches.of(mesh)
    caster = RayCaster(scene.triangles)
    offset = 2e-5 * scene.size_m
    if method == "hemicube":
        to_mesh = np.full(len(scene.triangles), -1)
        to_mesh[mesh.triangle_scene] = np.arange(len(mesh.triangle_scene))
        rows = HemicubeRows(caster, patches, mesh, hemicube_resolution, offset, to_mesh)
    else:
        rows = RayCastRows(caster, patches, samples_per_edge, offset)
    on_receiver = mesh.node_triangle[elements.node] < len(receiver)
    source_patches = np.flatnonzero(mesh.node_triangle[: mesh.patch_count] >= len(receiver))
    total = 0.0
    for _, block in row_blocks(rows, source_patches, elements, threads=2):
        total += (block[on_receiver].sum(axis=1) * elements.area_m2[on_receiver]).sum()
    return total / elements.area_m2[on_receiver].sum()


def disk_outline(radius: float, z: float, sides: int) -> np.ndarray:
    """(sides, 3) area-preserving polygon for a disk of ``radius`` centred on the z axis at height z."""
    angle = 2 * np.pi * np.arange(sides) / sides
    scale = radius * np.sqrt(np.pi / (0.5 * sides * np.sin(2 * np.pi / sides)))
    return np.stack([scale * np.cos(angle), scale * np.sin(angle), np.full(sides, z)], -1)


def disk(radius: float, z: float, sides: int = 96, facing_up: bool = True) -> np.ndarray:
    """Triangle fan of ``disk_outline``, normals along +z (``facing_up``) or -z."""
    rim = disk_outline(radius, z, sides)
    rim = np.concatenate([rim, rim[:1]])
    centre = np.array([0.0, 0.0, z])
    fan = np.stack([np.broadcast_to(centre, (sides, 3)), rim[:-1], rim[1:]], axis=1)
    return fan if facing_up else fan[:, ::-1]
