"""Install a MotionKit zip into the running Blender and enable it (run inside Blender).

Used by the Blender tests, the demo and the benchmarks so that what they
exercise is the real packaged artefact, installed the way a user installs it:
Preferences > Add-ons > Install on 3.x, as an extension on 4.2 and later.
Blender must be started with BLENDER_USER_* pointing at a throwaway folder
(tools/with_blender.sh does that).

As a script: blender -b --factory-startup --python tools/install_addon.py -- ZIP
prints MOTIONKIT_MODULE <name> once enabled.
"""
import os
import sys

import addon_utils
import bpy

EXTENSIONS = bpy.app.version >= (4, 2, 0)


def install(zip_path: str) -> str:
    """Installs and enables the zip; returns the add-on's module name."""
    zip_path = os.path.abspath(zip_path)
    if not os.path.isfile(zip_path):
        raise SystemExit(f"install_addon: no such zip: {zip_path}")
    if EXTENSIONS:
        result = bpy.ops.extensions.package_install_files(
            filepath=zip_path, repo="user_default", enable_on_install=False)
        module = "bl_ext.user_default.motionkit"
    else:
        result = bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True)
        module = "motionkit"
    if result != {'FINISHED'}:
        raise SystemExit(f"install_addon: installing {zip_path} failed: {result}")
    errors = []
    mod = addon_utils.enable(module, default_set=True, handle_error=errors.append)
    if errors or mod is None:
        raise SystemExit(f"install_addon: enabling {module} failed: {errors}")
    return module


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(args) != 1:
        raise SystemExit("usage: blender -b --factory-startup --python tools/install_addon.py -- ZIP")
    print("MOTIONKIT_MODULE", install(args[0]), flush=True)
