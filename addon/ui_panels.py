"""The MotionKit tab in the 3D view's sidebar (N panel)."""
import bpy

from . import contact_props, native_state


class MOTIONKIT_PT_main(bpy.types.Panel):
    bl_label = "MotionKit"
    bl_idname = "MOTIONKIT_PT_main"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "MotionKit"

    def draw(self, context):
        native_state.draw_status(self.layout)
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


class MOTIONKIT_UL_bone_map(bpy.types.UIList):
    """One row per source -> target pair; bone names pick from the armatures when they are in the file."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        settings = context.scene.motionkit_retarget
        row = layout.row(align=True)
        if settings.source_kind == 'ARMATURE' and settings.source is not None:
            row.prop_search(item, "source", settings.source.data, "bones", text="")
        else:
            row.prop(item, "source", text="", emboss=True)
        row.label(text="", icon='FORWARD')
        if settings.target is not None:
            row.prop_search(item, "target", settings.target.data, "bones", text="")
        else:
            row.prop(item, "target", text="")


class MOTIONKIT_PT_retarget(bpy.types.Panel):
    bl_label = "Retarget"
    bl_idname = "MOTIONKIT_PT_retarget"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "MotionKit"

    def draw(self, context):
        settings = context.scene.motionkit_retarget
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(settings, "source_kind", expand=True)
        if settings.source_kind == 'BVH':
            layout.prop(settings, "bvh_path")
        else:
            layout.prop(settings, "source")
        layout.prop(settings, "target")

        layout.label(text="Bone Map")
        row = layout.row()
        row.template_list("MOTIONKIT_UL_bone_map", "", settings, "pairs", settings, "active_pair", rows=6)
        col = row.column(align=True)
        col.operator("motionkit.bone_map_add", text="", icon='ADD')
        col.operator("motionkit.bone_map_remove", text="", icon='REMOVE')
        col.separator()
        col.operator("motionkit.bone_map_load", text="", icon='FILEBROWSER')
        col.operator("motionkit.bone_map_save", text="", icon='FILE_TICK')
        row = layout.row(align=True)
        row.operator("motionkit.bone_map_auto", icon='AUTO')
        row.operator("motionkit.bone_map_scheme", icon='PRESET')
        if not settings.pairs:
            layout.label(text="An empty map is filled automatically", icon='INFO')

        layout.prop(settings, "source_match")
        if settings.source_match == 'FRAME':
            layout.prop(settings, "match_frame")
        layout.prop(settings, "target_match")
        layout.prop(settings, "root_motion")
        layout.prop(settings, "floor_root")
        if settings.floor_root == "extract":
            layout.prop(settings, "root_smoothing")
        layout.prop(settings, "ground")
        layout.prop(settings, "align_facing")
        layout.prop(settings, "use_frame_range")
        if settings.use_frame_range:
            col = layout.column(align=True)
            col.prop(settings, "frame_start")
            col.prop(settings, "frame_end")
        layout.prop(settings, "overwrite")
        layout.operator("motionkit.retarget", icon='ARMATURE_DATA')


class MOTIONKIT_PT_retarget_feet(bpy.types.Panel):
    """Planted feet: contacts detected on the source and held on the target; their thresholds."""
    bl_label = "Plant Feet"
    bl_idname = "MOTIONKIT_PT_retarget_feet"
    bl_parent_id = "MOTIONKIT_PT_retarget"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "MotionKit"
    bl_options = {'DEFAULT_CLOSED'}

    def draw_header(self, context):
        self.layout.prop(context.scene.motionkit_retarget, "plant_feet", text="")

    def draw(self, context):
        settings = context.scene.motionkit_retarget
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.active = settings.plant_feet
        contact_props.draw(layout, settings.contacts)
        layout.label(text="Keyed as 0/1 curves on the feet", icon='INFO')


class MOTIONKIT_UL_ik_effectors(bpy.types.UIList):
    """One row per effector: bone, then its target or the pin."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        obj = data.id_data
        row = layout.row(align=True)
        row.prop_search(item, "bone", obj.data, "bones", text="")
        row.prop(item, "pin", text="", icon='PINNED' if item.pin else 'UNPINNED')
        if not item.pin:
            row.prop(item, "target", text="")
            if item.target is not None and item.target.type == 'ARMATURE':
                row.prop_search(item, "subtarget", item.target.data, "bones", text="")


class MOTIONKIT_PT_ik(bpy.types.Panel):
    bl_label = "Full-body IK"
    bl_idname = "MOTIONKIT_PT_ik"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "MotionKit"

    def draw(self, context):
        layout = self.layout
        obj = context.object
        if obj is None or obj.type != 'ARMATURE':
            layout.label(text="Select an armature", icon='INFO')
            return
        settings = obj.motionkit_ik
        row = layout.row()
        row.template_list("MOTIONKIT_UL_ik_effectors", "", settings, "effectors", settings, "active_effector",
                          rows=4)
        col = row.column(align=True)
        col.operator("motionkit.ik_effector_add", text="", icon='ADD')
        col.operator("motionkit.ik_effector_remove", text="", icon='REMOVE')
        if 0 <= settings.active_effector < len(settings.effectors):
            item = settings.effectors[settings.active_effector]
            row = layout.row(align=True)
            row.prop(item, "weight")
            row.prop(item, "use_position", toggle=True)
            row.prop(item, "use_orientation", toggle=True)
            layout.prop(item, "chain_count")
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(settings, "method")
        col = layout.column(align=True)
        col.prop(settings, "max_iterations")
        col.prop(settings, "damping")
        col.prop(settings, "regularization")
        layout.prop(settings, "root_translation")
        layout.prop(settings, "root_rotation")
        layout.prop(settings, "use_limits")
        row = layout.row(align=True)
        row.operator("motionkit.ik_solve", icon='CON_KINEMATIC')
        row.prop(settings, "live", toggle=True, icon='PLAY')
        layout.prop(settings, "use_scene_range")
        if not settings.use_scene_range:
            col = layout.column(align=True)
            col.prop(settings, "frame_start")
            col.prop(settings, "frame_end")
        layout.prop(settings, "new_action")
        layout.operator("motionkit.ik_bake", icon='REC')
