"""MotionKit's user interface: one module per capability holding its properties, operators, panel and
menu entries (bvh, keys, retarget, contacts, ik), the sidebar's top panel, the preferences, and what they
share (common). register() puts them into Blender in order; unregister() takes them out in reverse."""
import bpy

from . import batch, bvh, common, contacts, ik, keys, preferences, preview, retarget, sidebar
from ..features import ik_live

classes = (
    preferences.MOTIONKIT_AddonPreferences,
    *common.classes,
    sidebar.MOTIONKIT_PT_main,
    *bvh.classes,
    *keys.classes,
    *contacts.classes,
    *retarget.classes,
    *preview.classes,
    *batch.classes,
    *ik.classes,
)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    retarget.register_properties()
    batch.register_properties()
    ik.register_properties()
    bpy.types.TOPBAR_MT_file_import.append(bvh.menu_import)
    bpy.types.TOPBAR_MT_file_export.append(bvh.menu_export)
    for menu in keys.MENUS:
        getattr(bpy.types, menu).append(keys.menu_keys)
    bpy.types.VIEW3D_MT_pose.append(contacts.menu_pose)
    ik_live.register(ik.live_settings)
    preview.register()


def unregister():
    bpy.types.VIEW3D_MT_pose.remove(contacts.menu_pose)
    for menu in reversed(keys.MENUS):
        getattr(bpy.types, menu).remove(keys.menu_keys)
    bpy.types.TOPBAR_MT_file_export.remove(bvh.menu_export)
    bpy.types.TOPBAR_MT_file_import.remove(bvh.menu_import)
    preview.unregister()
    ik_live.unregister()
    ik.unregister_properties()
    batch.unregister_properties()
    retarget.unregister_properties()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
