"""Scene and object settings stored in the .blend (Render properties > Radiosity; Object properties > Radiosity).

The scene's properties are made from settings.SETTINGS, the one table of what a user can choose (plus the panel's
own Preview Group).
"""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from .settings import SETTINGS, Setting, UserSettings


def _property(setting: Setting):
    """The bpy property of one setting of the table."""
    common = {"name": setting.label, "description": setting.help, "default": setting.default}
    if setting.items:
        return EnumProperty(items=list(setting.items), **common)
    if setting.kind is bool:
        return BoolProperty(**common)
    if setting.kind is str:
        return StringProperty(subtype=setting.subtype or "NONE", **common)
    bounds = {key: value for key, value in (("min", setting.low), ("max", setting.high),
                                           ("soft_max", setting.soft_high)) if value is not None}
    if setting.kind is int:
        return IntProperty(**bounds, **common)
    extra = {"precision": setting.precision} if setting.precision is not None else {}
    return FloatProperty(unit=setting.unit or "NONE", **bounds, **extra, **common)


class RadiositySceneSettings(bpy.types.PropertyGroup):
    """The table's settings, and what the panel alone uses: the light group the preview shows."""

    __annotations__ = {setting.name: _property(setting) for setting in SETTINGS} | {
        "preview_light_group": StringProperty(
            name="Preview Group", description="The light group Preview Baked Light shows (its name, or "
            "'ungrouped'); empty shows the sum of them all")}

    def user_settings(self) -> UserSettings:
        return UserSettings(**{setting.name: getattr(self, setting.name) for setting in SETTINGS})


class RadiosityObjectSettings(bpy.types.PropertyGroup):
    mode: EnumProperty(name="Radiosity", default="BAKE", items=[
        ("BAKE", "Bake", "Receives, reflects and casts light, and gets baked"),
        ("SHADOW_ONLY", "Shadow Only", "Casts shadows but is not solved or baked"),
        ("EXCLUDE", "Exclude", "Ignored by the bake")])
    lightmap_scale: FloatProperty(name="Lightmap Scale", default=1.0, min=0.01, soft_max=8.0,
                                  description="Multiplies this object's lightmap texel density")


classes = (RadiositySceneSettings, RadiosityObjectSettings)


def register_properties():
    bpy.types.Scene.radiosity = PointerProperty(type=RadiositySceneSettings)
    bpy.types.Object.radiosity = PointerProperty(type=RadiosityObjectSettings)


def unregister_properties():
    del bpy.types.Object.radiosity
    del bpy.types.Scene.radiosity
