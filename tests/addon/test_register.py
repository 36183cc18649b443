"""Registration: the extension unregisters and registers cleanly, twice, and exposes its operators and panels."""
import bpy


def test_unregister_register_twice(extension):
    for _ in range(2):
        extension.unregister()
        assert not hasattr(bpy.types.Scene, "radiosity") and not hasattr(bpy.types.Object, "radiosity")
        assert "RENDER_PT_radiosity" not in dir(bpy.types)
        extension.register()
        assert hasattr(bpy.types.Scene, "radiosity") and hasattr(bpy.types.Object, "radiosity")
        assert hasattr(bpy.ops.radiosity, "bake") and hasattr(bpy.ops.radiosity, "cancel")
        assert "RENDER_PT_radiosity" in dir(bpy.types) and "OBJECT_PT_radiosity" in dir(bpy.types)
