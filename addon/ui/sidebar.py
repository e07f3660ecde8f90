"""The MotionKit tab in the 3D view's sidebar (N panel): its top panel, with the core's status and the
one-click tools; each capability's panel lives in its own ui module."""
import bpy

from . import common


class MOTIONKIT_PT_main(common.SidebarPanel, bpy.types.Panel):
    bl_label = "MotionKit"

    def draw(self, context):
        layout = self.layout
        common.draw_status(layout, compact=True)
        obj = context.object
        if obj is not None and obj.type == 'ARMATURE':
            row = layout.row()
            row.label(text=obj.name, icon='ARMATURE_DATA')
            row.label(text=f"{len(obj.data.bones)} bones")
        else:
            layout.label(text="Select an armature", icon='INFO')
        layout.label(text="Motion Capture (BVH)")
        row = layout.row(align=True)
        row.operator("motionkit.import_bvh", text="Import", icon='IMPORT')
        row.operator("motionkit.export_bvh", text="Export", icon='EXPORT')
        layout.label(text="Keys")
        row = layout.row(align=True)
        row.operator("motionkit.resample_keys", text="Resample", icon='IPO_BEZIER')
        row.operator("motionkit.reduce_keys", text="Reduce", icon='IPO_LINEAR')
        row = layout.row(align=True)
        row.operator("motionkit.filter_keys", text="Filter", icon='SMOOTHCURVE')
        row.operator("motionkit.mirror_action", text="Mirror", icon='MOD_MIRROR')
        layout.operator("motionkit.fix_foot_sliding", icon='CON_FLOOR')
