"""Reachable targets are met to 1e-6 m, with a humanoid's natural defaults and without them, judged by
Blender's own evaluation of the keyed result (frame_set, pose_bone.tail, matrix_world).

The targets are a capture's own toe paths, and the input pose is the same capture fifteen frames
later: the capture itself is a solution, so every target is reachable. With natural defaults the
frames are those whose capture pose lies inside the default joint ranges (on walk_and_turn_left,
frames 25-40 and 87-100 bend an ankle past its 40 degrees: no pose within the ranges reaches them).
A single arm chain is compared with Blender's own IK constraint on the same case.
"""
import os

import bpy
import numpy as np
import pytest
from mathutils import Vector
from walker import still_walker

REACHED = 1e-6  # metres
SHIFT = 15  # frames between the input pose and the targets' capture pose


@pytest.fixture()
def turning_walk(shared_dir):
    return os.path.join(shared_dir, "data", "bvh", "more", "walk_and_turn_left.bvh")


def toe_tails(obj, toes, frames):
    """(frames, toes, 3) world positions of the toes' tails, as Blender evaluates them."""
    scene = bpy.context.scene
    out = np.empty((len(frames), len(toes), 3))
    for i, frame in enumerate(frames):
        scene.frame_set(int(frame))
        for k, toe in enumerate(toes):
            out[i, k] = obj.matrix_world @ obj.pose.bones[toe].tail
    return out


def walk_in_place(obj, action, animdata):
    """Holds the root's horizontal location at its first key: the toes then stay within a metre of the
    origin, where Blender's float keys and matrices round a position to well under a micrometre (at the
    clip's farthest, four metres out, they round it by up to one)."""
    root = obj.data.bones[0]
    # The root's location channel is in its own rest frame: the axis nearest the armature's Z is up.
    up = int(np.argmax(np.abs(np.array(root.matrix_local.to_3x3())[2])))
    for fcurve in animdata.fcurves(action, obj):
        if fcurve.data_path == f'pose.bones["{root.name}"].location' and fcurve.array_index != up:
            co = np.empty(2 * len(fcurve.keyframe_points))
            fcurve.keyframe_points.foreach_get("co", co)
            co[1::2] = co[1]
            fcurve.keyframe_points.foreach_set("co", co)
            fcurve.keyframe_points.foreach_set("handle_left", co)
            fcurve.keyframe_points.foreach_set("handle_right", co)
            fcurve.update()


def shifted_copy(obj, action, frames, animdata):
    """A copy of action whose keys play `frames` earlier."""
    copy = action.copy()
    for fcurve in animdata.fcurves(copy, obj):
        co = np.empty(2 * len(fcurve.keyframe_points))
        fcurve.keyframe_points.foreach_get("co", co)
        co[0::2] -= frames
        fcurve.keyframe_points.foreach_set("co", co)
        handles = np.empty_like(co)
        for side in ("handle_left", "handle_right"):
            fcurve.keyframe_points.foreach_get(side, handles)
            handles[0::2] -= frames
            fcurve.keyframe_points.foreach_set(side, handles)
        fcurve.update()
    return copy


@pytest.mark.parametrize("natural, first, last", [(False, 1, 300), (True, 101, 300)],
                         ids=["plain", "natural"])
def test_toes_on_their_own_paths_are_met_to_a_micrometre(mk, animdata, turning_walk, natural, first, last):
    obj, action = mk.bvh.load(turning_walk, scale=1.0)
    toes = [bone.name for bone in obj.data.bones if "Toe" in bone.name]
    assert len(toes) == 2, toes
    walk_in_place(obj, action, animdata)
    frames = np.arange(first, last + 1)
    targets = toe_tails(obj, toes, frames)
    animdata.assign(obj, shifted_copy(obj, action, SHIFT, animdata))
    mk.ik.solve(obj, [mk.ik.Effector(toe, target=targets[:, k]) for k, toe in enumerate(toes)], (first, last),
                natural=natural)
    errors = np.linalg.norm(toe_tails(obj, toes, frames) - targets, axis=2).max(axis=1)
    worst = int(np.argmax(errors))
    print(f"\nnatural={natural}: median {np.median(errors) * 1e6:.3f} um, worst {errors[worst] * 1e6:.3f} um "
          f"at frame {frames[worst]}")
    assert errors[worst] < REACHED, f"frame {frames[worst]}: {errors[worst] * 1e6:.2f} um"


@pytest.mark.parametrize("natural", [False, True], ids=["plain", "natural"])
def test_an_arm_chain_meets_its_target_as_near_as_blenders_constraint(mk, walk60, natural):
    obj = still_walker(mk, walk60)
    goal = bpy.data.objects.new("Goal", None)
    bpy.context.scene.collection.objects.link(goal)
    # In front of the chest and below the shoulder: within the arm's reach and a person's joint ranges.
    goal.location = obj.matrix_world @ obj.pose.bones["lWrist"].tail + Vector((-0.25, -0.2, 0.3))
    constraint = obj.pose.bones["lWrist"].constraints.new('IK')
    constraint.target = goal
    constraint.chain_count = 4
    bpy.context.view_layer.update()
    theirs = (obj.matrix_world @ obj.pose.bones["lWrist"].tail - goal.location).length
    obj.pose.bones["lWrist"].constraints.remove(constraint)
    mk.ik.solve(obj, [mk.ik.Effector("lWrist", target=goal, chain_count=4)], root_translation=False,
                root_rotation=False, natural=natural)
    bpy.context.view_layer.update()
    ours = (obj.matrix_world @ obj.pose.bones["lWrist"].tail - goal.location).length
    print(f"\nnatural={natural}: Blender's IK constraint {theirs * 1e6:.3f} um, MotionKit {ours * 1e6:.3f} um")
    assert ours < REACHED
    assert ours <= max(theirs, 0.2 * REACHED)


# The arm's reach that the natural ranges allow (docs/ik.md): the elbow bends 0 to 150 degrees, the
# upper arm swings freely (only its twist is ranged) and the wrist bends 70 either way, so the hand's tail
# can lie anywhere from the shoulder at distances between the folded arm's and the straight arm's.
ELBOW_MOST = np.radians(150.0)
REACH_SHARE = 0.8
# Directions from the shoulder, in the walker's own frame (-Y forward, +X its left, +Z up): ahead, ahead
# and up, out to the side, ahead and down.
DIRECTIONS = np.array([[0.0, -1.0, 0.0], [0.3, -0.7, 0.6], [1.0, -0.2, 0.0], [0.2, -0.8, -0.5]])


def arm_reach(obj):
    """(shortest, longest) distance from lShoulder's head to lWrist's tail within the ranges, from the
    bones' lengths: straight (elbow at 0), and folded (elbow at 150 degrees, the wrist straight)."""
    upper = obj.data.bones["lShoulder"].length
    lower = obj.data.bones["lElbow"].length + obj.data.bones["lWrist"].length
    folded = np.sqrt(upper ** 2 + lower ** 2 - 2 * upper * lower * np.cos(np.pi - ELBOW_MOST))
    return folded, upper + lower


# Ahead and up, frame 25 ends 10.7 um from its target (Blender 3.4; the others within 0.9 um): not met to
# 1e-6 m yet. Strict: the test turns red once it is met, so that the mark goes.
UP_MISSED = pytest.mark.xfail(strict=True, reason="walk60 frame 25: the hand stops 10.7 um short (issue 36)")


@pytest.mark.parametrize("direction", [0, pytest.param(1, marks=UP_MISSED), 2, 3], ids=["ahead", "up", "side", "down"])
def test_a_hand_at_80_percent_of_its_reach_is_met_with_the_toes_pinned(mk, walk60, direction):
    """walk60 playing, both toes pinned, natural defaults (balance on): the left hand's target at 80 % of
    the reach the ranges allow from the shoulder as the capture has it on each frame. A pose within the
    ranges meets it (the elbow bent to the law of cosines' angle, inside 0-150 degrees, the upper arm
    turned onto the line), so the hand must be on it, in Blender's evaluation."""
    obj, _ = mk.bvh.load(walk60, name="reacher")
    folded, straight = arm_reach(obj)
    assert folded < REACH_SHARE * straight, "the target lies within the ranges' reach"
    frames = np.arange(1, 31)
    scene = bpy.context.scene
    world = np.array(obj.matrix_world)
    shoulders = []
    for f in frames:
        scene.frame_set(int(f))
        shoulders.append(tuple(obj.matrix_world @ obj.pose.bones["lShoulder"].head))
    unit = DIRECTIONS[direction] / np.linalg.norm(DIRECTIONS[direction])
    scale = np.linalg.norm(world[:3, 0])
    targets = np.array(shoulders) + REACH_SHARE * straight * scale * (world[:3, :3] / scale @ unit)
    mk.ik.solve(obj, [mk.ik.Effector("lToeJoint", pin=True, orientation=True),
                      mk.ik.Effector("rToeJoint", pin=True, orientation=True),
                      mk.ik.Effector("lWrist", target=targets)], (1, 30))
    errors = np.empty(frames.size)
    for i, f in enumerate(frames):
        scene.frame_set(int(f))
        errors[i] = np.linalg.norm(np.array(obj.matrix_world @ obj.pose.bones["lWrist"].tail) - targets[i])
    worst = int(np.argmax(errors))
    print(f"\n80 % of the reach, {['ahead', 'up', 'side', 'down'][direction]}: median {np.median(errors) * 1e6:.3f} um, "
          f"worst {errors[worst] * 1e6:.3f} um at frame {frames[worst]}")
    assert errors[worst] < REACHED, f"frame {frames[worst]}: {errors[worst] * 1e3:.3f} mm"
