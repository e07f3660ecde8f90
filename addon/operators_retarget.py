"""Retarget and the bone map: the operators behind the MotionKit > Retarget panel."""
import os

import bpy
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from . import bone_mapping, bvh, native_state, retargeting


def _settings(context):
    return context.scene.motionkit_retarget


def _source_ready(settings) -> str:
    """Why the source cannot be used yet, or ''."""
    if settings.source_kind == 'BVH':
        path = bpy.path.abspath(settings.bvh_path)
        return "" if path and os.path.isfile(path) else "Pick a BVH file"
    return "" if settings.source is not None else "Pick a source armature"


def _source_rig(settings):
    if settings.source_kind == 'BVH':
        return bvh.mapping_rig(bpy.path.abspath(settings.bvh_path))
    return retargeting.mapping_rig(settings.source)


class MOTIONKIT_OT_retarget(bpy.types.Operator):
    """Retarget the source's motion onto the target armature as a new action (MotionKit)"""
    bl_idname = "motionkit.retarget"
    bl_label = "Retarget"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        if not native_state.poll_native(cls):
            return False
        settings = _settings(context)
        why = _source_ready(settings) or ("" if settings.target is not None else "Pick a target armature")
        if why:
            cls.poll_message_set(why)
            return False
        return True

    def execute(self, context):
        settings = _settings(context)
        wm = context.window_manager
        wm.progress_begin(0, 3)
        imported = None
        try:
            source = settings.source
            if settings.source_kind == 'BVH':
                imported, _ = bvh.load(bpy.path.abspath(settings.bvh_path), context=context)
                source = imported
            wm.progress_update(1)
            frame_range = (settings.frame_start, settings.frame_end) if settings.use_frame_range else None
            plan = retargeting.plan(
                source, settings.target, settings.bone_map() or None, frame_range, settings.root_motion,
                source_match=settings.source_match, match_frame=settings.match_frame,
                target_match=settings.target_match, ground=settings.ground, align_facing=settings.align_facing)
            wm.progress_update(2)
            action = retargeting.apply(plan, overwrite=settings.overwrite)
        except (ValueError, OSError) as ex:
            if imported is not None:
                retargeting.remove_armature(imported)
            self.report({'ERROR'}, str(ex))
            return {'CANCELLED'}
        finally:
            wm.progress_end()
        self.report({'INFO'}, f"Retargeted {len(plan.frames)} frames, {len(plan.pairs)} bones onto "
                              f"'{plan.target.name}' as action '{action.name}'")
        return {'FINISHED'}


class MOTIONKIT_OT_bone_map_auto(bpy.types.Operator):
    """Fill the bone map from the bones' names and, where names say nothing, the skeletons (MotionKit)"""
    bl_idname = "motionkit.bone_map_auto"
    bl_label = "Auto-map"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        settings = _settings(context)
        why = _source_ready(settings) or ("" if settings.target is not None else "Pick a target armature")
        if why:
            cls.poll_message_set(why)
            return False
        return True

    def execute(self, context):
        settings = _settings(context)
        try:
            pairs = bone_mapping.auto_map(_source_rig(settings), retargeting.mapping_rig(settings.target))
        except (ValueError, OSError) as ex:
            self.report({'ERROR'}, str(ex))
            return {'CANCELLED'}
        settings.set_bone_map(pairs)
        self.report({'INFO'}, f"Mapped {len(pairs)} bones")
        return {'FINISHED'}


def _scheme_items(self, context):
    return [(key, scheme.get("label", key), "") for key, scheme in sorted(bone_mapping.schemes().items())]


class MOTIONKIT_OT_bone_map_scheme(bpy.types.Operator):
    """Fill the bone map from two naming schemes MotionKit ships (Mixamo, Rigify, CMU, GAMES-105, Unreal)"""
    bl_idname = "motionkit.bone_map_scheme"
    bl_label = "Map by Schemes"
    bl_options = {'REGISTER', 'UNDO'}

    source_scheme: EnumProperty(name="Source Scheme", items=_scheme_items)
    target_scheme: EnumProperty(name="Target Scheme", items=_scheme_items)

    @classmethod
    def poll(cls, context):
        return MOTIONKIT_OT_bone_map_auto.poll(context)

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        settings = _settings(context)
        try:
            pairs = bone_mapping.map_from_presets(_source_rig(settings), self.source_scheme,
                                                  retargeting.mapping_rig(settings.target), self.target_scheme)
        except (ValueError, OSError) as ex:
            self.report({'ERROR'}, str(ex))
            return {'CANCELLED'}
        settings.set_bone_map(pairs)
        self.report({'INFO'}, f"Mapped {len(pairs)} bones")
        return {'FINISHED'}


class MOTIONKIT_OT_bone_map_add(bpy.types.Operator):
    """Add a source -> target pair to the bone map"""
    bl_idname = "motionkit.bone_map_add"
    bl_label = "Add Pair"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        settings = _settings(context)
        settings.pairs.add()
        settings.active_pair = len(settings.pairs) - 1
        return {'FINISHED'}


class MOTIONKIT_OT_bone_map_remove(bpy.types.Operator):
    """Remove the selected pair from the bone map"""
    bl_idname = "motionkit.bone_map_remove"
    bl_label = "Remove Pair"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        settings = _settings(context)
        if not 0 <= settings.active_pair < len(settings.pairs):
            cls.poll_message_set("Select a pair")
            return False
        return True

    def execute(self, context):
        settings = _settings(context)
        settings.pairs.remove(settings.active_pair)
        settings.active_pair = min(settings.active_pair, len(settings.pairs) - 1)
        return {'FINISHED'}


class MOTIONKIT_OT_bone_map_save(bpy.types.Operator, ExportHelper):
    """Save the bone map as a JSON preset"""
    bl_idname = "motionkit.bone_map_save"
    bl_label = "Save Bone Map"

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={'HIDDEN'})

    def execute(self, context):
        try:
            bone_mapping.save_map(self.filepath, _settings(context).bone_map())
        except (ValueError, OSError) as ex:
            self.report({'ERROR'}, str(ex))
            return {'CANCELLED'}
        return {'FINISHED'}


class MOTIONKIT_OT_bone_map_load(bpy.types.Operator, ImportHelper):
    """Load a bone map saved as a JSON preset"""
    bl_idname = "motionkit.bone_map_load"
    bl_label = "Load Bone Map"
    bl_options = {'REGISTER', 'UNDO'}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={'HIDDEN'})

    def execute(self, context):
        try:
            pairs = bone_mapping.load_map(self.filepath)
        except (ValueError, OSError) as ex:
            self.report({'ERROR'}, str(ex))
            return {'CANCELLED'}
        _settings(context).set_bone_map(pairs)
        return {'FINISHED'}


classes = (MOTIONKIT_OT_retarget, MOTIONKIT_OT_bone_map_auto, MOTIONKIT_OT_bone_map_scheme,
           MOTIONKIT_OT_bone_map_add, MOTIONKIT_OT_bone_map_remove, MOTIONKIT_OT_bone_map_save,
           MOTIONKIT_OT_bone_map_load)
