"""Direct irradiance (W m^-2) from the analytic lights and the world, with shadow rays.

Closed forms (unoccluded), each multiplied by the visible share found with stratified shadow rays:
- point / spot: E = I cos(theta) / r^2 with I = P / (4 pi) (Blender's convention; spot x cone mask);
  with Blender's soft falloff a light of radius R gives I cos(theta) / (r^2 + R^2) (measured against Cycles);
- sun: E = S cos(theta);
- area: E = pi L F(point -> light polygon), L = P / (pi A), F by Lambert's contour formula;
- world: E = pi L_world x (share of cosine-weighted directions that escape the scene).
"""
from __future__ import annotations

import numpy as np

from .formfactor import point_to_polygon, visible_fraction
from .geometry import lengths, tangent_frames
from .raycast import RayCaster
from .sampling import concentric_disk, cosine_hemisphere, stratified_square
from .scene import AreaLight, PointLight, Scene, SpotLight, SunLight

DISK_POLYGON_SIDES = 64
UNIFORM_CHOICE = 0.1  # of one_light_irradiance's light choices, made uniformly


def direct_irradiance(scene: Scene, caster: RayCaster, points: np.ndarray, normals: np.ndarray,
                      offset_m: float, samples_per_edge: int, seed: int, lift=None, world: bool = True,
                      lights=None) -> np.ndarray:
    """(m, 3) irradiance at points with unit normals from every light of the scene (or those whose indices
    ``lights`` lists, each with the same rays as among all) and (unless ``world`` is False, for points whose
    final gather sees the world) its world. ``lift``
    (core.terminator.ShadowLift, optional) starts the lights' grazing shadow rays from smooth-shaded points on
    their smooth surface, as Cycles does; the world's rays, which Cycles mostly traces as BSDF samples, start from
    the points."""
    irradiance = np.zeros((len(points), 3))
    for index in range(len(scene.lights)) if lights is None else lights:
        light, factor = scene.lights[index], scene.light_factor[index]
        if factor == 0:
            continue
        sampler = _SAMPLERS[type(light)]
        scalar = sampler(light, caster, points, normals, offset_m, samples_per_edge, seed + 7919 * index, lift)
        irradiance += scalar[:, None] * (factor * np.asarray(light.color, dtype=np.float64))
    if world:
        irradiance += _world(scene, caster, points, normals, offset_m, samples_per_edge, seed)
    return irradiance


def sampled_irradiance(scene: Scene, caster: RayCaster, points: np.ndarray, normals: np.ndarray, offset_m: float,
                       seed: int, world: bool = True, exact_lights: int = 0) -> np.ndarray:
    """(m, 3) an unbiased estimate of ``direct_irradiance`` with one shadow ray per point to each of its
    ``exact_lights`` brightest lights (by their unshadowed irradiance there) and one more to one of the others,
    chosen in proportion to that irradiance (a share UNIFORM_CHOICE of the choices uniform, so that no light that
    reaches a point is left out) and divided by the chance of that choice (light selection: Shirley, Wang &
    Zimmerman 1996; the brightest tested first, the rest estimated: Ward 1991, adaptive shadow testing). For
    final-gather hits: with ``exact_lights`` 0, where the 64 rays of a texel average the choices out, a scene's
    many lamps cost one shadow ray, not one each; a scene with no more lamps than ``exact_lights`` is sampled
    with no choice at all. The ranking and the choice ignore the scene's ``light_factor``, which scales what a
    light brings: the samples of a light group's scene (core.scene.Scene.lit_by) are the whole scene's, each
    landing in its light's group."""
    irradiance = np.zeros((len(points), 3))
    lights = scene.lights
    if lights and len(points):
        colours = np.array([light.color for light in lights], dtype=np.float64)
        unshadowed = np.stack([_SAMPLERS[type(light)](light, None, points, normals, offset_m, 1, seed, None)
                               for light in lights], axis=1) * colours.sum(axis=1)
        exact = np.zeros(unshadowed.shape, dtype=bool)
        if exact_lights > 0:
            brightest = np.argsort(-unshadowed, axis=1, kind="stable")[:, :exact_lights]
            np.put_along_axis(exact, brightest, True, axis=1)
        pick, chance = _choose(unshadowed, exact, np.random.default_rng(seed).random(len(points)))
        picked = np.zeros(exact.shape)
        picked[np.arange(len(points)), pick] = np.where(exact.all(axis=1), 0.0, 1.0) / np.maximum(chance, 1e-300)
        scale = np.where(exact, 1.0, picked)  # each light's weight per point: 1 tested, 1/chance chosen, else 0
        for index, (light, factor) in enumerate(zip(lights, scene.light_factor)):
            rows = np.flatnonzero(scale[:, index] > 0)
            if factor == 0 or len(rows) == 0:
                continue
            scalar = _SAMPLERS[type(light)](light, caster, points[rows], normals[rows], offset_m, 1,
                                            seed + 7919 * index, None)
            irradiance[rows] += (scalar * scale[rows, index])[:, None] * (factor * colours[index])
    if world:
        irradiance += _world(scene, caster, points, normals, offset_m, 1, seed)
    return irradiance


def _choose(unshadowed: np.ndarray, exact: np.ndarray, draw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(m,) the light chosen at each point among those not ``exact`` by its (m,) uniform ``draw``, and the chance
    of that choice: a share UNIFORM_CHOICE of the draws picks uniformly among them, the rest in proportion to
    ``unshadowed`` (uniformly where that is 0 for all of them). Inverting the cumulative weights of each row
    (one cumulative sum, no per-light table of chances)."""
    weight = np.where(exact, 0.0, unshadowed)
    open_so_far = np.cumsum(~exact, axis=1)
    cumulative = np.cumsum(weight, axis=1)
    count, total = open_so_far[:, -1], cumulative[:, -1]
    by_chance = draw < UNIFORM_CHOICE
    uniform = by_chance | (total <= 0)
    rescaled = np.where(by_chance, draw / UNIFORM_CHOICE, (draw - UNIFORM_CHOICE) / (1.0 - UNIFORM_CHOICE))
    pick = np.where(uniform, (np.floor(rescaled * count)[:, None] >= open_so_far).sum(axis=1),
                    ((rescaled * total)[:, None] >= cumulative).sum(axis=1))
    pick = np.minimum(pick, unshadowed.shape[1] - 1)
    share = np.where(total > 0, weight[np.arange(len(draw)), pick] / np.maximum(total, 1e-300),
                     1.0 / np.maximum(count, 1))
    return pick, UNIFORM_CHOICE / np.maximum(count, 1) + (1.0 - UNIFORM_CHOICE) * share


def _world(scene: Scene, caster, points, normals, offset_m, samples_per_edge, seed) -> np.ndarray:
    """(m, 3) irradiance from the world: pi L_world x the share of directions that escape."""
    radiance = np.asarray(scene.world.radiance, dtype=np.float64)
    if radiance.max() <= 0:
        return np.zeros((len(points), 3))
    escaped = _world_escape_share(caster, points, normals, offset_m, samples_per_edge,
                                  seed + 7919 * len(scene.lights))
    return np.pi * escaped[:, None] * radiance


def spot_mask(cos_to_axis: np.ndarray, spot_size_rad: float, spot_blend: float) -> np.ndarray:
    """Cycles' spot cone (Blender 4.x): smoothstep(0, 1, (cos a - cos(size/2)) / ((1 - cos(size/2)) blend))."""
    cos_half = np.cos(spot_size_rad / 2.0)
    if spot_blend <= 0:
        return (cos_to_axis > cos_half).astype(np.float64)
    t = np.clip((cos_to_axis - cos_half) / ((1.0 - cos_half) * spot_blend), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def area_light_polygon(light: AreaLight) -> np.ndarray:
    """(V, 3) world-space outline of an area light; disks and ellipses as area-preserving polygons."""
    frame = _light_frame(light)
    half_x = light.size_m / 2.0
    half_y = (light.size_y_m if light.shape in ("RECTANGLE", "ELLIPSE") and light.size_y_m else light.size_m) / 2.0
    if light.shape in ("SQUARE", "RECTANGLE"):
        local = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=np.float64)
    else:
        angle = 2 * np.pi * np.arange(DISK_POLYGON_SIDES) / DISK_POLYGON_SIDES
        inscribed_area = 0.5 * DISK_POLYGON_SIDES * np.sin(2 * np.pi / DISK_POLYGON_SIDES)
        local = np.sqrt(np.pi / inscribed_area) * np.stack([np.cos(angle), np.sin(angle)], -1)
    local = local * [half_x, half_y]
    return np.asarray(light.position, dtype=np.float64) + local[:, :1] * frame[0] + local[:, 1:] * frame[1]


def area_light_area_m2(light: AreaLight) -> float:
    width = light.size_m
    height = light.size_y_m if light.shape in ("RECTANGLE", "ELLIPSE") and light.size_y_m else light.size_m
    return width * height * (np.pi / 4 if light.shape in ("DISK", "ELLIPSE") else 1.0)


def _light_frame(light) -> np.ndarray:
    """Rows: light X axis, Y axis, emission direction (all unit)."""
    direction = np.asarray(light.direction, dtype=np.float64)
    direction = direction / np.linalg.norm(direction)
    frame = tangent_frames(direction[None])[0]
    if getattr(light, "axis_x", None) is not None:
        x = np.asarray(light.axis_x, dtype=np.float64)
        x = x - direction * (x @ direction)
        x /= np.linalg.norm(x)
        frame = np.stack([x, np.cross(direction, x), direction])
    return frame


def _point_like(light, caster, points, normals, offset_m, samples_per_edge, seed, lift):
    """Point and spot lights; a radius spreads the shadow-ray targets over a disk facing each receiver."""
    to_light = np.asarray(light.position, dtype=np.float64) - points
    distance = lengths(to_light)
    direction = to_light / np.maximum(distance, 1e-300)[:, None]
    cosine = np.maximum(np.einsum("mk,mk->m", direction, normals), 0.0)
    squared = distance ** 2 + (light.radius_m ** 2 if light.soft_falloff else 0.0)
    irradiance = light.power_w / (4 * np.pi) * cosine / np.maximum(squared, 1e-300)
    if isinstance(light, SpotLight):
        axis = np.asarray(light.direction, dtype=np.float64) / np.linalg.norm(light.direction)
        irradiance *= spot_mask(-direction @ axis, light.spot_size_rad, light.spot_blend)
    lit = np.flatnonzero(irradiance > 0)
    if caster is None or len(lit) == 0:  # unshadowed, or nothing faces the light: no shadow rays to cast
        return irradiance
    if light.radius_m > 0:
        disk = concentric_disk(stratified_square(len(lit), samples_per_edge, seed)) * light.radius_m
        frame = tangent_frames(-direction[lit])
        targets = light.position + np.einsum("msi,mik->msk", disk, frame[:, :2])
    else:
        targets = np.broadcast_to(np.asarray(light.position, dtype=np.float64), (len(lit), 1, 3))
    irradiance[lit] *= visible_fraction(caster, points[lit], normals[lit], targets, -direction[lit], offset_m, 0.0,
                                        _rows(lift, lit))
    return irradiance


def _sun(light: SunLight, caster, points, normals, offset_m, samples_per_edge, seed, lift):
    """Sun: S cos(theta) times the share of a cone of the sun's angular diameter that is unoccluded."""
    to_sun = -np.asarray(light.direction, dtype=np.float64) / np.linalg.norm(light.direction)
    irradiance = light.strength_w_m2 * np.maximum(normals @ to_sun, 0.0)
    lit = np.flatnonzero(irradiance > 0)
    if caster is None or len(lit) == 0:  # unshadowed, or nothing faces the light: no shadow rays to cast
        return irradiance
    count = samples_per_edge if light.angle_rad > 0 else 1
    disk = concentric_disk(stratified_square(len(lit), count, seed)) * np.tan(light.angle_rad / 2.0)
    frame = tangent_frames(to_sun[None])[0]
    directions = to_sun + disk @ frame[:2]
    directions /= lengths(directions)[..., None]
    origins = np.broadcast_to((points[lit] + offset_m * normals[lit])[:, None, :], directions.shape)
    if lift is not None:
        origins = lift[lit].origins(origins, directions)
    rays = directions.size // 3
    blocked = caster.occluded(origins.reshape(-1, 3), directions.reshape(-1, 3), np.full(rays, np.inf))
    irradiance[lit] *= 1.0 - blocked.reshape(len(lit), -1).mean(axis=1)
    return irradiance


def _area(light: AreaLight, caster, points, normals, offset_m, samples_per_edge, seed, lift):
    """Area light: pi L F(point -> polygon), lit only on the emitting side, times the visible share."""
    polygon = area_light_polygon(light)
    direction = _light_frame(light)[2]
    radiance = light.power_w / (np.pi * area_light_area_m2(light))
    in_front = (points - np.asarray(light.position)) @ direction > 0
    irradiance = np.zeros(len(points))
    front = np.flatnonzero(in_front)
    irradiance[front] = np.pi * radiance * point_to_polygon(
        points[front], normals[front], np.broadcast_to(polygon, (len(front),) + polygon.shape).copy())
    lit = np.flatnonzero(irradiance > 0)
    if caster is None or len(lit) == 0:  # unshadowed, or nothing faces the light: no shadow rays to cast
        return irradiance
    unit = stratified_square(len(lit), samples_per_edge, seed)
    if light.shape in ("DISK", "ELLIPSE"):
        unit = 0.5 * (concentric_disk(unit) + 1.0)
    frame = _light_frame(light)
    width = light.size_m
    height = light.size_y_m if light.shape in ("RECTANGLE", "ELLIPSE") and light.size_y_m else light.size_m
    offsets = (unit - 0.5) * [width, height]
    targets = np.asarray(light.position) + offsets[..., :1] * frame[0] + offsets[..., 1:] * frame[1]
    light_normals = np.broadcast_to(direction, (len(lit), 3))
    irradiance[lit] *= visible_fraction(caster, points[lit], normals[lit], targets, light_normals, offset_m, 0.0,
                                        _rows(lift, lit))
    return irradiance


def _world_escape_share(caster, points, normals, offset_m, samples_per_edge, seed):
    """Share of cosine-weighted directions from each point that hit nothing (stratified, seeded)."""
    if len(points) == 0:
        return np.zeros(0)
    local = cosine_hemisphere(stratified_square(len(points), samples_per_edge, seed))
    directions = np.einsum("msi,mik->msk", local, tangent_frames(normals))
    origins = np.repeat(points + offset_m * normals, directions.shape[1], axis=0)
    blocked = caster.occluded(origins, directions.reshape(-1, 3), np.full(len(origins), np.inf))
    return 1.0 - blocked.reshape(len(points), -1).mean(axis=1)


def _rows(lift, rows):
    return None if lift is None else lift[rows]


_SAMPLERS = {PointLight: _point_like, SpotLight: _point_like, SunLight: _sun, AreaLight: _area}
