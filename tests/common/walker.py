"""walk60's skeleton in its rest pose, for the Blender tests that solve on a still body."""
import bpy


def still_walker(mk, walk60, name="walker"):
    """walk60's skeleton standing in its rest (T) pose, no action."""
    obj, action = mk.bvh.load(walk60, name=name)
    obj.animation_data.action = None
    bpy.data.actions.remove(action)
    for pose_bone in obj.pose.bones:
        pose_bone.location = (0, 0, 0)
        pose_bone.rotation_quaternion = (1, 0, 0, 0)
    bpy.context.view_layer.update()
    return obj
