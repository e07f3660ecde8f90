"""The MotionKit tab in the 3D view's sidebar (N panel): its top panel, with the core's status and the
one-click tools; each capability's panel lives in its own ui module."""
import bpy

from . import common


class MOTIONKIT_PT_main(bpy.types.Panel):
    bl_label = "MotionKit"
    bl_idname = "MOTIONKIT_PT_main"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "MotionKit"

    def draw(self, context):
        common.draw_status(self.layout)
        obj = context.object
        if obj is not None and obj.type == 'ARMATURE':
            self.layout.label(text=f"Armature: {obj.name} ({len(obj.data.bones)} bones)",
                              icon='ARMATURE_DATA')
        else:
            self.layout.label(text="Select an armature", icon='INFO')
        row = self.layout.row(align=True)
        row.operator("motionkit.import_bvh", text="Import BVH", icon='IMPORT')
        row.operator("motionkit.export_bvh", text="Export BVH", icon='EXPORT')
        self.layout.label(text="Keys")
        row = self.layout.row(align=True)
        row.operator("motionkit.resample_keys", text="Resample", icon='IPO_BEZIER')
        row.operator("motionkit.reduce_keys", text="Reduce", icon='IPO_LINEAR')
        self.layout.operator("motionkit.fix_foot_sliding", icon='CON_FLOOR')
