"""Full-body IK operators behind the MotionKit > Full-body IK panel."""
import bpy

from . import ik, native_state, operator_runs


def _armature(context):
    obj = context.object
    return obj if obj is not None and obj.type == 'ARMATURE' else None


def _poll_effectors(cls, context) -> bool:
    if not native_state.poll_native(cls):
        return False
    obj = _armature(context)
    if obj is None:
        cls.poll_message_set("Select an armature")
        return False
    if not any(e.bone for e in obj.motionkit_ik.effectors):
        cls.poll_message_set("Add an effector")
        return False
    return True


class MOTIONKIT_OT_ik_solve(bpy.types.Operator):
    """Solve full-body IK on the current frame and pose the armature (MotionKit)"""
    bl_idname = "motionkit.ik_solve"
    bl_label = "Solve"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _poll_effectors(cls, context)

    def execute(self, context):
        obj = _armature(context)
        settings = obj.motionkit_ik
        return operator_runs.run(
            self, context,
            lambda progress: ik.solve(obj, settings.effector_list(), None, settings.method, **settings.options()),
            lambda result: f"Solved in {int(result.iterations[0])} iterations, largest error "
                           f"{result.errors.max():.2e}")


class MOTIONKIT_OT_ik_bake(bpy.types.Operator):
    """Solve full-body IK on every frame of a range and key the solved bones (MotionKit)"""
    bl_idname = "motionkit.ik_bake"
    bl_label = "Bake"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _poll_effectors(cls, context)

    def execute(self, context):
        obj = _armature(context)
        settings = obj.motionkit_ik
        scene = context.scene
        frame_range = ((scene.frame_start, scene.frame_end) if settings.use_scene_range
                       else (settings.frame_start, settings.frame_end))

        def bake(progress):
            progress(0, 1)
            return ik.bake(obj, settings.effector_list(), frame_range, settings.method,
                           new_action=settings.new_action, **settings.options())

        return operator_runs.run(
            self, context, bake,
            lambda done: f"Baked {len(done[0].frames)} frames of {len(done[0].bones)} bones into "
                         f"'{done[1].name}'; largest error {done[0].errors.max():.2e}")


class MOTIONKIT_OT_ik_effector_add(bpy.types.Operator):
    """Add an effector (on the active bone in pose mode)"""
    bl_idname = "motionkit.ik_effector_add"
    bl_label = "Add Effector"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        if _armature(context) is None:
            cls.poll_message_set("Select an armature")
            return False
        return True

    def execute(self, context):
        settings = _armature(context).motionkit_ik
        item = settings.effectors.add()
        if context.active_pose_bone is not None:
            item.bone = context.active_pose_bone.name
        settings.active_effector = len(settings.effectors) - 1
        return {'FINISHED'}


class MOTIONKIT_OT_ik_effector_remove(bpy.types.Operator):
    """Remove the selected effector"""
    bl_idname = "motionkit.ik_effector_remove"
    bl_label = "Remove Effector"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = _armature(context)
        if obj is None or not 0 <= obj.motionkit_ik.active_effector < len(obj.motionkit_ik.effectors):
            cls.poll_message_set("Select an effector")
            return False
        return True

    def execute(self, context):
        settings = _armature(context).motionkit_ik
        settings.effectors.remove(settings.active_effector)
        settings.active_effector = min(settings.active_effector, len(settings.effectors) - 1)
        return {'FINISHED'}


classes = (MOTIONKIT_OT_ik_solve, MOTIONKIT_OT_ik_bake, MOTIONKIT_OT_ik_effector_add,
           MOTIONKIT_OT_ik_effector_remove)
