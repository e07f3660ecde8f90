"""A whole first session through the UI, as a user has it (run by test_ui.py in a window under Xvfb):

    blender --factory-startup --enable-event-simulate --python session.py -- ZIP WALK60 OUT_DIR

Every step is an operator invoked in the window's context with an undo step, as a click runs it: import
a BVH (the scene taking the clip's rate and range), retarget it onto a sample character, resample it, add
an IK effector and turn Live on by clicking its button, save, open the file again, move the target with
the viewport's own translate, check that the hand followed, undo, and check that both went back.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
from mathutils import Vector  # noqa: E402

import harness  # noqa: E402  (puts blend_samples/ on the path)
import generate  # noqa: E402

zip_path, walk60, out = sys.argv[sys.argv.index("--") + 1:]
mk = harness.start(zip_path)
watch = harness.watch_category("MotionKit")
HAND = "mixamorig:LeftHand"


def view():
    return harness.area('VIEW_3D')


def run(operator, *args, **props):
    """operator('EXEC_DEFAULT', undo=True, ...) in the 3D view, as Blender runs a click there."""
    with harness.override(area_=view()):
        result = operator('EXEC_DEFAULT', True, *args, **props)
    assert result == {'FINISHED'}, (operator, result)


def select_only(obj):
    for other in bpy.context.view_layer.objects:
        other.select_set(other == obj)
    bpy.context.view_layer.objects.active = obj


def hand_to_goal():
    bpy.context.view_layer.update()
    hero, goal = bpy.data.objects["MixamoT"], bpy.data.objects["Goal"]
    return (hero.matrix_world @ hero.pose.bones[HAND].tail - goal.matrix_world.translation).length


def steps():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    scene = bpy.context.scene
    generate.build_all(mk.animdata)
    hero = bpy.data.objects["MixamoT"]
    scene.render.fps, scene.frame_end = 24, 100  # a scene as a user starts with, slower than the capture
    yield 0.3

    run(bpy.ops.motionkit.import_bvh, filepath=walk60, update_scene_fps=True, update_scene_duration=True)
    capture = bpy.context.view_layer.objects.active
    harness.report("import.scene_rate", [scene.render.fps, scene.render.fps_base])
    harness.report("import.frames", [scene.frame_start, scene.frame_end])
    harness.report("import.bones_selected", all(mk.pose_channels.selected(capture)))
    yield 0.3

    scene.render.fps, scene.frame_start, scene.frame_end = 24, 1, 100  # as if the import had left them
    settings = scene.motionkit_retarget
    settings.source_kind, settings.source, settings.target = 'ARMATURE', capture, hero
    run(bpy.ops.motionkit.retarget)
    action = mk.animdata.assigned_action(hero)
    harness.report("retarget.action", action.name if action else None)
    harness.report("retarget.scene", [scene.render.fps, scene.frame_start, scene.frame_end,
                                      [round(v) for v in action.frame_range]])
    yield 0.3

    select_only(hero)
    run(bpy.ops.motionkit.resample_keys, timing='FPS', fps=30.0, change_scene_rate=True)
    harness.report("resample.scene_rate", scene.render.fps)
    curve = mk.animdata.fcurves(mk.animdata.assigned_action(hero), hero)[0]
    harness.report("resample.keys", len(curve.keyframe_points))
    yield 0.3

    # Full-body IK: the hand to a goal, Live on with a click on its button in the sidebar.
    goal = bpy.data.objects.new("Goal", None)
    scene.collection.objects.link(goal)
    scene.frame_set(scene.frame_start)
    goal.location = hero.matrix_world @ hero.pose.bones[HAND].tail + Vector((0.05, -0.15, 0.1))
    select_only(hero)
    run(bpy.ops.motionkit.list_edit, list="ik_effectors", action='ADD')
    effector = hero.motionkit_ik.effectors[-1]
    effector.bone, effector.target = HAND, goal
    yield from harness.show_sidebar(view())
    side = harness.region(view(), 'UI')
    yield from harness.open_tab(side, watch)
    words, _ = harness.read_region(os.path.join(out, "session-ik.png"), side)
    live = harness.find_words(words, "Live: Off")
    assert live, "no 'Live: Off' button on screen"
    yield from harness.click(live[0]["x"], live[0]["y"])
    yield from harness.wait_until(lambda: hero.motionkit_ik.live and hand_to_goal() < 1e-3,
                                  "Live to turn on and reach the goal", timeout=5.0, required=False)
    harness.report("ik.live_on", hero.motionkit_ik.live)
    harness.report("ik.reached", hand_to_goal())

    path = os.path.join(out, "session.blend")
    with harness.override():
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
    yield from harness.wait_until(lambda: "MixamoT" in bpy.data.objects and "Goal" in bpy.data.objects,
                                  "the saved file to open", timeout=10.0)
    hero, goal = bpy.data.objects["MixamoT"], bpy.data.objects["Goal"]
    harness.report("reopen.live_on", hero.motionkit_ik.live)

    select_only(goal)
    before = goal.location.copy()
    run(bpy.ops.transform.translate, value=(-0.05, 0.1, 0.08))
    yield from harness.wait_until(lambda: hand_to_goal() < 1e-3, "the hand to follow the goal", timeout=5.0,
                                  required=False)
    harness.report("move.goal_moved", (goal.location - before).length)
    harness.report("move.reached", hand_to_goal())
    # The viewport after the move, for a person to look at: nothing in it is read.
    moved = harness.screenshot(os.path.join(out, "session-moved-window.png"))
    harness.save_png(harness.crop(moved, harness.box_of(harness.region(view(), 'WINDOW'))),
                     os.path.join(out, "session-moved.png"))

    with harness.override(area_=view()):
        bpy.ops.ed.undo()
    yield from harness.wait_until(lambda: (bpy.data.objects["Goal"].location - before).length < 1e-6
                                  and hand_to_goal() < 1e-3, "the undo to put goal and hand back", timeout=5.0,
                                  required=False)
    goal = bpy.data.objects["Goal"]
    harness.report("undo.goal_back", (goal.location - before).length)
    harness.report("undo.reached", hand_to_goal())


harness.run(steps())
