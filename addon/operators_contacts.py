"""Fix foot sliding: the operator behind motionkit.contacts.plant (any armature's action).

Its thresholds (contact_props, shared with the Retarget panel) show in the redo panel (F9).
"""
import bpy

from . import contact_props, contacts, native_state, operator_runs


class MOTIONKIT_OT_fix_foot_sliding(bpy.types.Operator):
    """Detect foot contacts (or read the edited contact curves) and hold planted feet with full-body IK
    (MotionKit)"""
    bl_idname = "motionkit.fix_foot_sliding"
    bl_label = "Fix Foot Sliding"
    bl_options = {'REGISTER', 'UNDO'}

    __annotations__ = {
        "use_scene_range": bpy.props.BoolProperty(
            name="Scene Range", default=False,
            description="Hold contacts in the scene's frame range only (else the whole action)"),
        "redetect": bpy.props.BoolProperty(
            name="Detect Again", default=False,
            description="Detect contacts anew and replace the contact curves (else the curves are read when "
                        "the action has them)"),
        **contact_props.properties(),
    }

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
            lambda progress: contacts.plant(obj, frame_range, contact_props.settings(self), redetect=self.redetect),
            message)


def menu_pose(self, context):
    self.layout.operator(MOTIONKIT_OT_fix_foot_sliding.bl_idname)
