"""Relighting from a basis by source (core.relight): weights are emission now over emission baked, per channel; a
relit bake equals a bake of the relit scene; what changes the transport is named."""
from dataclasses import replace

import numpy as np
import pytest

from core import SceneError, World, bake
from core.bake import bake_light_groups
from core.relight import TransportKey, by_source, mix, weights
from core.scene import sources
from test_light_groups import GLOW, KEY, LAMPS, SETTINGS, room


def test_a_basis_by_source_relights_to_a_bake_of_the_relit_scene():
    """The room's basis (two lamps, the key lamp, the glowing panel, the sky) mixed at weight 1 gives back the
    whole bake within 0.2% on the mean over the elements (the solves' 0.1% residual). Mixed for the key lamp off,
    one lamp orange and the sky halved, it equals a bake of that scene within 1.5% (that bake refines its links and
    balances its energy for its own light, as the lamps-alone test of test_light_groups measures; on the outputs,
    where direct light is traced per texel and corner, the add-on's test holds them to 0.1%)."""
    scene = room(LAMPS + [KEY])
    whole = bake(scene, SETTINGS)
    basis = {key: part.element_light() for key, part in
             bake_light_groups(whole, SETTINGS, grouped=by_source(scene)).items()}
    baked = sources(scene)
    assert sorted(basis) == sorted(source.key for source in baked)
    ones = weights(baked, baked)
    assert np.abs(mix(basis, ones, list(basis)) - whole.element_light()).sum() < 0.002 * whole.element_light().sum()
    edited = room([LAMPS[0], replace(LAMPS[1], color=(1.0, 0.5, 0.2)), replace(KEY, power_w=0.0)],
                  world=World((0.15, 0.2, 0.25), light_group="sky"))
    relit = mix(basis, weights(baked, sources(edited)), list(basis))
    again = bake(edited, SETTINGS).element_light()
    assert np.abs(relit - again).sum() < 0.015 * again.sum()


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
