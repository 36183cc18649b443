"""Light groups: light is linear in emission (radiosity paper, section 4: B = (I - rho F)^-1 E), so twice the light
bakes exactly twice, and the light of the groups, each solved on the whole scene's elements and links, sums to the
whole scene's bake."""
from dataclasses import replace

import numpy as np
import pytest

import core.gather
from core import BakeSettings, Material, PointLight, Scene, World, bake
from core.atlas import AtlasSize, layout_atlas
from core.bake import bake_light_groups
from core.lightmap import LightmapSettings, bake_lightmap
from shapes import box_faces, quad

SETTINGS = BakeSettings(element_size_m=0.25, patch_size_m=0.5, residual_threshold=0.001)
LAMPS = [PointLight("lamp", (0.5, 0.5, 2.0), 200.0, (1.0, 0.8, 0.6), light_group="lamps"),
         PointLight("lamp 2", (3.5, 2.5, 1.5), 100.0, light_group="lamps")]
KEY = PointLight("key", (3.0, 0.5, 1.0), 150.0, (0.6, 0.7, 1.0))
WALL = Material("wall", (0.7, 0.6, 0.5))
GLOW = Material("glow", (0.8, 0.8, 0.8), (3.0, 3.0, 2.0), light_group="neon")
GLOW_OFF = replace(GLOW, emitted_radiance=(0.0, 0.0, 0.0))


def room_parts() -> list[np.ndarray]:
    """A 4 x 3 x 2.5 m room open on its +y side (the sky comes in), a block on its floor and a glowing ceiling
    panel (the last part)."""
    walls = box_faces((0, 0, 0), (4, 3, 2.5))
    panel = quad((1.5, 1, 2.49), (1.5, 2, 2.49), (2.5, 2, 2.49), (2.5, 1, 2.49))[:, ::-1]
    return walls[:3] + walls[4:] + box_faces((1, 1, 0), (1.6, 1.6, 0.8), inward=False) + [panel]


def room(lights, glow: Material = GLOW, world: World = World((0.3, 0.4, 0.5), light_group="sky")) -> Scene:
    triangles = np.concatenate(room_parts())
    material = np.r_[np.zeros(len(triangles) - 2, int), [1, 1]]
    return Scene(triangles, material, [WALL, glow], lights, world)


def lightmap(solution, groups=None, indirect="interpolate"):
    parts = room_parts()
    layout = layout_atlas([(p.reshape(-1, 3), np.arange(3 * len(p)).reshape(-1, 3)) for p in parts],
                          list(range(len(parts))), AtlasSize(16.0, 0, 2, 4096))
    return bake_lightmap(solution, np.arange(len(solution.scene.triangles)), np.concatenate(layout.corner_uv),
                         layout.width, layout.height, LightmapSettings(indirect=indirect, gather_samples_per_edge=4),
                         groups=groups)


def test_the_scene_lists_the_groups_that_emit():
    """Lamps, emissive materials and the world name their groups; "" is the ungrouped light (the key lamp); a
    group whose lamps are all off emits nothing and is left out."""
    assert room(LAMPS + [KEY]).light_groups == ["", "lamps", "neon", "sky"]
    dark = [replace(lamp, power_w=0.0) for lamp in LAMPS]
    assert room(dark + [KEY], world=World()).light_groups == ["", "neon"]


def test_twice_the_light_bakes_exactly_twice():
    """Every lamp, emitter and the sky at twice their power: the elements and the lightmap hold exactly twice the
    light (the same rays; linearity up to round-off, 1e-9)."""
    once = bake(room(LAMPS + [KEY]), SETTINGS)
    twice = bake(room([replace(light, power_w=2 * light.power_w) for light in LAMPS + [KEY]],
                      replace(GLOW, emitted_radiance=(6.0, 6.0, 4.0)), World((0.6, 0.8, 1.0))), SETTINGS)
    assert twice.element_light() == pytest.approx(2 * once.element_light(), rel=1e-9, abs=1e-12)
    page_once, page_twice = lightmap(once), lightmap(twice)
    assert page_twice.light[page_twice.covered] == pytest.approx(2 * page_once.light[page_once.covered], rel=1e-5)


@pytest.mark.parametrize("indirect, receiver_gather", [("interpolate", False), ("gather", False), ("gather", True)])
def test_light_groups_sum_to_the_whole_bake(monkeypatch, indirect, receiver_gather):
    """The groups' element light and lightmap sum to the whole scene's bake within 0.2% (the issue asks 0.5%;
    what is left is the solves' unfinished residual, 0.1% of the injected power, since the gather's rays, its
    choice of lamps and its denoiser's weights are the whole bake's: measured 0.05% and 0.03%), also with the
    elements' light solved again by rays (core.gather.gather_at_receivers, along the same rays for every group);
    the page's light is the sum of its groups' pages."""
    monkeypatch.setattr(core.gather, "GATHER_BELOW_ELEMENTS", np.inf)  # outputs gather here, so the elements do
    settings = replace(SETTINGS, receiver_gather=receiver_gather)
    scene = room(LAMPS + [KEY])
    whole = bake(scene, settings)
    assert whole.counts.get("receiver_gather", False) == receiver_gather
    groups = bake_light_groups(whole, settings)
    assert list(groups) == ["", "lamps", "neon", "sky"]
    total = sum(group.element_light() for group in groups.values())
    assert np.abs(total - whole.element_light()).sum() < 0.002 * whole.element_light().sum()
    page, by_group = lightmap(whole, indirect=indirect), lightmap(whole, groups, indirect)
    covered = page.covered
    assert np.abs(by_group.light - page.light)[covered].sum() < 0.002 * page.light[covered].sum()
    assert sorted(by_group.groups) == sorted(groups)
    assert np.array_equal(by_group.light, sum(by_group.groups.values()))


def test_a_group_holds_the_light_of_its_lamps_alone():
    """The lamps' group of the whole room equals a bake of the room lit by those lamps alone (its own elements'
    refinement and energy balance) within 1.5% on the mean; the sky's group, through the open side, is light."""
    whole = bake(room(LAMPS + [KEY]), SETTINGS)
    groups = bake_light_groups(whole, SETTINGS)
    alone = bake(room(LAMPS, replace(GLOW, emitted_radiance=(0.0, 0.0, 0.0)), World()), SETTINGS).element_light()
    lamps = groups["lamps"].element_light()
    assert np.abs(lamps - alone).sum() < 0.015 * alone.sum()
    sky = groups["sky"].element_light()
    assert sky.min() >= 0 and sky.sum() > 0


def test_a_group_solves_as_long_as_the_whole():
    """The room lit by its sky alone, solved to a loose 5% residual: its one group equals the whole bake within
    0.1% on the mean over the elements. The group's solve had stopped an iteration before the whole's (a rough
    solve, then refined links), and with it the ambient term (the unfinished iterations' light, measured from the
    last two): 1.0% off here, 29% on the room sample, whose sky falls mostly outside it."""
    scene = room([], GLOW_OFF, World((0.3, 0.4, 0.5), light_group="sky"))
    settings = replace(SETTINGS, residual_threshold=0.05)
    whole = bake(scene, settings)
    (group,) = bake_light_groups(whole, settings).values()
    assert len(group.state.history) >= len(whole.state.history)
    assert np.abs(group.element_light() - whole.element_light()).sum() < 0.001 * whole.element_light().sum()
