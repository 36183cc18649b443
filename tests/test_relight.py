"""Relighting from a basis by source (core.relight): weights are emission now over emission baked, per channel; a
relit bake equals a bake of the relit scene; what changes the transport is named."""
from dataclasses import replace

import numpy as np
import pytest

from core import SceneError, World, bake
from core.bake import bake_light_groups
from core.relight import TransportKey, basis, mix, weights
from core.scene import sources
from test_light_groups import GLOW, KEY, LAMPS, SETTINGS, room


def test_a_basis_relights_to_a_bake_of_the_relit_scene():
    """The room's basis (two lamps, the key lamp, off when baked, the glowing panel, the sky) mixed at the scene's
    own weights gives back the whole bake within 0.2% on the mean over the elements (the solves' 0.1% residual).
    Mixed for the key lamp on, one lamp orange and the sky halved, it equals a bake of that scene within 1.5% (that
    bake refines its links and balances its energy for its own light, as the lamps-alone test of test_light_groups
    measures; on the outputs, where direct light is traced per texel and corner, the add-on's test holds them to
    0.1%)."""
    scene = room(LAMPS + [replace(KEY, power_w=0.0)])
    whole = bake(scene, SETTINGS)
    split, baked = basis(scene)
    parts = {key: part.element_light() for key, part in bake_light_groups(whole, SETTINGS, grouped=split).items()}
    assert sorted(parts) == sorted(source.key for source in baked)
    mixed = mix(parts, weights(baked, sources(scene)), list(parts))
    assert np.abs(mixed - whole.element_light()).sum() < 0.002 * whole.element_light().sum()
    edited = room([LAMPS[0], replace(LAMPS[1], color=(1.0, 0.5, 0.2)), KEY],
                  world=World((0.15, 0.2, 0.25), light_group="sky"))
    relit = mix(parts, weights(baked, sources(edited)), list(parts))
    again = bake(edited, SETTINGS).element_light()
    assert np.abs(relit - again).sum() < 0.015 * again.sum()


def test_the_basis_lights_every_channel_of_every_lamp_and_the_world():
    """A red lamp is baked white at its power, a lamp that is off as the brightest lamp that is on (200 W x its
    brightest channel 1.0), a dark world at radiance 1, the panel's emission as it is: the scene's own weights are
    then its red channel alone, 0 for the lamp that is off and the world. Lamps keep their light groups."""
    scene = room([replace(LAMPS[0], color=(1.0, 0.0, 0.0)), LAMPS[1], replace(KEY, power_w=0.0)], world=World())
    split, baked = basis(scene)
    emission = {source.key: source.emission for source in baked}
    assert emission["lamp:lamp"] == pytest.approx((200.0,) * 3)
    assert emission["lamp:key"] == pytest.approx((200.0,) * 3)
    assert emission["world:world"] == pytest.approx((1.0,) * 3)
    assert emission["material:glow [neon]"] == pytest.approx(GLOW.emitted_radiance)
    assert {source.key: source.light_group for source in baked}["lamp:lamp"] == "lamps"
    assert sorted(split.light_groups) == sorted(emission)
    weight = weights(baked, sources(scene))
    assert weight["lamp:lamp"] == pytest.approx([1.0, 0.0, 0.0])
    assert weight["lamp:key"] == pytest.approx([0.0] * 3)
    assert weight["world:world"] == pytest.approx([0.0] * 3)


def test_weights_are_emission_ratios_and_refuse_what_the_basis_cannot_hold():
    """Twice a lamp's power is weight 2, half the panel's radiance 0.5; a channel baked dark cannot be raised, and a
    lamp the basis does not have cannot be added: both refused, naming the lamp."""
    baked = sources(room(LAMPS + [KEY]))
    brighter = sources(room([replace(LAMPS[0], power_w=400.0)] + LAMPS[1:] + [KEY],
                            replace(GLOW, emitted_radiance=(1.5, 1.5, 1.0))))
    weight = weights(baked, brighter)
    assert weight["lamp:lamp"] == pytest.approx([2.0] * 3)
    assert weight["material:glow [neon]"] == pytest.approx([0.5] * 3)
    assert weight["lamp:key"] == pytest.approx([1.0] * 3)
    dark = sources(room([replace(LAMPS[0], color=(1.0, 0.8, 0.0))] + LAMPS[1:] + [KEY]))
    with pytest.raises(SceneError, match="lamp 'lamp'"):
        weights(dark, baked)  # the blue channel was baked dark
    with pytest.raises(SceneError, match="lamp 'extra'"):
        weights(baked, sources(room(LAMPS + [KEY, replace(KEY, name="extra")])))


def test_the_transport_key_names_what_changed():
    """Power, colour and light group leave the key; a moved lamp, moved geometry, other settings or another
    reflectance are named."""
    scene = room(LAMPS + [KEY])
    key = TransportKey.of(scene, {"quality": "MEDIUM"})
    relit = room([replace(LAMPS[0], power_w=10.0, color=(1, 0, 0), light_group="other")] + LAMPS[1:])
    assert TransportKey.of(relit, {"quality": "MEDIUM"}).changes(key) == []
    moved = room([replace(LAMPS[0], position=(1.0, 1.0, 2.0))] + LAMPS[1:] + [KEY])
    assert TransportKey.of(moved, {"quality": "MEDIUM"}).changes(key) == ["lamp 'lamp' (moved or reshaped)"]
    shifted = room(LAMPS + [KEY])
    shifted.triangles = shifted.triangles + [0.0, 0.0, 0.01]
    assert "geometry" in TransportKey.of(shifted, {"quality": "MEDIUM"}).changes(key)[0]
    assert TransportKey.of(scene, {"quality": "HIGH"}).changes(key) == ["the bake settings"]
    painted = room(LAMPS + [KEY])
    painted.materials = [replace(painted.materials[0], reflectance=(0.5, 0.5, 0.5))] + painted.materials[1:]
    assert TransportKey.of(painted, {"quality": "MEDIUM"}).changes(key) == ["the reflectance of material 'wall'"]
