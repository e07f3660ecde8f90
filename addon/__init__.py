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

from . import (animdata, bone_mapping, bvh, contact_props, contacts, foot_contacts, ik, ik_live, ik_props,
               native_state, operators_bvh, operators_contacts, operators_ik, operators_keys, operators_retarget,
               pose_channels, preferences, resample_plan, resampling, retarget_props, retargeting, root_motion,
               rotation_channels, ui_panels)
from .native_state import native
from .resampling import reduce_keys, resample
from .retargeting import retarget, retarget_files

classes = (
    preferences.MOTIONKIT_AddonPreferences,
    ui_panels.MOTIONKIT_PT_main,
    operators_bvh.MOTIONKIT_OT_import_bvh,
    operators_bvh.MOTIONKIT_OT_export_bvh,
    operators_keys.MOTIONKIT_OT_resample_keys,
    operators_keys.MOTIONKIT_OT_reduce_keys,
    operators_contacts.MOTIONKIT_OT_fix_foot_sliding,
    *retarget_props.classes,
    *operators_retarget.classes,
    ui_panels.MOTIONKIT_UL_bone_map,
    ui_panels.MOTIONKIT_PT_retarget,
    ui_panels.MOTIONKIT_PT_retarget_feet,
    *ik_props.classes,
    *operators_ik.classes,
    ui_panels.MOTIONKIT_UL_ik_effectors,
    ui_panels.MOTIONKIT_PT_ik,
)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    retarget_props.register_properties()
    ik_props.register_properties()
    bpy.types.TOPBAR_MT_file_import.append(operators_bvh.menu_import)
    bpy.types.TOPBAR_MT_file_export.append(operators_bvh.menu_export)
    for menu in operators_keys.MENUS:
        getattr(bpy.types, menu).append(operators_keys.menu_keys)
    bpy.types.VIEW3D_MT_pose.append(operators_contacts.menu_pose)
    # Installed as an extension the package is bl_ext.<repo>.motionkit; the
    # aliases keep `import motionkit` and `from motionkit import animdata`
    # working for headless scripts either way, without loading anything twice.
    if __package__ != "motionkit":
        for name in _aliases():
            sys.modules.setdefault("motionkit" + name[len(__package__):], sys.modules[name])
    if not native_state.status.ok:
        # Enabling still succeeds so that the preferences and the sidebar can
        # show the reason; the console gets it in one line, not a traceback.
        print(f"MotionKit: {native_state.status.message}", file=sys.stderr)


def _aliases():
    prefix = __package__ + "."
    return [n for n in list(sys.modules) if n == __package__ or n.startswith(prefix)]


def unregister():
    if __package__ != "motionkit":
        for name in _aliases():
            alias = "motionkit" + name[len(__package__):]
            if sys.modules.get(alias) is sys.modules[name]:
                del sys.modules[alias]
    bpy.types.VIEW3D_MT_pose.remove(operators_contacts.menu_pose)
    for menu in reversed(operators_keys.MENUS):
        getattr(bpy.types, menu).remove(operators_keys.menu_keys)
    bpy.types.TOPBAR_MT_file_export.remove(operators_bvh.menu_export)
    bpy.types.TOPBAR_MT_file_import.remove(operators_bvh.menu_import)
    ik_live.unregister()
    ik_props.unregister_properties()
    retarget_props.unregister_properties()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
