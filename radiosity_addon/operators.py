"""Operators: Bake (a worker thread with progress and Esc when invoked from the UI; synchronous in execute()),
Cancel, and the viewport preview of the baked light."""
from __future__ import annotations

import os
import threading

import bpy

from ..core import BakeCancelled, BakeError
from . import hookup
from . import job as bake_job
from .lightmaps import lightmap_folder, page_images
from .export import export_scene
from .relighting import SESSION, cache_key, cache_path, transport_key
from .settings import light_group_output

# The one interactive bake at a time; the worker thread writes only plain Python values here.
STATUS = {"running": False, "fraction": 0.0, "message": "", "cancel": False, "error": None, "summary": "",
          "relight": "", "checking": False}


def _user_args(context):
    """The job's arguments from the scene's settings: UserSettings and the lightmaps' absolute folder."""
    settings = context.scene.radiosity
    return settings.user_settings(), lightmap_folder(settings.lightmap_folder)


def _summary(report: dict) -> str:
    return (f"Baked {len(report['objects'])} object(s): {report['elements']} elements, residual "
            f"{report['residual']:.4f}, {report['seconds']:.1f} s")


class RADIOSITY_OT_bake(bpy.types.Operator):
    """Solve diffuse light by radiosity and bake it into a colour attribute of every baked mesh, a lightmap on a
    UV map of its own, or both (the Target setting)"""

    bl_idname = "radiosity.bake"
    bl_label = "Bake Radiosity"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return not STATUS["running"] and context.scene is not None

    def execute(self, context):
        try:
            job = bake_job.prepare(context, *_user_args(context))
            bake_job.solve(job, lambda fraction, message: None, lambda: False)
        except BakeError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return _apply(self, job)

    def invoke(self, context, event):
        try:
            self._job = bake_job.prepare(context, *_user_args(context))
        except BakeError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        STATUS.update(running=True, fraction=0.0, message="Starting", cancel=False, error=None)
        self._thread = threading.Thread(target=self._work, daemon=True)
        self._thread.start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.progress_begin(0.0, 1.0)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _work(self):
        def progress(fraction, message):
            STATUS["fraction"], STATUS["message"] = fraction, message
        try:
            bake_job.solve(self._job, progress, lambda: STATUS["cancel"])
        except Exception as error:  # reported in the main thread by modal()
            STATUS["error"] = error

    def modal(self, context, event):
        if event.type == "ESC":
            STATUS["cancel"] = True
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        context.window_manager.progress_update(STATUS["fraction"])
        for area in context.screen.areas if context.screen else []:
            area.tag_redraw()
        if self._thread.is_alive():
            return {"RUNNING_MODAL"}
        return self._finish(context)

    def _finish(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        STATUS["running"] = False
        error = STATUS["error"]
        if isinstance(error, BakeCancelled):
            STATUS["summary"] = "Bake cancelled; nothing was changed."
            self.report({"WARNING"}, STATUS["summary"])
            return {"CANCELLED"}
        if error is not None:
            return _failed(self, error)
        return _apply(self, self._job)



def _failed(operator, error):
    STATUS["summary"] = f"Bake failed: {error}"
    operator.report({"ERROR"}, STATUS["summary"])
    return {"CANCELLED"}


def _apply(operator, job):
    """Write the results (main thread) and report; a file that cannot be written fails the bake, and the earlier
    files stay as they were."""
    try:
        report = bake_job.write_outputs(job)
    except BakeError as error:
        return _failed(operator, error)
    for warning in report["warnings"]:
        operator.report({"WARNING"}, warning)
    STATUS["summary"] = _summary(report)
    STATUS["relight"] = ""
    operator.report({"INFO"}, STATUS["summary"])
    return {"FINISHED"}


class RADIOSITY_OT_update_light(bpy.types.Operator):
    """Write the baked light again from the relighting cache, for the lamps' strengths and colours, emission
    strengths, the world's strength and the light groups as they are now, without baking; refused, naming it,
    when anything else changed since the cache was baked"""

    bl_idname = "radiosity.update_light"
    bl_label = "Update Light"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return not STATUS["running"] and context.scene is not None and bool(context.scene.radiosity.relight_cache)

    def execute(self, context):
        try:
            user, folder = _user_args(context)
            job = bake_job.relight_job(context, user, folder, cache_path(user.relight_cache))
        except BakeError as error:
            return _failed(self, error)
        return _apply(self, job)


class RADIOSITY_OT_cancel(bpy.types.Operator):
    """Stop the running radiosity bake; the file stays as it was"""

    bl_idname = "radiosity.cancel"
    bl_label = "Cancel Bake"

    @classmethod
    def poll(cls, context):
        return STATUS["running"]

    def execute(self, context):
        STATUS["cancel"] = True
        return {"FINISHED"}


class RADIOSITY_OT_preview(bpy.types.Operator):
    """Show the baked light in the viewport: every material of the baked objects emits base colour x baked light
    (the lightmap if one was baked, else the colour attribute) and viewports switch to Material Preview; run it
    again to restore the materials exactly and the previous shading"""

    bl_idname = "radiosity.preview"
    bl_label = "Preview Baked Light"

    _saved: dict = {}

    def execute(self, context):
        spaces = [space for area in context.screen.areas if area.type == "VIEW_3D"
                  for space in area.spaces if space.type == "VIEW_3D"] if context.screen else []
        hooked = [m for m in bpy.data.materials if hookup.REMEMBERED in m]
        if hooked:
            for material in hooked:
                hookup.unhook(material)
            for space in spaces:
                space.shading.type = RADIOSITY_OT_preview._saved.get(space.as_pointer(), space.shading.type)
            RADIOSITY_OT_preview._saved = {}
            return {"FINISHED"}
        group = _baked_light_group(context.scene.radiosity)
        if group is None:
            shown = context.scene.radiosity.preview_light_group
            self.report({"WARNING"}, f"No light group '{shown}' was baked: bake with Light Groups, or clear Preview "
                                     "Group." if shown and context.scene.radiosity.light_groups else
                        "Nothing baked yet: bake first.")
            return {"CANCELLED"}
        baked = [o for o in context.scene.objects if o.type == "MESH" and _has_baked_light(o, context.scene.radiosity)]
        for material in hookup.materials_of(baked):
            hookup.hook_up(material, group)
        for space in spaces:
            RADIOSITY_OT_preview._saved[space.as_pointer()] = space.shading.type
            space.shading.type = "MATERIAL"
        return {"FINISHED"}


def _baked_light_group(settings):
    """The hookup group for what was baked: the lightmap image on its UV map, else the colour attribute; those of
    the light group Preview Group names, if it does."""
    group = settings.preview_light_group if settings.light_groups else ""
    image = light_group_output(settings.lightmap_image, group) if group else settings.lightmap_image
    attribute = light_group_output(settings.attribute_name, group) if group else settings.attribute_name
    images = page_images(image)
    if images:
        return hookup.baked_light_group(uv_map=settings.lightmap_uv_map, images=images)
    if any(attribute in m.color_attributes for m in bpy.data.meshes):
        return hookup.baked_light_group(attribute=attribute)
    return None


def _has_baked_light(obj, settings) -> bool:
    mesh = obj.data
    return settings.lightmap_uv_map in mesh.uv_layers or settings.attribute_name in mesh.color_attributes


classes = (RADIOSITY_OT_bake, RADIOSITY_OT_cancel, RADIOSITY_OT_preview, RADIOSITY_OT_update_light)


def check_scene() -> None:
    """Why the current scene's relighting cache no longer fits it ('' if it does, or there is none) into the
    panel's status, so that the panel says so before Update Light is pressed: run a moment after the scene
    changes (``watch``), comparing what the transport depends on now with the cache's key."""
    scene = bpy.context.scene
    setting = scene.radiosity.relight_cache if scene is not None else ""
    STATUS["relight"] = ""
    if not setting or STATUS["running"]:
        return None
    STATUS["checking"] = True  # the export's own depsgraph updates do not call for another check
    try:
        path = cache_path(setting)
        if path not in SESSION and not os.path.isfile(path):
            return None
        changed = transport_key(export_scene(bpy.context).scene, scene.radiosity.user_settings()).changes(
            cache_key(path))
        STATUS["relight"] = f"Bake again: {', '.join(changed)} changed since the cache" if changed else ""
    except BakeError as error:
        STATUS["relight"] = str(error)
    finally:
        STATUS["checking"] = False
    return None


@bpy.app.handlers.persistent
def _scene_changed(scene, depsgraph=None) -> None:
    """A moment after the scene changes, ``check_scene`` (when a relighting cache is set and no check runs)."""
    if STATUS["checking"] or not getattr(getattr(scene, "radiosity", None), "relight_cache", ""):
        return
    if not bpy.app.timers.is_registered(check_scene):
        bpy.app.timers.register(check_scene, first_interval=1.0)


def watch(on: bool) -> None:
    """Check the relighting cache against the scene after every change (on), or stop."""
    handlers = bpy.app.handlers.depsgraph_update_post
    if on and _scene_changed not in handlers:
        handlers.append(_scene_changed)
    elif not on and _scene_changed in handlers:
        handlers.remove(_scene_changed)
