"""Panels: Render properties > Radiosity (settings, Bake / Cancel, progress) and Object properties > Radiosity."""
from __future__ import annotations

import bpy

from .operators import STATUS
from .settings import SETTINGS


class RENDER_PT_radiosity(bpy.types.Panel):
    bl_label = "Radiosity"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"

    def draw(self, context):
        settings = context.scene.radiosity
        layout = self.layout
        layout.use_property_split = True
        shown = {"": True, "vertex_colors": settings.target != "LIGHTMAP",
                 "lightmap": settings.target != "VERTEX_COLORS"}
        lightmap = None
        for setting in SETTINGS:  # in table order; a section's settings only when the target writes it
            if not shown[setting.section]:
                continue
            if setting.section == "lightmap":
                lightmap = lightmap or layout.column(heading="Lightmap")
            row = (lightmap if setting.section == "lightmap" else layout).row()
            row.enabled = setting.enabled_when is None or setting.enabled_when(settings)
            row.prop(settings, setting.name)
        if STATUS["running"]:
            if hasattr(layout, "progress"):
                layout.progress(factor=STATUS["fraction"], type="BAR", text=STATUS["message"])
            else:
                layout.label(text=f"{STATUS['message']} ({STATUS['fraction']:.0%})")
            layout.operator("radiosity.cancel", icon="CANCEL")
        else:
            layout.operator("radiosity.bake", icon="RENDER_STILL")
            layout.operator("radiosity.preview", icon="HIDE_OFF")
            if settings.relight_cache:
                layout.operator("radiosity.update_light", icon="LIGHT")
                if STATUS["relight"]:
                    layout.label(text=STATUS["relight"], icon="ERROR")
            if settings.light_groups:
                layout.prop(settings, "preview_light_group")
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
