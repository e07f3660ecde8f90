"""Add-on preferences: where the user sees whether the native core loaded."""
import bpy

from . import common


class MOTIONKIT_AddonPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__.rpartition(".")[0]  # the add-on's own package, not this ui sub-package

    def draw(self, context):
        common.draw_status(self.layout)
