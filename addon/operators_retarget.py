"""Retarget and the bone map: the operators behind the MotionKit > Retarget panel."""
import os

import bpy
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from . import bone_mapping, bvh, contact_props, native_state, operator_runs, retargeting


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


def _poll_rigs(cls, context) -> bool:
    settings = _settings(context)
    why = _source_ready(settings) or ("" if settings.target is not None else "Pick a target armature")
    if why:
        cls.poll_message_set(why)
        return False
    return True


def _fill_map(operator, context, pairs_of) -> set:
    """Put pairs_of(settings) into the bone map, reporting how many."""
    settings = _settings(context)

    def fill(progress):
        pairs = pairs_of(settings)
        settings.set_bone_map(pairs)
        return pairs

    return operator_runs.run(operator, context, fill, lambda pairs: f"Mapped {len(pairs)} bones")


class MOTIONKIT_OT_retarget(bpy.types.Operator):
    """Retarget the source's motion onto the target armature as a new action (MotionKit)"""
    bl_idname = "motionkit.retarget"
    bl_label = "Retarget"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return native_state.poll_native(cls) and _poll_rigs(cls, context)

    def execute(self, context):
        settings = _settings(context)
        source = bpy.path.abspath(settings.bvh_path) if settings.source_kind == 'BVH' else settings.source
        frame_range = (settings.frame_start, settings.frame_end) if settings.use_frame_range else None

        def work(progress):
            progress(0, 1)
            return retargeting.retarget(
                source, settings.target, settings.bone_map() or None, frame_range, settings.root_motion,
                source_match=settings.source_match, match_frame=settings.match_frame,
                target_match=settings.target_match, ground=settings.ground, align_facing=settings.align_facing,
                floor_root=settings.floor_root, root_smoothing=settings.root_smoothing,
                plant_feet=settings.plant_feet, contact_settings=contact_props.settings(settings.contacts),
                overwrite=settings.overwrite)

        return operator_runs.run(self, context, work,
                                 lambda action: f"Retargeted onto '{settings.target.name}' as action '{action.name}'")


class MOTIONKIT_OT_bone_map_auto(bpy.types.Operator):
    """Fill the bone map from the bones' names and, where names say nothing, the skeletons (MotionKit)"""
    bl_idname = "motionkit.bone_map_auto"
    bl_label = "Auto-map"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _poll_rigs(cls, context)

    def execute(self, context):
        return _fill_map(self, context, lambda settings: bone_mapping.auto_map(
            _source_rig(settings), retargeting.mapping_rig(settings.target)))


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
        return _poll_rigs(cls, context)

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        return _fill_map(self, context, lambda settings: bone_mapping.map_from_presets(
            _source_rig(settings), self.source_scheme, retargeting.mapping_rig(settings.target), self.target_scheme))


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
        return operator_runs.run(self, context,
                                 lambda progress: bone_mapping.save_map(self.filepath, _settings(context).bone_map()),
                                 lambda _: "")


class MOTIONKIT_OT_bone_map_load(bpy.types.Operator, ImportHelper):
    """Load a bone map saved as a JSON preset"""
    bl_idname = "motionkit.bone_map_load"
    bl_label = "Load Bone Map"
    bl_options = {'REGISTER', 'UNDO'}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={'HIDDEN'})

    def execute(self, context):
        return _fill_map(self, context, lambda settings: bone_mapping.load_map(self.filepath))


classes = (MOTIONKIT_OT_retarget, MOTIONKIT_OT_bone_map_auto, MOTIONKIT_OT_bone_map_scheme,
           MOTIONKIT_OT_bone_map_add, MOTIONKIT_OT_bone_map_remove, MOTIONKIT_OT_bone_map_save,
           MOTIONKIT_OT_bone_map_load)
