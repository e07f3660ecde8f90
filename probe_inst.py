import bpy, addon_utils, sys, os
print("repos", [(r.module, r.directory) for r in bpy.context.preferences.extensions.repos])
try:
    r = bpy.ops.extensions.package_install_files(filepath=os.path.abspath("probe.zip"), repo="user_default", enable_on_install=True)
    print("install op:", r)
except Exception as e:
    print("install op failed:", type(e).__name__, e)
print("enabled:", [a.module for a in bpy.context.preferences.addons])
