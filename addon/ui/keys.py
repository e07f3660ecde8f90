"""Resample, Reduce, Filter Keys and Mirror Action: Graph Editor and Dope Sheet Key menus, and the MotionKit tab."""
import math

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from . import common
from ..blender import animdata
from ..core import filter_plan, resample_plan
from ..features import filters, mirror, resampling


def _targets(context):
    """(objects, bones): in pose mode the selected bones of each armature, else the selected objects."""
    if context.mode == 'POSE':
        bones = {}
        for pose_bone in context.selected_pose_bones or ():
            bones.setdefault(pose_bone.id_data.name, []).append(pose_bone.name)
        objects = [bpy.data.objects[name] for name in bones]
        return objects, bones
    objects = [obj for obj in (context.selected_objects or ()) if animdata.assigned_action(obj) is not None]
    return objects, None


def _poll(cls, context) -> bool:
    if not common.poll_native(cls):
        return False
    objects, _ = _targets(context)
    if not objects:
        cls.poll_message_set("Select animated objects, or bones in pose mode")
        return False
    return True


class _KeysOperator:
    """What Resample Keys and Reduce Keys share: poll, the dialog, and running on the targets."""

    @classmethod
    def poll(cls, context):
        return _poll(cls, context)

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def run(self, context, work, done_message):
        """work(objects, bones, progress) -> result; done_message(result) -> the report."""
        objects, bones = _targets(context)
        return common.run(self, context, lambda progress: work(objects, bones, progress), done_message)


class MOTIONKIT_OT_resample_keys(_KeysOperator, bpy.types.Operator):
    """Put the keys on a new frame step or frame rate, interpolating rotations on the quaternion sphere (MotionKit)"""
    bl_idname = "motionkit.resample_keys"
    bl_label = "Resample Keys"
    bl_options = {'REGISTER', 'UNDO'}

    timing: EnumProperty(name="Timing", items=[
        ('STEP', "Frame Step", "A key every N frames"),
        ('FPS', "Frame Rate", "Keys at a new frame rate")], default='FPS')
    step: FloatProperty(name="Step", description="Frames between keys", default=2.0, min=0.01, max=1e4)
    fps: FloatProperty(name="Frame Rate", description="The new frame rate", default=24.0, min=0.01, max=1e4)
    change_scene_rate: BoolProperty(
        name="Change Scene Frame Rate", default=True,
        description="Set the scene to the new rate and rescale frames; else keep it and space the keys")
    scalar: EnumProperty(name="Location/Scale", items=resample_plan.SCALAR_INTERPOLANTS, default="catmull-rom")
    rotation: EnumProperty(name="Rotation", items=resample_plan.ROTATION_INTERPOLANTS, default="squad")
    output: EnumProperty(name="Output", items=resample_plan.OUTPUTS, default='EXACT')
    tension: FloatProperty(name="Tension", default=0.0, min=-1.0, max=1.0)
    continuity: FloatProperty(name="Continuity", default=0.0, min=-1.0, max=1.0)
    bias: FloatProperty(name="Bias", default=0.0, min=-1.0, max=1.0)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "timing")
        if self.timing == 'STEP':
            layout.prop(self, "step")
        else:
            layout.prop(self, "fps")
            layout.column(heading="Scene").prop(self, "change_scene_rate", text="Change Rate")
        layout.prop(self, "scalar")
        layout.prop(self, "rotation")
        if "kochanek-bartels" in (self.scalar, self.rotation):
            col = layout.column(align=True)
            col.prop(self, "tension")
            col.prop(self, "continuity")
            col.prop(self, "bias")
        layout.prop(self, "output")

    def execute(self, context):
        return self.run(context, lambda objects, bones, progress: resampling.resample(
            objects, step=self.step if self.timing == 'STEP' else None,
            fps=self.fps if self.timing == 'FPS' else None, rotation=self.rotation, scalar=self.scalar,
            output=self.output, change_scene_rate=self.change_scene_rate, bones=bones,
            tension=self.tension, continuity=self.continuity, bias=self.bias,
            scene=context.scene, progress=progress),
            lambda actions: f"Resampled {', '.join(a.name for a in actions)}")


class MOTIONKIT_OT_reduce_keys(_KeysOperator, bpy.types.Operator):
    """Fit the fewest Bezier keys that stay within a tolerance of the current curves (MotionKit)"""
    bl_idname = "motionkit.reduce_keys"
    bl_label = "Reduce Keys"
    bl_options = {'REGISTER', 'UNDO'}

    tolerance: FloatProperty(name="Tolerance", description="Location, scale and other channels, in their units",
                             default=1e-3, min=1e-9, max=1e3, precision=5)
    rotation_tolerance: FloatProperty(name="Rotation Tolerance", subtype='ANGLE', default=math.radians(0.1),
                                      min=1e-9, max=math.pi, description="On the whole rotation, not per channel")
    samples_per_frame: IntProperty(name="Samples per Frame", default=4, min=1, max=64,
                                   description="How densely the tolerance is checked")
    space: EnumProperty(name="Space", default='CHANNELS', items=[
        ('CHANNELS', "Channels", "Each channel within its own tolerance"),
        ('WORLD', "World", "Every joint of an armature, and points along each bone's axes, within a distance "
                           "of where they were; other curves per channel")])
    distance: FloatProperty(name="Distance", subtype='DISTANCE', unit='LENGTH', default=1e-3, min=1e-9, max=1e3,
                            precision=4, description="How far any joint or axis point may move (scene units)")
    axis_length: FloatProperty(name="Axis Length", subtype='DISTANCE', unit='LENGTH', default=0.1, min=0.0,
                               max=1e3, description="How far along each bone's axes the checked points lie")

    def draw(self, context):
        layout = self.layout
        # As Blender draws an operator's properties itself: no keyframe decorators, whose column would
        # leave the labels too little room in the narrow redo panel.
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(self, "space")
        if self.space == 'WORLD':
            layout.prop(self, "distance")
            layout.prop(self, "axis_length")
        column = layout.column(heading="Other Curves" if self.space == 'WORLD' else "")
        column.prop(self, "tolerance")
        column.prop(self, "rotation_tolerance")
        layout.prop(self, "samples_per_frame")

    def execute(self, context):
        return self.run(context, lambda objects, bones, progress: resampling.reduce_keys(
            objects, self.tolerance, self.rotation_tolerance, samples_per_frame=self.samples_per_frame,
            bones=bones, progress=progress, space=self.space, distance=self.distance,
            axis_length=self.axis_length),
            lambda counts: f"Reduced {counts[0]} keys to {counts[1]}")


class MOTIONKIT_OT_filter_keys(_KeysOperator, bpy.types.Operator):
    """Filter the motion: low-pass, Gaussian, median or One-Euro, rotations on the quaternion sphere (MotionKit)"""
    bl_idname = "motionkit.filter_keys"
    bl_label = "Filter Keys"
    bl_options = {'REGISTER', 'UNDO'}

    kind: EnumProperty(name="Filter", items=filter_plan.FILTERS, default="butterworth")
    cutoff: FloatProperty(name="Cut-off", description="Hz, in the action's own frame rate",
                          default=filter_plan.MAYA_CUTOFF_HZ, min=1e-3, max=1e4)
    order: IntProperty(name="Order", default=4, min=1, max=8)
    sigma: FloatProperty(name="Sigma", description="Frames", default=1.0, min=1e-3, max=1e3)
    size: IntProperty(name="Window", description="Frames, odd", default=5, min=3, max=101, step=2)
    min_cutoff: FloatProperty(name="Min Cut-off", description="Hz, when still", default=1.0, min=1e-3, max=1e3)
    beta: FloatProperty(name="Speed Coefficient", description="How fast the cut-off rises with speed",
                        default=0.0, min=0.0, max=1e3)
    d_cutoff: FloatProperty(name="Speed Cut-off", description="Hz, of the speed estimate", default=1.0,
                            min=1e-3, max=1e3)
    keys: EnumProperty(name="Keys", items=filter_plan.KEYS, default="EVERY_FRAME")
    channels: EnumProperty(name="Channels", items=filter_plan.CHANNELS, default="ALL")
    use_range: BoolProperty(name="Scene Range", default=False, description="Only the scene's frame range")

    _PARAMETERS = {"butterworth": ("cutoff", "order"), "gaussian": ("sigma",), "median": ("size",),
                   "one_euro": ("min_cutoff", "beta", "d_cutoff"), "euler": ()}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "kind")
        for name in self._PARAMETERS[self.kind]:
            layout.prop(self, name)
        layout.prop(self, "channels")
        layout.prop(self, "keys")
        layout.prop(self, "use_range")

    def execute(self, context):
        scene = context.scene
        frame_range = (scene.frame_start, scene.frame_end) if self.use_range else None
        size = self.size if self.size % 2 else self.size + 1
        return self.run(context, lambda objects, bones, progress: filters.filter(
            objects, self.kind, cutoff=self.cutoff, order=self.order, sigma=self.sigma, size=size,
            min_cutoff=self.min_cutoff, beta=self.beta, d_cutoff=self.d_cutoff, bones=bones,
            frame_range=frame_range, keys=self.keys, channels=self.channels, progress=progress),
            lambda report: f"Filtered {report.curves} curves ({report.keys_before} keys, now {report.keys_after})")


class MOTIONKIT_OT_mirror_action(bpy.types.Operator):
    """Mirror the active armature's action left <-> right into a new action, bones paired by side (MotionKit)"""
    bl_idname = "motionkit.mirror_action"
    bl_label = "Mirror Action"
    bl_options = {'REGISTER', 'UNDO'}

    plane: EnumProperty(name="Plane", items=[(axis, f"{axis} = Offset", f"The armature's {axis} = offset plane")
                                             for axis in mirror.PLANES], default="X")
    plane_offset: FloatProperty(name="Offset", description="Where the plane crosses its axis, armature units",
                                default=0.0, subtype='DISTANCE')
    target: StringProperty(name="Onto", description="Another armature with the same bone names that plays the "
                           "mirrored action (empty: the active armature itself)")
    action_name: StringProperty(name="Action", description="The new action's name (empty: the action's, "
                                "with ' Mirrored')")
    use_range: BoolProperty(name="Scene Range", default=False, description="Only the scene's frame range")

    @classmethod
    def poll(cls, context):
        obj = common.poll_active_armature(cls, context)
        if obj is None:
            return False
        if animdata.assigned_action(obj) is None:
            cls.poll_message_set(f"'{obj.name}' has no action to mirror")
            return False
        return True

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "plane")
        layout.prop(self, "plane_offset")
        layout.prop_search(self, "target", bpy.data, "objects")
        layout.prop(self, "action_name")
        layout.prop(self, "use_range")

    def execute(self, context):
        scene = context.scene
        target = bpy.data.objects.get(self.target) if self.target else None
        if self.target and target is None:
            self.report({'ERROR'}, f"There is no object named '{self.target}'")
            return {'CANCELLED'}
        return common.run(self, context, lambda progress: mirror.mirror(
            context.active_object, plane=self.plane, plane_offset=self.plane_offset, target=target,
            action_name=self.action_name or None,
            frame_range=(scene.frame_start, scene.frame_end) if self.use_range else None, progress=progress),
            lambda report: f"Mirrored into '{report.action}': {len(report.pairs)} pairs, "
                           f"{len(report.centre)} centre bones, {len(report.kept_local)} kept local")


def menu_keys(self, context):
    layout = self.layout
    layout.separator()
    layout.operator(MOTIONKIT_OT_resample_keys.bl_idname, text="Resample Keys [MotionKit]")
    layout.operator(MOTIONKIT_OT_reduce_keys.bl_idname, text="Reduce Keys [MotionKit]")
    layout.operator(MOTIONKIT_OT_filter_keys.bl_idname, text="Filter Keys [MotionKit]")
    layout.operator(MOTIONKIT_OT_mirror_action.bl_idname, text="Mirror Action [MotionKit]")


MENUS = ("GRAPH_MT_key", "DOPESHEET_MT_key")


classes = (MOTIONKIT_OT_resample_keys, MOTIONKIT_OT_reduce_keys, MOTIONKIT_OT_filter_keys, MOTIONKIT_OT_mirror_action)
