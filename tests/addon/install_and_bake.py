"""Run in a fresh process with BLENDER_USER_RESOURCES set to an empty folder: install the built extension zip
into the user repository, import embreex from the wheel it bundled, and bake a small scene with it.
Usage: python install_and_bake.py EXTENSION.zip; prints a JSON line with what it found."""
import glob
import json
import os
import sys

import bpy

result = bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default",
                                                  enable_on_install=True)
local = glob.glob(os.path.join(os.environ["BLENDER_USER_RESOURCES"], "extensions", ".local", "lib", "python*",
                               "site-packages"))
sys.path.insert(0, local[0])
for name in [m for m in sys.modules if m.startswith("embreex")]:
    del sys.modules[name]
import embreex  # noqa: E402

bpy.ops.mesh.primitive_plane_add(size=2.0)
bpy.ops.object.light_add(type="POINT", location=(0.0, 0.0, 1.0))
bpy.context.active_object.data.energy = 100.0
bpy.context.scene.radiosity.quality = "DRAFT"
baked = bpy.ops.radiosity.bake()
plane = bpy.data.objects["Plane"].data
print(json.dumps({"install": sorted(result), "embreex": embreex.__file__, "local": local[0],
                  "bake": sorted(baked), "attribute": "Radiosity" in plane.color_attributes}))
