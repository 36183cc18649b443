"""Scene and object settings stored in the .blend (Render properties > Radiosity; Object properties > Radiosity)."""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from .presets import UserSettings

QUALITY_ITEMS = [
    ("DRAFT", "Draft", "16 elements across the scene, no adaptive pass, 5% residual: seconds"),
    ("MEDIUM", "Medium", "40 elements across the scene, one adaptive pass, 1% residual"),
    ("HIGH", "High", "80 elements across the scene, two adaptive passes, 0.2% residual"),
    ("CUSTOM", "Custom", "Use the settings below"),
]


class RadiositySceneSettings(bpy.types.PropertyGroup):
    quality: EnumProperty(name="Quality", items=QUALITY_ITEMS, default="MEDIUM",
                          description="Preset for element size, adaptive passes and convergence")
    element_size: FloatProperty(name="Element Size", default=0.25, min=0.005, soft_max=2.0, unit="LENGTH",
                                description="Target edge length of the receiving elements (Custom quality)")
    patch_size: FloatProperty(name="Patch Size", default=1.0, min=0.01, soft_max=5.0, unit="LENGTH",
                              description="Target edge length of the shooting patches; larger is faster")
    adaptive_passes: IntProperty(name="Adaptive Passes", default=1, min=0, max=6,
                                 description="Passes that split elements where light changes fast (shadow edges)")
    residual: FloatProperty(name="Convergence", default=0.01, min=1e-5, max=0.5, precision=4,
                            description="Stop when the unshot power is this share of the injected power")
    light_samples: IntProperty(name="Light Samples", default=4, min=1, max=16,
                               description="Shadow rays per element and soft light: this number squared")
    form_factors: EnumProperty(name="Form Factors", default="raycast", items=[
        ("raycast", "Ray-cast", "Exact point-to-patch factor times shadow-ray visibility (accurate)"),
        ("hemicube", "Hemicube", "Cohen & Greenberg's hemicube with a ray-cast item buffer (classic, aliases)")])
    attribute_name: StringProperty(name="Attribute", default="Radiosity",
                                   description="Name of the colour attribute the bake writes (replaced on rebake)")
    create_radiosity_mesh: BoolProperty(name="Create Radiosity Mesh", default=False,
                                        description="Also add an object holding the adaptive element mesh and "
                                                    "its light")

    def user_settings(self) -> UserSettings:
        return UserSettings(self.quality, self.element_size, self.patch_size, self.adaptive_passes, self.residual,
                            self.light_samples, self.form_factors)


class RadiosityObjectSettings(bpy.types.PropertyGroup):
    mode: EnumProperty(name="Radiosity", default="BAKE", items=[
        ("BAKE", "Bake", "Receives, reflects and casts light, and gets baked"),
        ("SHADOW_ONLY", "Shadow Only", "Casts shadows but is not solved or baked"),
        ("EXCLUDE", "Exclude", "Ignored by the bake")])


classes = (RadiositySceneSettings, RadiosityObjectSettings)


def register_properties():
    bpy.types.Scene.radiosity = PointerProperty(type=RadiositySceneSettings)
    bpy.types.Object.radiosity = PointerProperty(type=RadiosityObjectSettings)


def unregister_properties():
    del bpy.types.Object.radiosity
    del bpy.types.Scene.radiosity
