"""Scene and object settings stored in the .blend (Render properties > Radiosity; Object properties > Radiosity)."""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from .presets import UserSettings

QUALITY_ITEMS = [
    ("DRAFT", "Draft", "16 elements and 128 lightmap texels across the scene, no adaptive pass: seconds"),
    ("MEDIUM", "Medium", "32 elements and 256 lightmap texels across the scene, one adaptive pass"),
    ("HIGH", "High", "48 elements and 512 lightmap texels across the scene, one adaptive pass, more shadow rays"),
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
    make_local: BoolProperty(name="Make Linked Objects Local", default=False,
                             description="Make objects linked from libraries local (with their meshes) so that "
                                         "they hold their bake; off, they light the scene but are not baked")
    target: EnumProperty(name="Target", default="VERTEX_COLORS", items=[
        ("VERTEX_COLORS", "Vertex Colors", "A colour attribute per mesh corner"),
        ("LIGHTMAP", "Lightmap", "A lightmap texture on a new UV map (sharp shadows at any mesh density)"),
        ("BOTH", "Both", "Vertex colours and a lightmap")])
    max_memory_gb: FloatProperty(name="Memory Limit (GB)", default=0.0, min=0.0, soft_max=256.0,
                                 description="The most memory a bake may use, in GiB: a larger bake gets coarser "
                                             "elements or is refused before the heavy work starts; 0 allows 75% "
                                             "of this machine's memory")
    texels_per_metre: FloatProperty(name="Texels per Metre", default=0.0, min=0.0, soft_max=1024.0,
                                    description="Lightmap density; 0 follows the quality preset (Medium: 256 "
                                                "texels across the scene)")
    lightmap_resolution: IntProperty(name="Resolution", default=0, min=0, max=8192,
                                     description="Square lightmap size in texels; 0 sizes it from the density")
    lightmap_max_size: IntProperty(name="Max Size", default=4096, min=64, max=16384,
                                   description="Texels a side of a lightmap image; a density that needs more gets "
                                               "several images")
    lightmap_padding: IntProperty(name="Padding", default=4, min=1, max=32,
                                  description="Texels between charts, filled by dilation so filtering and "
                                              "mipmaps do not bleed")
    lightmap_indirect: EnumProperty(name="Indirect Light", default="auto", items=[
        ("auto", "Automatic", "Final gather where the elements are coarse next to the distances between surfaces, "
                              "else interpolation (what the presets use)"),
        ("interpolate", "Interpolate", "From the radiosity elements' corners: smooth, fast"),
        ("gather", "Final Gather", "Rays from each texel look up the radiosity solution: finer indirect detail, "
                                   "some noise")],
                                    description="How lightmap texels get indirect light (Custom quality)")
    gather_samples: IntProperty(name="Gather Samples", default=8, min=1, max=32,
                                description="Final-gather rays per texel: this number squared (Custom quality)")
    lightmap_uv_map: StringProperty(name="UV Map", default="Lightmap",
                                    description="Name of the UV map the bake makes, or reads with Use Existing UV "
                                                "Map (existing UV maps are never changed)")
    lightmap_existing_uv: BoolProperty(name="Use Existing UV Map", default=False,
                                       description="Bake onto the UV map named above, which the objects already "
                                                   "have (it is read, not changed), instead of making one")
    lightmap_image: StringProperty(name="Image", default="Radiosity Lightmap",
                                   description="Name of the lightmap image (and of its .exr file)")
    lightmap_folder: StringProperty(name="Folder", default="//", subtype="DIR_PATH",
                                    description="Where the .exr goes (// is the .blend's folder; an unsaved "
                                                ".blend gets the image packed)")
    lightmap_half: BoolProperty(name="Half Float", default=True,
                                description="16-bit float EXR (smaller); off for 32-bit float")
    lightmap_png: BoolProperty(name="Also PNG", default=False,
                               description="Also write an 8-bit sRGB PNG beside the EXR, for engines that want low "
                                           "dynamic range (not for a packed image)")
    lightmap_png_exposure: FloatProperty(name="PNG Exposure", default=0.0, soft_min=-10.0, soft_max=10.0,
                                         description="Stops: the PNG holds sRGB(clamp(light x 2^stops, 0, 1))")

    def user_settings(self) -> UserSettings:
        return UserSettings(self.quality, self.element_size, self.patch_size, self.adaptive_passes, self.residual,
                            self.light_samples, self.form_factors, gather_samples_per_edge=self.gather_samples,
                            texels_per_metre=self.texels_per_metre, lightmap_indirect=self.lightmap_indirect,
                            max_memory_gb=self.max_memory_gb)

    def outputs(self):
        from .job import Outputs
        from .lightmaps import LightmapOptions, lightmap_folder
        options = LightmapOptions(self.lightmap_uv_map, self.lightmap_image, self.texels_per_metre or None,
                                  self.lightmap_resolution or None, self.lightmap_padding, self.lightmap_max_size,
                                  half=self.lightmap_half,
                                  png_exposure=self.lightmap_png_exposure if self.lightmap_png else None,
                                  existing_uv_map=self.lightmap_existing_uv)
        return Outputs(self.target, self.attribute_name, self.create_radiosity_mesh, options,
                       lightmap_folder(self.lightmap_folder), self.make_local)


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
