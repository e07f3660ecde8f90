"""A whole Blender session, run by test_ik.py in its own Blender: Live IK on, the file saved and opened
again, the target moved; prints LIVE <distance from the wrist's tail to the target> before and after."""
import os
import sys

import bpy
from mathutils import Vector

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import install_addon  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
zip_path, walk60, blend = args
install_addon.install(zip_path)
import motionkit as mk  # noqa: E402


def tail(obj, bone):
    bpy.context.view_layer.update()
    return obj.matrix_world @ obj.pose.bones[bone].tail


obj, action = mk.bvh.load(walk60, name="walker")
obj.animation_data.action = None  # a still pose: only Live moves it
goal = bpy.data.objects.new("Goal", None)
bpy.context.scene.collection.objects.link(goal)
goal.location = tail(obj, "lWrist") + Vector((-0.2, -0.2, 0.2))
item = obj.motionkit_ik.effectors.add()
item.bone, item.target = "lWrist", goal
obj.motionkit_ik.root_translation = obj.motionkit_ik.root_rotation = False
obj.motionkit_ik.live = True
bpy.context.view_layer.update()
print(f"LIVE before-save {(tail(obj, 'lWrist') - goal.location).length:.6f}")
bpy.ops.wm.save_as_mainfile(filepath=blend)
bpy.ops.wm.open_mainfile(filepath=blend)
obj, goal = bpy.data.objects["walker"], bpy.data.objects["Goal"]
print(f"LIVE toggle-after-open {obj.motionkit_ik.live}")
goal.location += Vector((0.05, -0.1, 0.1))
bpy.context.view_layer.update()
print(f"LIVE after-open {(tail(obj, 'lWrist') - goal.location).length:.6f}")
