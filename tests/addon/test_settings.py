"""The one settings table (radiosity_addon/settings.py) is what the panel's properties, the command line and
UserSettings all show: the same names, defaults, bounds and choices, whatever the table holds."""
from dataclasses import replace

import bpy
import pytest


def test_every_default_lies_within_its_bounds_and_items(extension):
    from radiosity_baker.radiosity_addon.settings import SETTINGS, UserSettings
    for setting in SETTINGS:
        if setting.items:
            assert setting.default in [item[0] for item in setting.items], setting.name
        if setting.low is not None:
            assert setting.low <= setting.default <= setting.high, setting.name
    assert UserSettings() == UserSettings(**{setting.name: setting.default for setting in SETTINGS})


def test_the_panel_properties_are_the_table(empty_scene):
    from radiosity_baker.radiosity_addon.settings import SETTINGS, UserSettings
    properties = bpy.types.Scene.bl_rna.properties["radiosity"].fixed_type.properties
    for setting in SETTINGS:
        prop = properties[setting.name]
        assert prop.name == setting.label and prop.description == setting.help, setting.name
        if setting.items:
            assert [item.identifier for item in prop.enum_items] == [item[0] for item in setting.items]
        elif setting.kind in (int, float):
            assert (prop.hard_min, prop.hard_max) == pytest.approx((setting.low, setting.high)), setting.name
        if setting.kind is float:
            assert prop.default == pytest.approx(setting.default), setting.name
        elif not setting.items:
            assert prop.default == setting.default, setting.name
    from_panel, defaults = vars(empty_scene.radiosity.user_settings()), vars(UserSettings())
    for name, value in defaults.items():  # Blender keeps float properties as 32-bit floats
        assert from_panel[name] == (pytest.approx(value, rel=1e-7) if isinstance(value, float) else value), name


def test_the_command_line_options_are_the_table(extension):
    """One option per setting of the table (and --no-X to switch a switch back off); the options given replace
    the input file's saved settings, which replace the table's defaults."""
    from radiosity_baker.radiosity_addon.cli import build_parser, user_settings
    from radiosity_baker.radiosity_addon.settings import SETTINGS, UserSettings
    parser = build_parser("test")
    assert user_settings(parser.parse_args(["in.blend", "-o", "out.blend"])) == UserSettings()
    flags = {}
    for action in parser._actions:
        flags.setdefault(action.dest, []).extend(action.option_strings)
    for setting in SETTINGS:
        switch_back = [f"--no-{setting.flag[2:]}"] if setting.kind is bool else []
        assert flags[setting.name] == [setting.flag, *switch_back], setting.name
    given = user_settings(parser.parse_args(["in.blend", "-o", "out.blend", "--target", "both", "--float",
                                             "--png-exposure", "-1.5", "--resolution", "512", "--indirect",
                                             "gather", "--quality", "custom"]))
    assert given == UserSettings(target="BOTH", lightmap_half=False, lightmap_png=True, lightmap_png_exposure=-1.5,
                                 lightmap_resolution=512, lightmap_indirect="gather", quality="CUSTOM")
    saved = UserSettings(quality="DRAFT", target="BOTH", lightmap_resolution=64, light_groups=True,
                         own_mesh_copies=False, relight_cache="/cache/level.rlcache")
    assert user_settings(parser.parse_args(["in.blend", "-o", "out.blend"]), saved) == saved
    given = user_settings(parser.parse_args(["in.blend", "-o", "out.blend", "--target", "lightmap",
                                             "--no-light-groups", "--no-keep-shared-meshes"]), saved)
    assert given == replace(saved, target="LIGHTMAP", light_groups=False, own_mesh_copies=True)


def test_a_value_out_of_its_bounds_is_refused_by_name(extension):
    from radiosity_baker.core import SettingsError
    from radiosity_baker.radiosity_addon.settings import UserSettings
    with pytest.raises(SettingsError, match="'residual' must be from"):
        UserSettings(residual=5.0)
    with pytest.raises(SettingsError, match="'target' must be one of"):
        UserSettings(target="TEXTURE")
    with pytest.raises(SettingsError, match="'seed' must be a int"):
        UserSettings(seed="7")


class _Recorder:
    """A stand-in for a panel's layout that records the properties drawn and whether their row was enabled."""

    def __init__(self, drawn, enabled=True):
        self.drawn, self.enabled, self.use_property_split = drawn, enabled, False

    def row(self, **_):
        return _Recorder(self.drawn, self.enabled)

    column = row

    def prop(self, owner, name, **_):
        self.drawn[name] = self.enabled

    def operator(self, *_, **__):
        pass

    label = progress = operator


@pytest.mark.parametrize("target, hidden", [("VERTEX_COLORS", "lightmap"), ("LIGHTMAP", "vertex_colors"),
                                            ("BOTH", None)])
def test_the_panel_draws_every_setting_of_the_target(empty_scene, target, hidden):
    """Every setting of the table is drawn unless its section is not written; Custom's settings are greyed out
    under a preset, and the density and the resolution grey each other out."""
    from radiosity_baker.radiosity_addon.panels import RENDER_PT_radiosity
    from radiosity_baker.radiosity_addon.settings import SETTINGS
    settings = empty_scene.radiosity
    settings.target, settings.quality, settings.texels_per_metre = target, "MEDIUM", 20.0
    drawn = {}
    RENDER_PT_radiosity.draw(type("Panel", (), {"layout": _Recorder(drawn)})(), bpy.context)
    assert list(drawn) == [setting.name for setting in SETTINGS if setting.section != hidden]
    assert drawn["quality"] and not drawn["element_size"]
    if target != "VERTEX_COLORS":
        assert drawn["texels_per_metre"] and not drawn["lightmap_resolution"] and not drawn["lightmap_indirect"]
