"""Relighting without re-tracing: light is linear in emission (radiosity paper, section 4: B = (I - rho F)^-1 E),
so a bake split by light source (each lamp, each emissive material, the world) is a basis. The same sources at
other strengths and colours, grouped in any way, light the scene as a weighted sum of the basis: no ray is cast and
nothing is solved again.

A source's weight is, per RGB channel, its emission now over its emission in the basis: a lamp's power (a sun's
strength) x colour, a material's emitted radiance, the world's radiance. The basis lights every channel of every
lamp and of the world, those that are off included (``basis``), so a relight may turn any of them on. A lamp added
since, or a material that did not emit when the basis was baked, holds no light to scale: it is refused, naming
it; so is anything that changes where light goes (``TransportKey``): geometry, materials' reflectance, lamps'
placement and shape, settings.
"""
from __future__ import annotations

import copy
import hashlib
from dataclasses import dataclass, replace

import numpy as np

from .errors import SceneError
from .scene import LAMP, MATERIAL, WORLD, Scene, Source, material_name, power_field, source_key, sources

# A lamp's fields that do not move its light (the rest, placement and shape, do).
LAMP_EMISSION_FIELDS = ("name", "power_w", "strength_w_m2", "color", "light_group")


def basis(scene: Scene) -> tuple[Scene, list[Source]]:
    """The scene a relighting basis is baked from (core.bake.bake_light_groups of it: one part per source, each
    in a light group of its own, named by ``Source.key``), and the sources of the basis, with their emission
    there and their light groups in ``scene``. Every lamp and the world light every channel in the basis, so that
    a relight may turn on or tint any of them: a channel that is dark takes the source's brightest channel, and a
    lamp that is off (its power or colour zero) emits as the brightest lamp of its kind that is on (its kind: suns
    in W m^-2, the others in W), or at 1 when none is; a dark world emits radiance 1 (W m^-2 sr^-1). Emissive
    materials keep what they emit, with their dark channels filled so."""
    filled = copy.copy(scene)
    filled.lights = [_lit(light, factor, scene) for light, factor in zip(scene.lights, scene.light_factor)]
    filled.light_factor = np.ones(len(scene.lights))
    filled.materials = [replace(material, emitted_radiance=_filled(material.emitted_radiance))
                        if max(material.emitted_radiance) > 0 else material for material in scene.materials]
    filled.world = replace(scene.world, radiance=_filled(scene.world.radiance) if max(scene.world.radiance) > 0
                           else (1.0, 1.0, 1.0))
    split = copy.copy(filled)
    split.lights = [replace(light, light_group=source_key(LAMP, light.name)) for light in filled.lights]
    split.materials = [replace(material, light_group=source_key(MATERIAL, material_name(filled, index)))
                       for index, material in enumerate(filled.materials)]
    split.world = replace(filled.world, light_group=source_key(WORLD, WORLD))
    return split, sources(filled)


def _lit(light, factor: float, scene: Scene):
    """``light`` emitting in every channel: its power x ``factor`` (the scene's light factor), its colour's dark
    channels filled, or, when it is off, as the brightest lamp of its kind in ``scene`` that is on (1 if none)."""
    field = power_field(light)
    power = getattr(light, field) * factor
    if power > 0 and max(light.color) > 0:
        return replace(light, **{field: power, "color": _filled(light.color)})
    powers = [getattr(other, field) * other_factor * max(other.color)
              for other, other_factor in zip(scene.lights, scene.light_factor) if power_field(other) == field]
    return replace(light, **{field: max(powers + [0.0]) or 1.0, "color": (1.0, 1.0, 1.0)})


def _filled(colour) -> tuple[float, float, float]:
    """A colour with its zero channels set to its brightest channel."""
    brightest = max(colour)
    return tuple(float(c) if c > 0 else float(brightest) for c in colour)


def weights(baked: list[Source], now: list[Source]) -> dict[str, np.ndarray]:
    """(3,) weight of each baked source (by ``Source.key``) for the sources ``now``: emission now over emission
    baked, per channel; 0 for a source that is off now. SceneError names a source that is new or brighter in a
    channel baked dark."""
    current = {source.key: source for source in now}
    new = [source for key, source in current.items() if key not in {s.key for s in baked}]
    if new:
        raise SceneError(f"The relighting cache has no light of {_named(new[0])}, which emits now and was not in "
                         "the scene (a material: did not emit) when the cache was baked: bake again.")
    out = {}
    for source in baked:
        emission = np.asarray(current[source.key].emission if source.key in current else (0.0,) * 3)
        before = np.asarray(source.emission)
        if ((before == 0) & (emission > 0)).any():
            raise SceneError(f"The relighting cache holds no light in a colour channel of {_named(source)} that it "
                             "was baked dark in (a colour with a zero channel): bake again.")
        out[source.key] = np.divide(emission, before, out=np.zeros(3), where=before > 0)
    return out


def _named(source: Source) -> str:
    return {LAMP: f"lamp '{source.name}'", MATERIAL: f"material '{source.name}'", WORLD: "the world"}[source.kind]


def mix(basis: dict[str, np.ndarray], weight: dict[str, np.ndarray], members: list[str]) -> np.ndarray:
    """The light of the sources ``members`` (keys; none: dark) at their weights: the sum of weight x basis, the
    weights (3,) applied to the last axis's RGB channels."""
    total = np.zeros_like(next(iter(basis.values())))
    for key in members:
        total += basis[key] * weight[key].astype(total.dtype)
    return total


@dataclass(frozen=True)
class TransportKey:
    """What a basis depends on besides emission, as digests: the geometry (triangles, what is solved, shading
    normals, texture UVs), the reflectance of every triangle and of each material by name, each lamp's placement
    and shape, and the settings. Lamps that are removed, or whose only change is emission or light group, keep
    the basis."""

    geometry: str
    reflectance: str
    materials: dict
    lamps: dict
    settings: str

    @classmethod
    def of(cls, scene: Scene, settings: dict) -> "TransportKey":
        geometry = _digest(scene.triangles, scene.casts_only, scene.corner_normals, scene.triangle_uv,
                           scene.terminator_offset)
        materials = {m.name: _digest(np.asarray(m.reflectance),
                                     m.texture.pixels if m.texture is not None else np.zeros(0))
                     for m in scene.materials}
        digests = sorted(set(materials.values()))
        code = np.array([digests.index(materials[m.name]) for m in scene.materials])[scene.material_index]
        reflectance = _digest(np.frombuffer(" ".join(digests).encode(), dtype=np.uint8), code)
        lamps = {light.name: repr(type(light).__name__) + repr(
            {k: v for k, v in vars(light).items() if k not in LAMP_EMISSION_FIELDS}) for light in scene.lights}
        return cls(geometry, reflectance, materials, lamps, repr(sorted(settings.items())))

    def changes(self, baked: "TransportKey") -> list[str]:
        """What differs from the ``baked`` key, in words (empty when the basis still holds)."""
        found = []
        if self.geometry != baked.geometry:
            found.append("the geometry (meshes, their placement, shading or what is baked)")
        changed = [name for name in sorted(set(self.materials) & set(baked.materials))
                   if self.materials[name] != baked.materials[name]]
        found += [f"the reflectance of material '{name}'" for name in changed]
        if self.reflectance != baked.reflectance and not changed:
            found.append("which materials the meshes have")
        found += [f"lamp '{name}' (moved or reshaped)" for name in sorted(set(self.lamps) & set(baked.lamps))
                  if self.lamps[name] != baked.lamps[name]]
        if self.settings != baked.settings:
            found.append("the bake settings")
        return found


def _digest(*arrays) -> str:
    hashed = hashlib.sha256()
    for array in arrays:
        array = np.ascontiguousarray(array)
        hashed.update(repr((array.dtype.str, array.shape)).encode())
        hashed.update(array.tobytes())
    return hashed.hexdigest()
