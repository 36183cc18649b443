"""A procedural production-like scene: a colonnaded courtyard at 250k to several million triangles.

    python sample_blends/courtyard.py OUT.blend [--triangles 250000] [--seed 0]     (with the bpy module)

The scene is built as numpy geometry first (``courtyard(triangles, seed)``: meshes, object instances, materials,
lights, world), so the core can bake it without Blender (``core_scene``) and the bpy module can save it as a .blend
(``save_blend``). It holds what real levels and archviz interiors bring, on purpose:

- a courtyard open to the sky, lit by a sun and a sky, ringed by two storeys of arcades (columns, semicircular
  arches with soffits and spandrels, flat ceilings, sloped roofs), stairs, and a few lamps under the arcades;
- single-sided walls, ceilings and roofs (as game assets are: open shells seen from both sides), drapes and
  foliage cards hanging in space;
- intersecting geometry: column bases sunk into the floor, a ground floor that runs on under the outer walls (its
  corners buried), crates pushed into each other and into walls, stair steps that overlap;
- decals: emblems 3 mm in front of walls and columns;
- decimated props: noisy blobs with irregular triangles whose vertices sink into their plinths;
- linked duplicates everywhere (every prop instance shares its mesh);
- textures with pure-white texels (floor tiles, plaster, fabric).

The triangle count follows ``triangles`` by tessellation and prop count (within a few percent); the layout does
not change with it, so bakes at 250k, 500k and 1M triangles light the same courtyard.
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field

import numpy as np

COURT_X, COURT_Y = 24.0, 14.0      # open courtyard, m
ARCADE_DEPTH = 3.5                 # arcade depth behind the columns, m
STOREY = (5.0, 4.5)                # ground and upper storey heights, m
COLUMN_SPACING = 3.0               # m
DECAL_GAP_M = 0.003
SLAB_M = 0.15                      # the gallery floor lies this far above the arcade ceiling under it


@dataclass
class Mesh:
    """Triangles of one mesh: (V, 3) vertices (m, object space), (F, 3) vertex indices, (V, 2) UVs."""

    vertices: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray

    @staticmethod
    def join(parts: list["Mesh"]) -> "Mesh":
        offsets = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
        return Mesh(np.concatenate([p.vertices for p in parts]),
                    np.concatenate([p.faces + o for p, o in zip(parts, offsets)]),
                    np.concatenate([p.uvs for p in parts]))

    def flipped(self) -> "Mesh":
        return Mesh(self.vertices, self.faces[:, ::-1], self.uvs)


@dataclass
class Instance:
    """One object: its name, mesh, material and 4 x 4 object-to-world matrix."""

    name: str
    mesh: str
    material: str
    matrix: np.ndarray


@dataclass
class CourtyardScene:
    meshes: dict[str, Mesh] = field(default_factory=dict)
    objects: list[Instance] = field(default_factory=list)
    # material name -> (base colour, texture kind or None, emission strength)
    materials: dict[str, tuple] = field(default_factory=dict)
    # ("SUN", direction, strength) / ("POINT", position, power, radius)
    lights: list[tuple] = field(default_factory=list)
    world: tuple = (0.35, 0.45, 0.6)

    def add(self, name: str, mesh: Mesh, material: str, matrix=None, mesh_name: str | None = None) -> None:
        mesh_name = mesh_name or name
        if mesh_name not in self.meshes:
            self.meshes[mesh_name] = mesh
        self.objects.append(Instance(name, mesh_name, material, np.eye(4) if matrix is None else matrix))

    @property
    def triangle_count(self) -> int:
        return sum(len(self.meshes[item.mesh].faces) for item in self.objects)


# --------------------------------------------------------------------------------------------- primitives
def grid(origin, u_axis, v_axis, nu: int, nv: int, jitter: float = 0.0, rng=None) -> Mesh:
    """A planar nu x nv grid of quads spanning origin + [0, 1] u_axis + [0, 1] v_axis, normal u x v; with
    ``jitter`` the diagonals flip at random (an irregular, decimated-looking triangulation)."""
    origin, u_axis, v_axis = (np.asarray(a, dtype=np.float64) for a in (origin, u_axis, v_axis))
    s, t = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1), indexing="ij")
    vertices = origin + s[..., None] * u_axis + t[..., None] * v_axis
    index = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
    a, b, c, d = index[:-1, :-1].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    flip = (rng.random(len(a)) < 0.5) if (jitter and rng is not None) else np.zeros(len(a), dtype=bool)
    first = np.where(flip[:, None], np.stack([a, b, d], 1), np.stack([a, b, c], 1))
    second = np.where(flip[:, None], np.stack([b, c, d], 1), np.stack([a, c, d], 1))
    uv = np.stack([s.ravel() * np.linalg.norm(u_axis), t.ravel() * np.linalg.norm(v_axis)], 1)
    return Mesh(vertices.reshape(-1, 3), np.concatenate([first, second]), uv)


def box(lo, hi, cuts: int = 1) -> Mesh:
    """A closed axis-aligned box (outward normals), each face cut into cuts x cuts quads."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    faces = [grid((x0, y0, z0), (0, dy, 0), (dx, 0, 0), cuts, cuts),  # bottom, -z
             grid((x0, y0, z1), (dx, 0, 0), (0, dy, 0), cuts, cuts),  # top, +z
             grid((x0, y0, z0), (dx, 0, 0), (0, 0, dz), cuts, cuts),  # -y
             grid((x0, y1, z0), (0, 0, dz), (dx, 0, 0), cuts, cuts),  # +y
             grid((x0, y0, z0), (0, 0, dz), (0, dy, 0), cuts, cuts),  # -x
             grid((x1, y0, z0), (0, dy, 0), (0, 0, dz), cuts, cuts)]  # +x
    return Mesh.join(faces)


def lathe(radius_at, z0: float, z1: float, segments: int, rings: int, caps: bool = True) -> Mesh:
    """A closed surface of revolution about +z: radius_at(t) for t in [0, 1] from z0 to z1."""
    t = np.linspace(0.0, 1.0, rings + 1)
    angle = np.linspace(0.0, 2 * np.pi, segments + 1)
    radius = np.asarray(radius_at(t), dtype=np.float64)
    a, r = np.meshgrid(angle, radius, indexing="ij")
    z = np.broadcast_to(z0 + (z1 - z0) * t, a.shape)
    vertices = np.stack([r * np.cos(a), r * np.sin(a), z], -1).reshape(-1, 3)
    index = np.arange((segments + 1) * (rings + 1)).reshape(segments + 1, rings + 1)
    p, q, s, w = index[:-1, :-1].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([p, q, s], 1), np.stack([p, s, w], 1)])
    uv = np.stack([a.ravel() * radius.max(), z.ravel()], 1)
    parts = [Mesh(vertices, faces, uv)]
    if caps:
        for height, rad, up in ((z0, radius[0], False), (z1, radius[-1], True)):
            if rad > 1e-9:
                ring = np.stack([rad * np.cos(angle[:-1]), rad * np.sin(angle[:-1]), np.full(segments, height)], 1)
                centre = np.array([[0.0, 0.0, height]])
                tri = np.stack([np.zeros(segments, int), 1 + np.arange(segments), 1 + (np.arange(segments) + 1)
                                % segments], 1)
                cap = Mesh(np.concatenate([centre, ring]), tri if up else tri[:, ::-1],
                           np.concatenate([centre, ring])[:, :2])
                parts.append(cap)
    mesh = Mesh.join(parts)
    return _drop_degenerate(mesh)


def blob(radius: float, segments: int, rng, roughness: float = 0.25) -> Mesh:
    """A decimated-looking lumpy sphere: a UV sphere with noisy radii and randomly thinned rings."""
    rings = max(4, segments // 2)
    mesh = lathe(lambda t: radius * np.sin(np.pi * np.clip(t, 1e-3, 1 - 1e-3)), -radius, radius, segments, rings,
                 caps=True)
    noise = 1.0 + roughness * (rng.random(len(mesh.vertices)) - 0.5)
    centre = mesh.vertices.mean(axis=0)
    vertices = centre + (mesh.vertices - centre) * noise[:, None]
    return Mesh(vertices, mesh.faces, mesh.uvs)


def _drop_degenerate(mesh: Mesh) -> Mesh:
    v = mesh.vertices[mesh.faces]
    area = np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    return Mesh(mesh.vertices, mesh.faces[area > 1e-12], mesh.uvs)


def arch_band(x0: float, x1: float, spring: float, top: float, y0: float, y1: float, samples: int) -> Mesh:
    """One arch bay between x0 and x1 in a wall from y0 to y1 (thickness along y): a semicircular soffit springing
    at height ``spring`` and the two spandrels (faces at y0 and y1) up to ``top``, single-sided, facing out of the
    wall."""
    radius = 0.5 * (x1 - x0)
    angle = np.linspace(np.pi, 0.0, samples + 1)
    x = 0.5 * (x0 + x1) + radius * np.cos(angle)
    z = spring + radius * np.sin(angle)
    parts = []
    for y, facing in ((y0, -1.0), (y1, 1.0)):
        arch = np.stack([x, np.full_like(x, y), z], 1)
        upper = np.stack([x, np.full_like(x, y), np.full_like(x, top)], 1)
        vertices = np.concatenate([arch, upper])
        n = samples + 1
        i = np.arange(samples)
        faces = np.concatenate([np.stack([i, i + 1, n + i + 1], 1), np.stack([i, n + i + 1, n + i], 1)])
        if facing > 0:
            faces = faces[:, ::-1]
        parts.append(Mesh(vertices, faces, vertices[:, [0, 2]]))
    inner = np.concatenate([np.stack([x, np.full_like(x, y0), z], 1), np.stack([x, np.full_like(x, y1), z], 1)])
    n = samples + 1
    i = np.arange(samples)
    soffit = np.concatenate([np.stack([i, n + i, n + i + 1], 1), np.stack([i, n + i + 1, i + 1], 1)])
    parts.append(Mesh(inner, soffit, np.stack([np.concatenate([angle, angle]) * radius, inner[:, 1]], 1)))
    return _drop_degenerate(Mesh.join(parts))


def foliage(count: int, spread: float, height: float, rng) -> Mesh:
    """``count`` single-sided leaf cards (two triangles each) at random orientations in a bush."""
    centre = np.stack([rng.normal(0, spread / 3, count), rng.normal(0, spread / 3, count),
                       height * rng.random(count)], 1)
    size = 0.06 + 0.06 * rng.random(count)
    theta, phi = 2 * np.pi * rng.random(count), np.arccos(2 * rng.random(count) - 1)
    u = np.stack([np.cos(theta), np.sin(theta), np.zeros(count)], 1)
    w = np.stack([np.sin(phi) * np.cos(theta + 1.3), np.sin(phi) * np.sin(theta + 1.3), np.cos(phi)], 1)
    v = np.cross(w, u)
    v /= np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-9)
    corners = np.stack([centre - size[:, None] * (u + v), centre + size[:, None] * (u - v),
                        centre + size[:, None] * (u + v), centre - size[:, None] * (u - v)], 1)
    base = 4 * np.arange(count)
    faces = np.concatenate([np.stack([base, base + 1, base + 2], 1), np.stack([base, base + 2, base + 3], 1)])
    uv = np.tile([[0, 0], [1, 0], [1, 1], [0, 1]], (count, 1)).astype(float)
    return Mesh(corners.reshape(-1, 3), faces, uv)


def drape(width: float, length: float, nu: int, nv: int, rng) -> Mesh:
    """A single-sided hanging cloth in the xz plane (normal -y), folded by a sine wave along x."""
    mesh = grid((0, 0, 0), (width, 0, 0), (0, 0, -length), nu, nv)
    folds = 0.06 * np.sin(mesh.vertices[:, 0] * 2 * np.pi / 0.35 + rng.random() * 6) * \
        (1 - mesh.vertices[:, 2] / length * 0.3)
    vertices = mesh.vertices + np.stack([np.zeros_like(folds), folds, np.zeros_like(folds)], 1)
    return Mesh(vertices, mesh.faces, mesh.uvs)


def transform(rotation_z: float = 0.0, translation=(0.0, 0.0, 0.0), scale: float = 1.0) -> np.ndarray:
    c, s = np.cos(rotation_z), np.sin(rotation_z)
    matrix = np.eye(4)
    matrix[:3, :3] = scale * np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    matrix[:3, 3] = translation
    return matrix


# --------------------------------------------------------------------------------------------- the scene
def courtyard(triangles: int = 250_000, seed: int = 0) -> CourtyardScene:
    """The courtyard at about ``triangles`` triangles (see the module docstring)."""
    low, high = 0.05, 20.0  # tessellation scale: prop counts and subdivisions grow with it
    for _ in range(30):
        detail = np.sqrt(low * high)
        count = _build(detail, seed).triangle_count
        low, high = (detail, high) if count < triangles else (low, detail)
    return _build(np.sqrt(low * high), seed)


def _build(detail: float, seed: int) -> CourtyardScene:
    rng = np.random.default_rng(seed)
    scene = CourtyardScene()
    scene.materials.update({
        "plaster": ((0.78, 0.74, 0.66), "plaster", 0.0),
        "stone floor": ((0.6, 0.58, 0.55), "tiles", 0.0),
        "marble": ((0.9, 0.9, 0.88), None, 0.0),
        "terracotta": ((0.6, 0.32, 0.2), None, 0.0),
        "wood": ((0.42, 0.28, 0.16), None, 0.0),
        "fabric red": ((0.7, 0.08, 0.06), "fabric", 0.0),
        "fabric blue": ((0.1, 0.2, 0.6), "fabric", 0.0),
        "foliage": ((0.12, 0.35, 0.08), None, 0.0),
        "gold": ((0.85, 0.62, 0.2), None, 0.0),
        "bronze": ((0.35, 0.25, 0.15), None, 0.0),
    })
    outer_x, outer_y = COURT_X / 2 + ARCADE_DEPTH, COURT_Y / 2 + ARCADE_DEPTH
    height = sum(STOREY)
    floor_cuts = int(round(90 * detail))
    # Ground floor: one irregular mesh running on under the outer walls (its border is buried in them).
    scene.add("ground floor", grid((-outer_x - 0.4, -outer_y - 0.4, 0.0), (2 * outer_x + 0.8, 0, 0),
                                   (0, 2 * outer_y + 0.8, 0), floor_cuts, int(floor_cuts * outer_y / outer_x),
                                   jitter=1.0, rng=rng), "stone floor")
    # Outer walls: single-sided planes facing inwards, both storeys.
    wall_cuts = max(2, int(round(24 * detail)))
    for name, origin, u_axis in (("wall south", (-outer_x, -outer_y, 0), (2 * outer_x, 0, 0)),
                                 ("wall east", (outer_x, -outer_y, 0), (0, 2 * outer_y, 0)),
                                 ("wall north", (outer_x, outer_y, 0), (-2 * outer_x, 0, 0)),
                                 ("wall west", (-outer_x, outer_y, 0), (0, -2 * outer_y, 0))):
        scene.add(name, grid(origin, u_axis, (0, 0, height + 1.2), wall_cuts * 2, wall_cuts), "plaster")
    _arcades(scene, detail, rng, outer_x, outer_y)
    _stairs(scene, detail, outer_x)
    _props(scene, detail, rng, outer_x, outer_y)
    scene.lights.append(("SUN", (-0.35, 0.25, -0.9), 4.0, 0.02))
    for x in (-8.0, 0.0, 8.0):
        for y in (-(COURT_Y / 2 + ARCADE_DEPTH / 2), COURT_Y / 2 + ARCADE_DEPTH / 2):
            scene.lights.append(("POINT", (x, y, STOREY[0] - 0.6), 60.0, 0.08))
    return scene


def _arcades(scene: CourtyardScene, detail: float, rng, outer_x: float, outer_y: float) -> None:
    """Columns, arches, ceilings and sloped roofs on the four sides of the courtyard, two storeys. Each side is
    built in a frame whose x runs along it and whose -y points from the courtyard's edge into the arcade."""
    segments = max(8, int(round(48 * detail)))
    rings = max(2, int(round(10 * detail)))
    arch_samples = max(6, int(round(24 * detail)))
    radius = 0.5 * COLUMN_SPACING
    springs = [h - 0.1 - radius for h in STOREY]  # arch springs above each storey's floor
    column = lathe(lambda t: 0.28 - 0.04 * t + 0.03 * np.exp(-((t - 0.03) / 0.03) ** 2), -0.15, springs[0] - 0.4,
                   segments, rings)
    capital = box((-0.4, -0.4, 0.0), (0.4, 0.4, 0.4), cuts=max(1, int(round(3 * detail))))
    upper_column = lathe(lambda t: 0.2 - 0.03 * t, 0.0, springs[1], segments // 2 + 4, rings)
    baluster = lathe(lambda t: 0.05 + 0.03 * np.sin(np.pi * t), 0.0, 0.9, max(6, segments // 4), max(2, rings // 2))
    top = sum(STOREY)
    for side, angle, length, across in (("south", 0.0, COURT_X, COURT_Y), ("north", np.pi, COURT_X, COURT_Y),
                                        ("east", np.pi / 2, COURT_Y, COURT_X), ("west", -np.pi / 2, COURT_Y, COURT_X)):
        frame = transform(angle)
        edge = -across / 2
        wall = edge - ARCADE_DEPTH
        span = length + 2 * ARCADE_DEPTH  # ceilings and roofs run into the neighbouring sides' (they intersect)
        xs = np.linspace(-length / 2, length / 2, int(round(length / COLUMN_SPACING)) + 1)
        for storey, (z0, h) in enumerate(zip((0.0, STOREY[0]), STOREY)):
            for i, x in enumerate(xs):
                place = frame @ transform(0.0, (x, edge, z0))
                if storey == 0:
                    scene.add(f"column {side} {i}", column, "marble", place, "column")
                    scene.add(f"capital {side} {i}", capital, "marble",
                              place @ transform(0.0, (0, 0, springs[0] - 0.4)), "capital")
                else:
                    scene.add(f"upper column {side} {i}", upper_column, "marble", place, "upper column")
            arches = Mesh.join([arch_band(a, b, z0 + springs[storey], z0 + h, edge - 0.2, edge + 0.2, arch_samples)
                                for a, b in zip(xs[:-1], xs[1:])])
            scene.add(f"arches {side} {storey}", _in(frame, arches), "plaster")
            # Flat ceiling over the arcade (single-sided, facing down); over the ground storey the gallery floor.
            ceiling = grid((-span / 2, wall, z0 + h), (0, ARCADE_DEPTH - 0.2, 0), (span, 0, 0),
                           max(2, int(6 * detail)), max(4, int(40 * detail)))
            scene.add(f"ceiling {side} {storey}", _in(frame, ceiling), "plaster")
            if storey == 0:
                slab = _in(transform(0.0, (0.0, 0.0, SLAB_M)), ceiling.flipped())
                scene.add(f"gallery floor {side}", _in(frame, slab), "stone floor")
                for k, x in enumerate(np.linspace(-length / 2 + 0.2, length / 2 - 0.2, int(round(length / 0.35)))):
                    scene.add(f"baluster {side} {k}", baluster, "marble",
                              frame @ transform(0.0, (x, edge, STOREY[0])), "baluster")
                rail = box((-length / 2, edge - 0.1, STOREY[0] + 0.9), (length / 2, edge + 0.1, STOREY[0] + 1.0))
                scene.add(f"rail {side}", _in(frame, rail), "marble")
        # Sloped roof over the upper gallery: single-sided, facing up, from above the outer wall to the edge.
        roof = grid((-span / 2, wall, top + 1.2), (0, ARCADE_DEPTH + 0.6, -0.9), (span, 0, 0),
                    max(2, int(6 * detail)), max(4, int(40 * detail)))
        scene.add(f"roof {side}", _in(frame, roof.flipped()), "terracotta")
        # Decals: emblems 3 mm in front of the outer wall, facing the arcade, one per bay.
        for i, x in enumerate(xs[:-1] + COLUMN_SPACING / 2):
            emblem = grid((x - 0.4, wall + DECAL_GAP_M, 2.2), (0.8, 0, 0), (0, 0, 0.8), 2, 2).flipped()
            scene.add(f"emblem {side} {i}", _in(frame, emblem), "gold")


def _in(matrix: np.ndarray, mesh: Mesh) -> Mesh:
    """The mesh with the matrix applied to its vertices (geometry baked into the mesh, not the object)."""
    return Mesh(mesh.vertices @ matrix[:3, :3].T + matrix[:3, 3], mesh.faces, mesh.uvs)


def _stairs(scene: CourtyardScene, detail: float, outer_x: float) -> None:
    """A staircase in the west arcade up to the gallery: overlapping closed steps."""
    steps = 24
    rise, run = STOREY[0] / steps, 0.32
    step = box((0.0, 0.0, -0.05), (1.6, run + 0.05, rise), cuts=max(1, int(round(2 * detail))))
    for k in range(steps):
        scene.add(f"step {k}", step, "marble", transform(0.0, (-outer_x + 0.3, -COURT_Y / 2 + 0.5 + k * run,
                                                                k * rise)), "step")


def _props(scene: CourtyardScene, detail: float, rng, outer_x: float, outer_y: float) -> None:
    """Crates, barrels, urns, plant pots with foliage, benches, drapes and decimated statues, as linked
    duplicates; several intersect each other, the floor or the walls."""
    segments = max(8, int(round(32 * detail)))
    meshes = {
        "crate": (box((-0.4, -0.4, 0.0), (0.4, 0.4, 0.8), cuts=max(1, int(round(4 * detail)))), "wood"),
        "barrel": (lathe(lambda t: 0.32 + 0.06 * np.sin(np.pi * t), 0.0, 1.0, segments, max(4, int(12 * detail))),
                   "wood"),
        "urn": (lathe(lambda t: 0.18 + 0.2 * np.sin(np.pi * t ** 0.8), 0.0, 0.9, segments, max(6, int(16 * detail))),
                "terracotta"),
        "pot": (lathe(lambda t: 0.3 + 0.1 * t, 0.0, 0.5, segments, max(2, int(4 * detail))), "terracotta"),
        "bench": (Mesh.join([box((-0.9, -0.25, 0.4), (0.9, 0.25, 0.48), cuts=max(1, int(round(3 * detail)))),
                             box((-0.8, -0.2, 0.0), (-0.7, 0.2, 0.42)), box((0.7, -0.2, 0.0), (0.8, 0.2, 0.42))]),
                  "wood"),
    }
    bush = foliage(int(600 * detail ** 2), 0.5, 1.2, rng)
    statue = blob(0.45, max(12, int(round(60 * detail))), rng)
    plinth = box((-0.45, -0.45, 0.0), (0.45, 0.45, 1.1), cuts=2)
    # Props under the arcades along the walls and in the courtyard.
    count = int(round(60 * detail))
    kinds = list(meshes)
    for k in range(count):
        kind = kinds[k % len(kinds)]
        mesh, material = meshes[kind]
        side = rng.integers(4)
        t = rng.uniform(-0.45, 0.45)
        depth = rng.uniform(0.6, ARCADE_DEPTH - 0.4)
        if side < 2:
            x, y = t * 2 * outer_x, (COURT_Y / 2 + depth) * (1 if side else -1)
        else:
            x, y = (COURT_X / 2 + depth) * (1 if side == 3 else -1), t * 2 * outer_y
        if k % 7 == 3:  # some stand in the courtyard itself
            x, y = rng.uniform(-COURT_X / 2 + 1, COURT_X / 2 - 1), rng.uniform(-COURT_Y / 2 + 1, COURT_Y / 2 - 1)
        place = transform(rng.uniform(0, 2 * np.pi), (x, y, 0.0))
        scene.add(f"{kind} {k}", mesh, material, place, kind)
        if kind == "crate" and k % 2 == 0:  # a second crate pushed into the first, tilted on top
            scene.add(f"{kind} {k} stacked", mesh, material, place @ transform(0.5, (0.2, 0.1, 0.7)), kind)
        if kind == "pot":
            scene.add(f"bush {k}", bush, "foliage", place @ transform(0.0, (0, 0, 0.4)), "bush")
    # Statues on plinths in the courtyard: decimated blobs sunk into their plinths.
    for k, x in enumerate(np.linspace(-COURT_X / 2 + 3, COURT_X / 2 - 3, 4)):
        place = transform(0.3 * k, (x, 0.0, 0.0))
        scene.add(f"plinth {k}", plinth, "marble", place, "plinth")
        scene.add(f"statue {k}", statue, "bronze", place @ transform(0.0, (0, 0, 1.4)), "statue")
    # Drapes hanging from the gallery rail over the courtyard side of the upper arcade (single-sided).
    cloth = drape(1.8, 3.2, max(4, int(round(30 * detail))), max(4, int(round(50 * detail))), rng)
    for k, x in enumerate(np.linspace(-COURT_X / 2 + 2, COURT_X / 2 - 2, 6)):
        for sign in (-1, 1):
            material = "fabric red" if (k + (sign > 0)) % 2 else "fabric blue"
            matrix = transform(0.0 if sign < 0 else np.pi, (x + 0.9 * sign, sign * (COURT_Y / 2 - 0.25),
                                                            STOREY[0] + 0.95))
            scene.add(f"drape {k} {'north' if sign > 0 else 'south'}", cloth, material, matrix, "drape")
    # Shields (decals) 3 mm in front of the courtyard face of some columns.
    shield = grid((-0.2, 0.0, 0.0), (0.4, 0, 0), (0, 0, 0.5), 2, 2)
    for k, x in enumerate(np.linspace(-COURT_X / 2, COURT_X / 2, 9)):
        radius = 0.28 - 0.04 * (2.0 / (STOREY[0] - 0.5)) + DECAL_GAP_M
        scene.add(f"shield {k}", shield, "gold", transform(np.pi, (x, -COURT_Y / 2 + radius, 1.8)), "shield")


# --------------------------------------------------------------------------------------------- outputs
def texture_pixels(kind: str, colour, size: int = 128) -> np.ndarray:
    """(size, size, 3) linear RGB in [0, 1] around ``colour``, with pure-white texels as stock textures have
    (grout lines, highlights, stripes)."""
    y, x = np.mgrid[0:size, 0:size] / size
    colour = np.asarray(colour, dtype=np.float64)
    if kind == "tiles":
        grout = (np.mod(x * 8, 1.0) < 0.06) | (np.mod(y * 8, 1.0) < 0.06)
        light = (np.floor(x * 8) + np.floor(y * 8)) % 2 == 0
        rgb = np.where(grout[..., None], 1.0, colour * np.where(light, 1.2, 0.8)[..., None])
    elif kind == "plaster":
        noise = np.random.default_rng(7).random((size, size))
        rgb = colour * (1.0 + 0.6 * (noise - 0.5) + 0.3 * np.sin(x * 20) * np.sin(y * 13))[..., None]
    else:  # fabric: white stripes
        rgb = np.where((np.mod(x * 16, 1.0) < 0.2)[..., None], 1.0, colour)
    return np.clip(rgb, 0.0, 1.0)


def core_scene(model: CourtyardScene):
    """The model as a core.Scene (textures averaged per element through the object's UVs)."""
    from core import Material, PointLight, Scene, SunLight, World
    from core.texture import ReflectanceTexture
    names = list(model.materials)
    materials = []
    for name in names:
        colour, texture, _ = model.materials[name]
        tex = ReflectanceTexture(texture_pixels(texture, colour)) if texture else None
        materials.append(Material(name, tuple(colour), texture=tex))
    triangles, material, objects, uvs = [], [], [], []
    for number, item in enumerate(model.objects):
        mesh = model.meshes[item.mesh]
        world = mesh.vertices @ item.matrix[:3, :3].T + item.matrix[:3, 3]
        triangles.append(world[mesh.faces])
        uvs.append(mesh.uvs[mesh.faces] / 2.0)
        material.append(np.full(len(mesh.faces), names.index(item.material)))
        objects.append(np.full(len(mesh.faces), number))
    lights = []
    for number, light in enumerate(model.lights):
        if light[0] == "SUN":
            lights.append(SunLight(f"sun {number}", light[1], light[2], angle_rad=light[3]))
        else:
            lights.append(PointLight(f"lamp {number}", light[1], light[2], radius_m=light[3]))
    return Scene(np.concatenate(triangles), np.concatenate(material), materials, lights,
                 World(tuple(model.world)), object_index=np.concatenate(objects),
                 object_names=[item.name for item in model.objects], triangle_uv=np.concatenate(uvs))


def save_blend(model: CourtyardScene, path: str) -> None:
    """Save the model as a .blend with the bpy module: one mesh datablock per mesh (linked duplicates share it),
    Principled materials (textures as packed images), a sun, point lights and a constant sky."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    materials = {name: _blender_material(name, *spec) for name, spec in model.materials.items()}
    meshes = {}
    for name, mesh in model.meshes.items():
        data = bpy.data.meshes.new(name)
        data.vertices.add(len(mesh.vertices))
        data.vertices.foreach_set("co", mesh.vertices.astype(np.float32).ravel())
        count = len(mesh.faces)
        data.loops.add(3 * count)
        data.loops.foreach_set("vertex_index", mesh.faces.astype(np.int32).ravel())
        data.polygons.add(count)
        data.polygons.foreach_set("loop_start", (3 * np.arange(count)).astype(np.int32))
        data.polygons.foreach_set("loop_total", np.full(count, 3, dtype=np.int32))
        uv = data.uv_layers.new(name="UVMap")
        uv.data.foreach_set("uv", (mesh.uvs[mesh.faces.ravel()] / 2.0).astype(np.float32).ravel())
        data.update()
        data.validate()
        meshes[name] = data
    for item in model.objects:
        obj = bpy.data.objects.new(item.name, meshes[item.mesh])
        if not obj.data.materials:
            obj.data.materials.append(materials[item.material])
        obj.material_slots[0].link = "OBJECT"
        obj.material_slots[0].material = materials[item.material]
        obj.matrix_world = _matrix(item.matrix)
        scene.collection.objects.link(obj)
    for number, light in enumerate(model.lights):
        kind = light[0]
        data = bpy.data.lights.new(f"{kind.lower()} {number}", kind)
        obj = bpy.data.objects.new(data.name, data)
        if kind == "SUN":
            data.energy, data.angle = light[2], light[3]
            direction = np.asarray(light[1], dtype=np.float64)
            obj.rotation_mode = "QUATERNION"
            obj.rotation_quaternion = _rotation_to(-direction / np.linalg.norm(direction))
        else:
            obj.location = light[1]
            data.energy, data.shadow_soft_size = light[2], light[3]
        scene.collection.objects.link(obj)
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*model.world, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    scene.world = world
    bpy.ops.wm.save_as_mainfile(filepath=str(path))


def _matrix(matrix: np.ndarray):
    from mathutils import Matrix
    return Matrix(matrix.tolist())


def _rotation_to(direction: np.ndarray):
    """The quaternion turning +Z to ``direction`` (a light shines along its local -Z)."""
    from mathutils import Vector
    return Vector((0.0, 0.0, 1.0)).rotation_difference(Vector(direction.tolist()))


def _blender_material(name: str, colour, texture, emission: float):
    """The sample scenes' diffuse material (make_samples.material), emitting ``emission`` x the colour, with the
    generated ``texture`` as its base colour."""
    import bpy
    from make_samples import material as diffuse_material
    material = diffuse_material(name, colour, tuple(emission * c for c in colour) if emission else None)
    bsdf = material.node_tree.nodes["Principled BSDF"]
    if texture:
        pixels = texture_pixels(texture, colour)
        size = pixels.shape[0]
        image = bpy.data.images.new(f"{name} texture", size, size, alpha=False, float_buffer=True)
        image.pixels.foreach_set(np.concatenate([pixels, np.ones((size, size, 1))], -1).astype(np.float32).ravel())
        image.pack()
        node = material.node_tree.nodes.new("ShaderNodeTexImage")
        node.image = image
        material.node_tree.links.new(node.outputs["Color"], bsdf.inputs["Base Color"])
    return material


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("output", help="the .blend to write")
    parser.add_argument("--triangles", type=int, default=250_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    model = courtyard(args.triangles, args.seed)
    save_blend(model, args.output)
    print(f"{args.output}: {model.triangle_count} triangles, {len(model.objects)} objects, "
          f"{len(model.meshes)} meshes")


if __name__ == "__main__":
    main(sys.argv[1:])
