"""Panels: Render properties > Radiosity (settings, Bake / Cancel, progress) and Object properties > Radiosity."""
from __future__ import annotations

import bpy

from .operators import STATUS


class RENDER_PT_radiosity(bpy.types.Panel):
    bl_label = "Radiosity"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"

    def draw(self, context):
        settings = context.scene.radiosity
        layout = self.layout
        layout.use_property_split = True
        layout.prop(settings, "quality")
        column = layout.column()
        column.enabled = settings.quality == "CUSTOM"
        for name in ("element_size", "patch_size", "adaptive_passes", "residual", "light_samples"):
            column.prop(settings, name)
        layout.prop(settings, "form_factors")
        layout.prop(settings, "max_memory_gb")
        layout.prop(settings, "target")
        if settings.target != "LIGHTMAP":
            layout.prop(settings, "attribute_name")
        if settings.target != "VERTEX_COLORS":
            box = layout.column(heading="Lightmap")
            for name in ("texels_per_metre", "lightmap_resolution", "lightmap_max_size", "lightmap_padding",
                         "lightmap_uv_map", "lightmap_existing_uv", "lightmap_image", "lightmap_folder",
                         "lightmap_half", "lightmap_png"):
                box.prop(settings, name)
            exposure = box.column()
            exposure.enabled = settings.lightmap_png
            exposure.prop(settings, "lightmap_png_exposure")
            indirect = box.column()
            indirect.enabled = settings.quality == "CUSTOM"
            indirect.prop(settings, "lightmap_indirect")
            gather = indirect.column()
            gather.enabled = settings.lightmap_indirect != "interpolate"
            gather.prop(settings, "gather_samples")
        layout.prop(settings, "create_radiosity_mesh")
        layout.prop(settings, "make_local")
        if STATUS["running"]:
            if hasattr(layout, "progress"):
                layout.progress(factor=STATUS["fraction"], type="BAR", text=STATUS["message"])
            else:
                layout.label(text=f"{STATUS['message']} ({STATUS['fraction']:.0%})")
            layout.operator("radiosity.cancel", icon="CANCEL")
        else:
            layout.operator("radiosity.bake", icon="RENDER_STILL")
            layout.operator("radiosity.preview", icon="HIDE_OFF")
        if STATUS["summary"]:
            layout.label(text=STATUS["summary"])


class OBJECT_PT_radiosity(bpy.types.Panel):
    bl_label = "Radiosity"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type in {"MESH", "CURVE", "SURFACE", "META", "FONT"}

    def draw(self, context):
        self.layout.use_property_split = True
        self.layout.prop(context.object.radiosity, "mode")
        self.layout.prop(context.object.radiosity, "lightmap_scale")


classes = (RENDER_PT_radiosity, OBJECT_PT_radiosity)
