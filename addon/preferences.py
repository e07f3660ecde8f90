"""Add-on preferences: where the user sees whether the native core loaded."""
import bpy

from . import native_state


class MOTIONKIT_AddonPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    def draw(self, context):
        native_state.draw_status(self.layout)
