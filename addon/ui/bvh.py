"""File > Import/Export > Motion Capture (.bvh) [MotionKit], with the file browser's options grouped in
sub-panels as Blender's own importers group theirs."""
import time

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper, orientation_helper

from . import common
from ..features import bvh

_ROTATION_ITEMS = [
    ('QUATERNION', "Quaternion", "Keys rotation_quaternion: no gimbal lock"),
    ('NATIVE', "Euler (Native)", "Each bone takes the rotation order of its BVH joint"),
] + [(mode, f"Euler ({mode})", f"Keys rotation_euler in Blender's {mode} mode, continuous")
     for mode in ('XYZ', 'XZY', 'YXZ', 'YZX', 'ZXY', 'ZYX')]

_ORDER_ITEMS = [('NATIVE', "Native", "Each Euler bone's own order; ZXY for the others")] + [
    (order, order, f"Channels {' '.join(a + 'rotation' for a in order)}")
    for order in ('XYZ', 'XZY', 'YXZ', 'YZX', 'ZXY', 'ZYX')]


@orientation_helper(axis_forward='-Z', axis_up='Y')
class MOTIONKIT_OT_import_bvh(bpy.types.Operator, ImportHelper):
    """Import a BVH motion capture file as an armature with one key per frame (MotionKit)"""
    bl_idname = "motionkit.import_bvh"
    bl_label = "Import BVH"
    bl_options = {'REGISTER', 'UNDO'}

    filename_ext = ".bvh"
    filter_glob: StringProperty(default="*.bvh", options={'HIDDEN'})
    scale: FloatProperty(name="Scale", description="Multiply the file's distances by this",
                         default=1.0, min=1e-6, max=1e6)
    rotation_mode: EnumProperty(name="Rotation", items=_ROTATION_ITEMS, default='QUATERNION')
    frame_start: IntProperty(name="Start Frame", description="Frame of the file's first frame", default=1)
    use_fps_scale: BoolProperty(name="Scale to Scene FPS",
                                description="Place keys by the file's frame time at the scene's frame rate")
    update_scene_fps: BoolProperty(name="Use File's Frame Rate",
                                   description="Set the scene's frame rate to the file's")
    update_scene_duration: BoolProperty(name="Update Scene Duration",
                                        description="Extend the scene's frame range to the clip")

    @classmethod
    def poll(cls, context):
        return common.poll_native(cls)

    def draw(self, context):
        pass  # the sub-panels below draw the options

    def execute(self, context):
        wm = context.window_manager
        wm.progress_begin(0, 2)
        started = time.perf_counter()
        try:
            options = bvh.ImportOptions(
                scale=self.scale, axis_forward=self.axis_forward, axis_up=self.axis_up,
                rotation_mode=self.rotation_mode, frame_start=self.frame_start,
                use_fps_scale=self.use_fps_scale, update_scene_fps=self.update_scene_fps,
                update_scene_duration=self.update_scene_duration)
            wm.progress_update(1)
            obj, action = bvh.load(self.filepath, options, context=context)
        except (ValueError, OSError, RuntimeError) as ex:
            self.report({'ERROR'}, str(ex))
            return {'CANCELLED'}
        finally:
            wm.progress_end()
        for other in context.view_layer.objects:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        self.report({'INFO'}, f"Imported {obj.name}: {len(obj.data.bones)} bones, "
                              f"{int(action.frame_range[1] - action.frame_range[0]) + 1} frames "
                              f"in {time.perf_counter() - started:.2f} s")
        return {'FINISHED'}


@orientation_helper(axis_forward='-Z', axis_up='Y')
class MOTIONKIT_OT_export_bvh(bpy.types.Operator, ExportHelper):
    """Export the active armature's animation as a BVH motion capture file (MotionKit)"""
    bl_idname = "motionkit.export_bvh"
    bl_label = "Export BVH"
    bl_options = {'REGISTER'}

    filename_ext = ".bvh"
    filter_glob: StringProperty(default="*.bvh", options={'HIDDEN'})
    scale: FloatProperty(name="Scale", description="Multiply distances by this in the file",
                         default=1.0, min=1e-6, max=1e6)
    rotation_order: EnumProperty(name="Rotation Order", items=_ORDER_ITEMS, default='NATIVE')
    frame_start: IntProperty(name="Start Frame", default=-1,
                             description="First frame to write (-1: the scene's)")
    frame_end: IntProperty(name="End Frame", default=-1,
                           description="Last frame to write (-1: the scene's)")

    def draw(self, context):
        pass  # the sub-panels below draw the options

    @classmethod
    def poll(cls, context):
        return common.poll_active_armature(cls, context) is not None

    def execute(self, context):
        scene = context.scene
        start = scene.frame_start if self.frame_start < 0 else self.frame_start
        end = scene.frame_end if self.frame_end < 0 else self.frame_end
        wm = context.window_manager
        wm.progress_begin(0, 1)
        try:
            bvh.save(context.active_object, self.filepath, bvh.ExportOptions(
                scale=self.scale, axis_forward=self.axis_forward, axis_up=self.axis_up,
                rotation_order=self.rotation_order, frame_range=(start, end)), context=context)
        except (ValueError, OSError, RuntimeError) as ex:
            self.report({'ERROR'}, str(ex))
            return {'CANCELLED'}
        finally:
            wm.progress_end()
        self.report({'INFO'}, f"Exported frames {start}-{end} to {self.filepath}")
        return {'FINISHED'}


class _FileOptions:
    """One group of a MotionKit file operator's options in the file browser's side panel."""
    bl_space_type = 'FILE_BROWSER'
    bl_region_type = 'TOOL_PROPS'
    bl_parent_id = "FILE_PT_operator"
    operator_class = None
    groups: tuple = ()  # (heading or "", ((property, label or None), ...)), ...

    @classmethod
    def poll(cls, context):
        operator = context.space_data.active_operator
        return operator is not None and operator.bl_idname == cls.operator_class.__name__

    def draw(self, context):
        common.draw_groups(common.split_layout(self.layout), context.space_data.active_operator, self.groups)


class MOTIONKIT_PT_import_bvh_transform(_FileOptions, bpy.types.Panel):
    bl_label = "Transform"
    operator_class = MOTIONKIT_OT_import_bvh
    groups = (("", (("scale", None), ("axis_forward", None), ("axis_up", None))),)


class MOTIONKIT_PT_import_bvh_animation(_FileOptions, bpy.types.Panel):
    bl_label = "Animation"
    operator_class = MOTIONKIT_OT_import_bvh
    groups = (("", (("rotation_mode", None), ("frame_start", None))),
              ("Keys", (("use_fps_scale", "At Scene Rate"),)))


class MOTIONKIT_PT_import_bvh_scene(_FileOptions, bpy.types.Panel):
    bl_label = "Scene"
    operator_class = MOTIONKIT_OT_import_bvh
    groups = (("From Clip", (("update_scene_fps", "Frame Rate"), ("update_scene_duration", "Frame Range"))),)


class MOTIONKIT_PT_export_bvh_transform(_FileOptions, bpy.types.Panel):
    bl_label = "Transform"
    operator_class = MOTIONKIT_OT_export_bvh
    groups = (("", (("scale", None), ("axis_forward", None), ("axis_up", None))),)


class MOTIONKIT_PT_export_bvh_animation(_FileOptions, bpy.types.Panel):
    bl_label = "Animation"
    operator_class = MOTIONKIT_OT_export_bvh
    groups = (("", (("rotation_order", "Order"), ("frame_start", "Start"), ("frame_end", "End"))),)


def menu_import(self, context):
    self.layout.operator(MOTIONKIT_OT_import_bvh.bl_idname, text=MENU_LABEL)


def menu_export(self, context):
    self.layout.operator(MOTIONKIT_OT_export_bvh.bl_idname, text=MENU_LABEL)


MENU_LABEL = "Motion Capture (.bvh) [MotionKit]"

classes = (MOTIONKIT_OT_import_bvh, MOTIONKIT_OT_export_bvh, MOTIONKIT_PT_import_bvh_transform,
           MOTIONKIT_PT_import_bvh_animation, MOTIONKIT_PT_import_bvh_scene, MOTIONKIT_PT_export_bvh_transform,
           MOTIONKIT_PT_export_bvh_animation)
