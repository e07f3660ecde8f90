"""MotionKit: retarget, full-body IK and keyframe resampling with a native core.

Blender 3.4 installs this package as a legacy add-on (bl_info); 4.2 and later
install it as an extension (blender_manifest.toml, written by build_addon.py).
"""

bl_info = {
    "name": "MotionKit",
    "author": "MotionKit developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > MotionKit",
    "description": "Motion retargeting, full-body IK and keyframe resampling with a native solver",
    "category": "Animation",
}

import sys

import bpy

from . import native_state, preferences, ui_panels
from .native_state import native

classes = (
    preferences.MOTIONKIT_AddonPreferences,
    ui_panels.MOTIONKIT_PT_main,
)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    # Installed as an extension the package is bl_ext.<repo>.motionkit; the
    # alias keeps `import motionkit` working for headless scripts either way.
    if __package__ != "motionkit":
        sys.modules.setdefault("motionkit", sys.modules[__package__])
    if not native_state.status.ok:
        # Enabling still succeeds so that the preferences and the sidebar can
        # show the reason; the console gets it in one line, not a traceback.
        print(f"MotionKit: {native_state.status.message}", file=sys.stderr)


def unregister():
    if sys.modules.get("motionkit") is sys.modules[__package__] and __package__ != "motionkit":
        del sys.modules["motionkit"]
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
