"""Fix foot sliding: the operator behind motionkit.contacts.plant (any armature's action).

Registered by the add-on's class list; its thresholds show in the redo panel (F9).
"""
import bpy

from . import contacts, native_state, operator_runs
from .foot_contacts import ContactSettings

_DEFAULTS = ContactSettings()


class MOTIONKIT_OT_fix_foot_sliding(bpy.types.Operator):
    """Detect foot contacts (or read the edited contact curves) and hold planted feet with full-body IK
    (MotionKit)"""
    bl_idname = "motionkit.fix_foot_sliding"
    bl_label = "Fix Foot Sliding"
    bl_options = {'REGISTER', 'UNDO'}

    use_scene_range: bpy.props.BoolProperty(
        name="Scene Range", default=False,
        description="Hold contacts in the scene's frame range only (else the whole action)")
    redetect: bpy.props.BoolProperty(
        name="Detect Again", default=False,
        description="Detect contacts anew and replace the contact curves (else the curves are read when "
                    "the action has them)")
    height_enter: bpy.props.FloatProperty(
        name="Height", default=_DEFAULTS.height_enter, min=0.001, max=1.0, precision=3,
        description="A point enters a contact this close to its standing height (leg lengths)")
    height_leave: bpy.props.FloatProperty(
        name="Height to Leave", default=_DEFAULTS.height_leave, min=0.001, max=1.0, precision=3,
        description="...and leaves it higher than this (leg lengths)")
    speed_enter: bpy.props.FloatProperty(
        name="Speed", default=_DEFAULTS.speed_enter, min=0.001, max=10.0, precision=3,
        description="A point enters a contact slower than this (leg lengths per second)")
    speed_leave: bpy.props.FloatProperty(
        name="Speed to Leave", default=_DEFAULTS.speed_leave, min=0.001, max=10.0, precision=3,
        description="...and leaves it faster than this (leg lengths per second)")
    min_length: bpy.props.FloatProperty(
        name="Shortest Contact", default=_DEFAULTS.min_length, min=0.0, max=2.0, precision=3, unit='TIME_ABSOLUTE',
        description="Contacts shorter than this (seconds) are ignored")
    blend: bpy.props.FloatProperty(
        name="Blend", default=_DEFAULTS.blend, min=0.001, max=2.0, precision=3, unit='TIME_ABSOLUTE',
        description="How long (seconds) the feet take to ease into and out of a plant")

    @classmethod
    def poll(cls, context):
        if not native_state.poll_native(cls):
            return False
        obj = context.object
        if obj is None or obj.type != 'ARMATURE' or obj.animation_data is None \
                or obj.animation_data.action is None:
            cls.poll_message_set("Select an armature with an action")
            return False
        return True

    def settings(self) -> ContactSettings:
        return ContactSettings(height_enter=self.height_enter,
                               height_leave=max(self.height_leave, self.height_enter),
                               speed_enter=self.speed_enter, speed_leave=max(self.speed_leave, self.speed_enter),
                               min_length=self.min_length, blend=self.blend)

    def execute(self, context):
        obj = context.object
        scene = context.scene
        frame_range = (scene.frame_start, scene.frame_end) if self.use_scene_range else None

        def message(report):
            count = sum(len(runs) for runs in report.intervals)
            return (f"Held {count} foot contacts ({report.source}) on '{obj.name}' in "
                    f"{report.seconds * 1000:.0f} ms, largest miss {report.max_error.max():.2e}")

        return operator_runs.run(
            self, context,
            lambda progress: contacts.plant(obj, frame_range, self.settings(), redetect=self.redetect),
            message)


def menu_pose(self, context):
    self.layout.operator(MOTIONKIT_OT_fix_foot_sliding.bl_idname)
