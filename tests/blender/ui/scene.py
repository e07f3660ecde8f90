"""The scene the UI scenarios work in, as a user has it after a few minutes: the sample characters, a
motion capture imported, a bone map filled from it to the T-pose Mixamo-named character (the longest
names), and IK effectors on that character (a hand to a goal, both feet pinned)."""
import bpy
from mathutils import Vector

import generate


def build(mk, walk60: str) -> dict:
    for obj in list(bpy.data.objects):  # the startup file's cube, camera and light
        bpy.data.objects.remove(obj)
    rigs = generate.build_all(mk.animdata)
    capture, _ = mk.bvh.load(walk60, name="walk60")
    capture.location.x = -3.0
    target = rigs["MixamoT"]
    settings = bpy.context.scene.motionkit_retarget
    settings.source_kind, settings.source, settings.target = 'ARMATURE', capture, target
    settings.set_bone_map(mk.retargeting.auto_map(capture, target))

    goal = bpy.data.objects.new("Goal", None)
    bpy.context.scene.collection.objects.link(goal)
    goal.location = target.matrix_world @ target.pose.bones["mixamorig:LeftHand"].tail + Vector((0.1, -0.2, 0.15))
    effectors = target.motionkit_ik.effectors
    for bone, pin in (("mixamorig:LeftHand", False), ("mixamorig:LeftFoot", True),
                      ("mixamorig:RightFoot", True)):
        item = effectors.add()
        item.bone, item.pin = bone, pin
        if not pin:
            item.target = goal
    target.motionkit_ik.active_effector = 0
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj == target)
    bpy.context.view_layer.objects.active = target
    return {"capture": capture, "target": target, "goal": goal, **rigs}
