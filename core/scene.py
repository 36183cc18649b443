"""Scene model: world-space triangles, diffuse materials, analytic lights and a constant world.

Units follow Blender / Cycles (see docs/units.md):
- lengths in metres, everything scene-linear RGB;
- a material's ``emitted_radiance`` is L in W m^-2 sr^-1 per channel; its exitance is pi L;
- point and spot lights carry a power P in W with radiant intensity P / (4 pi) (Blender's convention);
- a sun carries its strength S in W m^-2 (irradiance S cos(theta));
- an area light carries a power P in W, emitted as radiance P / (pi A) from its emitting side (Cycles);
- the world is a constant background radiance.

Validation happens once, on construction, and raises :class:`SceneError` naming the offending item.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from .errors import SceneError
from .geometry import lengths, triangle_areas, triangle_unit_normals

RGB = tuple[float, float, float]
TERMINATOR_GEOMETRY_OFFSET = 0.1  # Blender's default for an object's Shadow Terminator Geometry Offset
# Pure white (reflectance 1) is accepted, as in Cycles; the solve keeps elements just below it, so that light
# bouncing between white walls stays finite (the bake says so in its warnings).
MAX_REFLECTANCE = 0.99
# The most a light's power (W), a sun's strength (W m^-2) or an emitted or world radiance (W m^-2 sr^-1) may be,
# per channel: far beyond any real lamp, and far from where float32 light overflows in the solve's sums.
MAX_EMISSION = 1e12


@dataclass(frozen=True)
class Material:
    """Lambertian material. ``reflectance`` in [0, 1] per channel; ``emitted_radiance`` >= 0 (W m^-2 sr^-1).

    ``texture`` (optional, core.texture.ReflectanceTexture): a base-colour image read through the scene's
    ``triangle_uv``; elements then reflect the image's mean over their footprint, and ``reflectance`` is the
    image's overall mean (used where one value is needed). ``light_group``: the light group its emission belongs
    to ("" none; see ``Scene.light_groups``)."""

    name: str
    reflectance: RGB = (0.8, 0.8, 0.8)
    emitted_radiance: RGB = (0.0, 0.0, 0.0)
    texture: object = None
    light_group: str = ""


@dataclass(frozen=True)
class PointLight:
    """Blender point light: ``power_w`` (W) per channel via ``color``; ``radius_m`` softens shadows.

    ``soft_falloff`` (Blender 4.0+, on by default) makes a sized light fall off as a disk facing the receiver,
    I cos(theta) / (r^2 + radius^2), instead of I cos(theta) / r^2.
    """

    name: str
    position: tuple[float, float, float]
    power_w: float
    color: RGB = (1.0, 1.0, 1.0)
    radius_m: float = 0.0
    soft_falloff: bool = True
    light_group: str = ""


@dataclass(frozen=True)
class SpotLight:
    """Blender spot light: a point light masked by a cone of full angle ``spot_size_rad`` around ``direction``.

    ``spot_blend`` in [0, 1] softens the cone edge with Cycles' smoothstep (Blender 4.x, kernel/light/spot.h).
    """

    name: str
    position: tuple[float, float, float]
    direction: tuple[float, float, float]
    power_w: float
    spot_size_rad: float
    spot_blend: float = 0.15
    color: RGB = (1.0, 1.0, 1.0)
    radius_m: float = 0.0
    soft_falloff: bool = True
    light_group: str = ""


@dataclass(frozen=True)
class SunLight:
    """Blender sun: ``strength_w_m2`` (irradiance on a facing surface); light travels along ``direction``.

    ``angle_rad`` is the sun's angular diameter (soft shadows).
    """

    name: str
    direction: tuple[float, float, float]
    strength_w_m2: float
    color: RGB = (1.0, 1.0, 1.0)
    angle_rad: float = 0.0
    light_group: str = ""


AREA_SHAPES = ("SQUARE", "RECTANGLE", "DISK", "ELLIPSE")


@dataclass(frozen=True)
class AreaLight:
    """Blender area light centred at ``position``; emits from one side, along ``direction`` (local -Z).

    ``size_m`` is the X size (diameter for disks); ``size_y_m`` the Y size for RECTANGLE / ELLIPSE.
    ``axis_x`` orients the light's local X axis in the plane.
    """

    name: str
    position: tuple[float, float, float]
    direction: tuple[float, float, float]
    power_w: float
    shape: str = "SQUARE"
    size_m: float = 1.0
    size_y_m: float | None = None
    axis_x: tuple[float, float, float] | None = None
    color: RGB = (1.0, 1.0, 1.0)
    light_group: str = ""


Light = PointLight | SpotLight | SunLight | AreaLight


@dataclass(frozen=True)
class World:
    """Constant background radiance (W m^-2 sr^-1): Blender's world colour x strength."""

    radiance: RGB = (0.0, 0.0, 0.0)
    light_group: str = ""


@dataclass
class Scene:
    """Triangles in world space with one material each, plus lights and the world.

    triangles:       (T, 3, 3) float64, vertex positions in metres.
    material_index:  (T,) int, index into ``materials``.
    object_index:    (T,) int, index into ``object_names`` (for messages and per-object outputs).
    casts_only:      (T,) bool, True for "shadow only" geometry: it blocks light but is not solved.
    triangle_uv:     (T, 3, 2) float, optional: each corner's UV in its material's texture.
    corner_normals:  (T, 3, 3) float, optional: each corner's shading normal (Blender's corner normals: smooth
                     shading, sharp edges, custom normals); default, and wherever one is not finite or is zero,
                     the triangle's own normal.
    terminator_offset: (T,) float in [0, 1], optional: the object's Cycles Shadow Terminator Geometry Offset
                     (core.terminator; 0 turns the smooth-surface start off); default 0.1, Blender's.
    light_factor:    (L,) float >= 0, optional: each lamp's light is its power x this (default 1). A light group's
                     scene (``lit_by``) sets the other lamps' to 0 and keeps their power, by which the lamps
                     sampled one at a time are chosen (core.analytic_lights.sampled_irradiance): each such sample
                     then lands in exactly one group.

    Zero-area triangles are dropped on construction; ``dropped_triangles`` counts them and
    ``triangle_source`` maps each kept triangle to its index in the input.
    """

    triangles: np.ndarray
    material_index: np.ndarray
    materials: list[Material]
    lights: list = field(default_factory=list)
    world: World = field(default_factory=World)
    object_index: np.ndarray | None = None
    object_names: list[str] | None = None
    casts_only: np.ndarray | None = None
    triangle_uv: np.ndarray | None = None
    corner_normals: np.ndarray | None = None
    terminator_offset: np.ndarray | None = None
    light_factor: np.ndarray | None = None
    dropped_triangles: int = field(init=False, default=0)
    triangle_source: np.ndarray = field(init=False)

    def __post_init__(self):
        self.triangles = _per_triangle(self.triangles, "triangles", (3, 3), np.float64)
        count = len(self.triangles)
        self.material_index = np.asarray(self.material_index, dtype=np.int64).reshape(-1)
        if self.object_index is None:
            self.object_index = np.zeros(count, dtype=np.int64)
        self.object_index = np.asarray(self.object_index, dtype=np.int64).reshape(-1)
        if self.object_names is None:
            self.object_names = [f"object {i}" for i in range(int(self.object_index.max(initial=-1)) + 1)]
        if self.casts_only is None:
            self.casts_only = np.zeros(count, dtype=bool)
        self.casts_only = np.asarray(self.casts_only, dtype=bool).reshape(-1)
        if self.triangle_uv is None:
            self.triangle_uv = np.zeros((count, 3, 2))
        self.triangle_uv = _per_triangle(self.triangle_uv, "triangle_uv", (3, 2), np.float64)
        self.corner_normals = _unit_corner_normals(self.triangles, self.corner_normals)
        if self.terminator_offset is None:
            self.terminator_offset = np.full(count, TERMINATOR_GEOMETRY_OFFSET)
        self.terminator_offset = np.asarray(self.terminator_offset, dtype=np.float64).reshape(-1)
        if self.light_factor is None:
            self.light_factor = np.ones(len(self.lights))
        self.light_factor = np.asarray(self.light_factor, dtype=np.float64).reshape(-1)
        _validate(self)
        keep = triangle_areas(self.triangles) > 0.0
        self.dropped_triangles = int(count - keep.sum())
        self.triangle_source = np.flatnonzero(keep)
        self.triangles = self.triangles[keep]
        self.material_index = self.material_index[keep]
        self.object_index = self.object_index[keep]
        self.casts_only = self.casts_only[keep]
        self.triangle_uv = self.triangle_uv[keep]
        self.corner_normals = self.corner_normals[keep]
        self.terminator_offset = self.terminator_offset[keep]
        if not (~self.casts_only).any():
            raise SceneError("Nothing to bake: every triangle has zero area or is 'shadow only'.")

    @cached_property
    def unit_normals(self) -> np.ndarray:
        """(T, 3) each triangle's unit normal (counter-clockwise corners face it), for the rays' hits."""
        return triangle_unit_normals(self.triangles)

    @property
    def reflectance(self) -> np.ndarray:
        """(M, 3) reflectance per material."""
        return np.array([m.reflectance for m in self.materials], dtype=np.float64).reshape(-1, 3)

    def reflectance_at(self, scene_triangle: np.ndarray, barycentric: np.ndarray) -> np.ndarray:
        """(m, 3) reflectance at surface points: the material's, or its texture's nearest texel where the
        material has one and the triangle has finite UVs."""
        reflectance = self.reflectance[self.material_index[scene_triangle]]
        for texture, rows in self.textured_rows(scene_triangle):
            uv = np.einsum("mc,mck->mk", barycentric[rows], self.triangle_uv[scene_triangle[rows]])
            reflectance[rows] = texture.lookup(uv)
        return reflectance

    def shading_normals(self, scene_triangle: np.ndarray, barycentric: np.ndarray) -> np.ndarray:
        """(m, 3) unit shading normals at surface points: the corner normals interpolated and normalised, as
        Cycles shades a smooth triangle (and bakes it); the triangle's normal where they cancel out."""
        normal = np.einsum("mc,mck->mk", barycentric, self.corner_normals[scene_triangle])
        length = lengths(normal)[:, None]
        flat = self.unit_normals[scene_triangle]
        return np.where(length > 1e-6, normal / np.maximum(length, 1e-300), flat)

    def textured_rows(self, scene_triangle: np.ndarray):
        """(texture, rows) for each textured material among the given triangles: the rows whose triangle has it
        and finite UVs."""
        material = self.material_index[scene_triangle]
        mapped = np.isfinite(self.triangle_uv[scene_triangle]).all(axis=(1, 2))
        for index, item in enumerate(self.materials):
            rows = np.flatnonzero((material == index) & mapped) if item.texture is not None else []
            if len(rows):
                yield item.texture, rows

    @property
    def emitted_radiance(self) -> np.ndarray:
        """(M, 3) emitted radiance per material, W m^-2 sr^-1."""
        return np.array([m.emitted_radiance for m in self.materials], dtype=np.float64).reshape(-1, 3)

    @property
    def emissive(self) -> np.ndarray:
        """(T,) bool: the triangles whose material emits light in some channel."""
        return (self.emitted_radiance > 0).any(axis=1)[self.material_index]

    @property
    def light_groups(self) -> list[str]:
        """The light groups that emit light here (Cycles' light groups: lamps, emissive materials and the world
        each belong to one, or to none, ""), sorted, "" first when anything ungrouped emits."""
        return sorted({source.light_group for source in sources(self)})

    def lit_by(self, group: str) -> "Scene":
        """This scene with only the light of light group ``group`` ("" the ungrouped): the others' lamps with
        ``light_factor`` 0 (kept in place, so that every lamp keeps its shadow rays' seed and its chance of being
        sampled), their emission and the world's dark. Light is linear in emission, so the light of the groups
        sums to the scene's."""
        lit = copy.copy(self)
        lit.light_factor = np.where([light.light_group == group for light in self.lights], self.light_factor, 0.0)
        lit.materials = [material if material.light_group == group else
                         replace(material, emitted_radiance=(0.0, 0.0, 0.0)) for material in self.materials]
        lit.world = self.world if self.world.light_group == group else World()
        return lit

    @property
    def size_m(self) -> float:
        """Diagonal of the scene's bounding box in metres (sets ray offsets)."""
        points = self.triangles.reshape(-1, 3)
        return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


LAMP, MATERIAL, WORLD = "lamp", "material", "world"


@dataclass(frozen=True)
class Source:
    """One source of light: its kind (LAMP, MATERIAL or WORLD), name (a lamp's or material's), emission (3,) per
    channel (W, W m^-2 or W m^-2 sr^-1 by kind, times colour) and light group."""

    kind: str
    name: str
    emission: tuple[float, float, float]
    light_group: str

    @property
    def key(self) -> str:
        """The source's name among all kinds (its light group in core.relight.by_source's scene)."""
        return source_key(self.kind, self.name)


def sources(scene: Scene) -> list[Source]:
    """The scene's sources of light: lamps that are on, emissive materials in use, the world if it is bright."""
    found = []
    for light, factor in zip(scene.lights, scene.light_factor):
        emission = tuple(float(getattr(light, power_field(light)) * factor * c) for c in light.color)
        if max(emission) > 0:
            found.append(Source(LAMP, light.name, emission, light.light_group))
    for index in np.unique(scene.material_index):
        material = scene.materials[index]
        if max(material.emitted_radiance) > 0:
            found.append(Source(MATERIAL, material_name(scene, index), tuple(map(float, material.emitted_radiance)),
                                material.light_group))
    if max(scene.world.radiance) > 0:
        found.append(Source(WORLD, WORLD, tuple(map(float, scene.world.radiance)), scene.world.light_group))
    return found


def source_key(kind: str, name: str) -> str:
    """A source's name among all kinds: "lamp:<name>", "material:<name>", "world:world"."""
    return f"{kind}:{name}"


def material_name(scene: Scene, index: int) -> str:
    """A material's name, told apart from the same material emitting in another light group."""
    material = scene.materials[index]
    return f"{material.name} [{material.light_group}]" if material.light_group else material.name


def _per_triangle(values, name: str, shape: tuple[int, ...], dtype) -> np.ndarray:
    """``values`` as a (T, *shape) array; SceneError if they are not numbers or do not make whole triangles."""
    try:
        array = np.asarray(values, dtype=dtype)
    except (TypeError, ValueError) as error:
        raise SceneError(f"{name} must be an array of numbers ({error}).") from None
    if array.size % int(np.prod(shape)):
        raise SceneError(f"{name} must have shape (T, {', '.join(map(str, shape))}), got {array.shape}.")
    return array.reshape(-1, *shape)


def _unit_corner_normals(triangles: np.ndarray, corner_normals) -> np.ndarray:
    """(T, 3, 3) unit corner normals; the triangle's normal for corners without a usable one."""
    flat = np.repeat(triangle_unit_normals(triangles)[:, None, :], 3, axis=1)
    if corner_normals is None:
        return flat
    normals = np.asarray(corner_normals, dtype=np.float64)
    if normals.shape != flat.shape:
        raise SceneError(f"corner_normals has shape {normals.shape} for {len(triangles)} triangles.")
    with np.errstate(invalid="ignore", over="ignore"):
        length = lengths(normals)[..., None]
        usable = np.isfinite(length) & (length > 1e-12)
        return np.where(usable, normals / np.where(usable, length, 1.0), flat)


def _validate(scene: Scene) -> None:
    count = len(scene.triangles)
    if count == 0:
        raise SceneError("The scene is empty: no triangles to bake.")
    for name, array in (("material_index", scene.material_index), ("object_index", scene.object_index),
                        ("casts_only", scene.casts_only), ("triangle_uv", scene.triangle_uv),
                        ("terminator_offset", scene.terminator_offset)):
        if len(array) != count:
            raise SceneError(f"{name} has {len(array)} entries for {count} triangles.")
    offset = scene.terminator_offset
    wrong = ~(np.isfinite(offset) & (offset >= 0) & (offset <= 1))
    if wrong.any():
        index = int(np.flatnonzero(wrong)[0])
        raise SceneError(f"Object '{_object_name(scene, index)}': Shadow Terminator Geometry Offset must be in "
                         f"[0, 1], got {offset[index]}.")
    bad = ~np.isfinite(scene.triangles).all(axis=(1, 2))
    if bad.any():
        raise SceneError(f"Object '{_object_name(scene, int(np.flatnonzero(bad)[0]))}' has NaN or infinite "
                         f"vertex coordinates ({int(bad.sum())} triangles).")
    wrong = (scene.material_index < 0) | (scene.material_index >= len(scene.materials))
    if wrong.any():
        index = int(np.flatnonzero(wrong)[0])
        raise SceneError(f"Object '{_object_name(scene, index)}': a triangle refers to material "
                         f"{int(scene.material_index[index])} but the scene has materials 0 to "
                         f"{len(scene.materials) - 1}.")
    for material in scene.materials:
        _check_material(material)
    for light in scene.lights:
        _check_light(light)
    factor = scene.light_factor
    if factor.shape != (len(scene.lights),) or not (np.isfinite(factor) & (factor >= 0)).all():
        raise SceneError(f"light_factor must be {len(scene.lights)} finite numbers >= 0, one per light.")
    _check_rgb(scene.world.radiance, "World background", "radiance", upper=MAX_EMISSION)
    has_emitter = any(max(scene.materials[m].emitted_radiance) > 0 for m in np.unique(scene.material_index))
    has_light = any(_light_power(light) * factor > 0 for light, factor in zip(scene.lights, scene.light_factor)) \
        or max(scene.world.radiance) > 0
    if not (has_emitter or has_light):
        raise SceneError("The scene has no light: add a lamp, an emissive material or a world background.")


def _object_name(scene: Scene, triangle: int) -> str:
    return scene.object_names[int(scene.object_index[triangle])]


def _check_rgb(values, owner: str, quantity: str, upper: float | None) -> None:
    values = np.asarray(values, dtype=np.float64)
    shown = f"({', '.join(f'{v:g}' for v in values.ravel())})"
    if values.shape != (3,) or not np.isfinite(values).all():
        raise SceneError(f"{owner}: {quantity} must be three finite numbers, got {shown}.")
    if (values < 0).any():
        raise SceneError(f"{owner}: {quantity} must not be negative, got {shown}.")
    if upper is not None and (values > upper).any():
        reason = "a surface cannot reflect more light than it receives" if upper == 1.0 else "unbounded emission"
        raise SceneError(f"{owner}: {quantity} {shown} must not exceed {upper:g} ({reason}).")


def _check_material(material: Material) -> None:
    _check_rgb(material.reflectance, f"Material '{material.name}'", "reflectance", upper=1.0)
    if material.texture is not None:
        pixels = material.texture.pixels[..., :3]
        if not np.isfinite(pixels).all() or pixels.min() < 0 or pixels.max() > 1.0:
            raise SceneError(f"Material '{material.name}': its base colour texture has values outside [0, 1] "
                             f"(from {pixels.min():.3g} to {pixels.max():.3g}); a surface cannot reflect more light "
                             "than it receives.")
    _check_rgb(material.emitted_radiance, f"Material '{material.name}'", "emitted radiance", upper=MAX_EMISSION)


def power_field(light) -> str:
    """The field that holds a lamp's strength: a sun's irradiance (W m^-2), the others' power (W)."""
    return "strength_w_m2" if isinstance(light, SunLight) else "power_w"


def _light_power(light) -> float:
    return getattr(light, power_field(light)) * max(light.color)


def _check_light(light) -> None:
    owner = f"Light '{light.name}'"
    _check_rgb(light.color, owner, "colour", upper=None)
    power = getattr(light, power_field(light))
    if not (np.isfinite(power) and 0 <= power * max(light.color) <= MAX_EMISSION):
        raise SceneError(f"{owner}: power / strength x colour must be a finite number from 0 to {MAX_EMISSION:g}, "
                         f"got {float(power):g}.")
    vectors = [getattr(light, name) for name in ("position", "direction") if hasattr(light, name)]
    if not all(np.isfinite(np.asarray(v, dtype=np.float64)).all() for v in vectors):
        raise SceneError(f"{owner}: position and direction must be finite.")
    if hasattr(light, "direction") and np.linalg.norm(light.direction) == 0:
        raise SceneError(f"{owner}: direction must not be the zero vector.")
    if isinstance(light, AreaLight):
        if light.shape not in AREA_SHAPES:
            raise SceneError(f"{owner}: shape must be one of {AREA_SHAPES}, got '{light.shape}'.")
        sizes = [light.size_m] + ([light.size_y_m] if light.size_y_m is not None else [])
        if any(not np.isfinite(s) or s <= 0 for s in sizes):
            raise SceneError(f"{owner}: size must be positive, got {', '.join(f'{float(s):g}' for s in sizes)}.")
    if isinstance(light, SpotLight) and not (0 < light.spot_size_rad <= np.pi and 0 <= light.spot_blend <= 1):
        raise SceneError(f"{owner}: spot size must be in (0, pi] and blend in [0, 1].")
