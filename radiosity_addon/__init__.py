"""The Blender layer: export, Bake operator, panels, write-back and the command line.

Submodules that touch bpy are imported inside register(), so ``python -m radiosity_addon`` can start without them.
"""
from __future__ import annotations

_cli_handle = None


def _modules():
    from . import operators, panels, properties
    return properties, operators, panels


def register():
    import bpy
    global _cli_handle
    properties, operators, panels = _modules()
    for module in (properties, operators, panels):
        for cls in module.classes:
            bpy.utils.register_class(cls)
    properties.register_properties()
    operators.watch(True)
    if hasattr(bpy.utils, "register_cli_command"):
        from .cli import blender_command
        _cli_handle = bpy.utils.register_cli_command("radiosity_bake", blender_command)


def unregister():
    import bpy
    global _cli_handle
    properties, operators, panels = _modules()
    if _cli_handle is not None:
        bpy.utils.unregister_cli_command(_cli_handle)
        _cli_handle = None
    operators.watch(False)
    properties.unregister_properties()
    for module in (panels, operators, properties):
        for cls in reversed(module.classes):
            bpy.utils.unregister_class(cls)
