"""Blender extension entry point: a shim over radiosity_addon (no bpy import at module level)."""


def register():
    from .radiosity_addon import register as register_addon
    register_addon()


def unregister():
    from .radiosity_addon import unregister as unregister_addon
    unregister_addon()
