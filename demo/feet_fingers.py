"""out/feet_fingers.png: feet on the floor and fists, before and after, on a real Mixamo character.

Y Bot (Mixamo's FBX through Blender's importer: centimetres, scaled 0.01,
turned 90 degrees) receives walk60 (a capture) and Mixamo's punch (an FBX
clip). "Before" is the retarget as it was: the hips at the source's height
above the floor scaled by the leg ratio and nothing else (floor_fit="off"),
and no finger in the bone map. "After" is the default. Top: a side view of the
left leg on a stance frame, source and targets, each with its own floor
line. Bottom: the left hand on the punch's tightest frame, seen across the
palm. Every point is Blender's own evaluation (frame_set, matrix_world @
pose_bone.head/tail).
"""
from __future__ import annotations

import os

import bpy
import mathutils
import numpy as np


def _points(obj, names, frame):
    bpy.context.scene.frame_set(int(frame))
    world = obj.matrix_world
    return {n: (np.array(world @ obj.pose.bones[n].head), np.array(world @ obj.pose.bones[n].tail)) for n in names}


def _floor(obj, feet):
    """The rig's floor in world Z: the capture's floor its importer recorded, else its rest soles."""
    recorded = obj.data.get("motionkit_floor")
    if recorded is not None:
        return (obj.matrix_world @ mathutils.Vector((0.0, 0.0, float(recorded)))).z
    world, z = obj.matrix_world, []
    for foot in feet:
        stack = [obj.data.bones[foot]]
        while stack:
            bone = stack.pop()
            stack += list(bone.children)
            z += [(world @ bone.head_local).z, (world @ bone.tail_local).z]
    return min(z)


def import_fbx(path, name):
    before = set(bpy.data.objects)
    bpy.ops.import_scene.fbx(filepath=path)
    added = [o for o in bpy.data.objects if o not in before]
    arm = next(o for o in added if o.type == 'ARMATURE')
    arm.name = name
    return arm, added


def _stance_frame(obj, foot, frames):
    """The frame where the foot's ankle is lowest and slowest: a stance frame."""
    heads = np.array([_points(obj, [foot], f)[foot][0] for f in frames])
    speed = np.linalg.norm(np.gradient(heads, axis=0), axis=1)
    score = (heads[:, 2] - heads[:, 2].min()) / max(np.ptp(heads[:, 2]), 1e-9) + speed / max(speed.max(), 1e-9)
    return int(frames[int(np.argmin(score))])


def _joints(obj, chain, frame):
    """World positions of a chain's joints (each bone's head; the last one's tail where it is no end bone
    of its own: an FBX import's tails need not lie anywhere), and the names."""
    names = [b for b in chain if b in obj.pose.bones]
    pts = _points(obj, names, frame)
    ends = [] if names[-1].endswith("_End") else [pts[names[-1]][1]]
    return np.array([pts[n][0] for n in names] + ends), names


def _leg_panel(ax, obj, chain, frame, title, color):
    """Side view of a leg's joints (hip, knee, ankle, ball, toe) with the rig's floor: bones drawn joint to
    joint, since an FBX import's bone tails need not lie on the next joint."""
    joints, names = _joints(obj, chain, frame)
    origin = joints[0]
    ax.plot(joints[:, 1] - origin[1], joints[:, 2], "-o", color=color, lw=3, ms=4)
    floor = _floor(obj, [names[2]])
    ax.axhline(floor, color="#555555", lw=1.5, ls="--")
    lowest = min(joints[2, 2], joints[3, 2])  # ankle and ball
    ax.set_title(f"{title}\nlowest of ankle and ball: {100 * (lowest - floor):+.1f} cm above its floor", fontsize=9)
    ax.set_aspect("equal")
    ax.set_xlabel("forward (m)")
    ax.set_ylabel("height (m)")


def _hand_panel(ax, obj, prefix, frame, title, color):
    """The left hand's fingers, joint to joint, seen across the palm (the plane of the hand and its middle
    finger, the index-to-pinky line as its width)."""
    chains = [[f"{prefix}LeftHand{f}{k}" for k in range(1, 5)] for f in ("Thumb", "Index", "Middle", "Ring", "Pinky")]
    hand = _points(obj, [prefix + "LeftHand"], frame)[prefix + "LeftHand"][0]
    heads = {c[0]: _points(obj, [c[0]], frame)[c[0]][0] for c in chains}
    along = heads[chains[2][0]] - hand
    along /= np.linalg.norm(along)
    width = heads[chains[1][0]] - heads[chains[4][0]]
    normal = np.cross(along, width)
    normal /= np.linalg.norm(normal)
    for chain in chains:
        joints = np.array([_points(obj, [n], frame)[n][0] for n in chain if n in obj.pose.bones])
        joints = np.vstack([hand, joints])  # the hand's head, then each joint up to the finger's end bone
        ax.plot((joints - hand) @ along, (joints - hand) @ normal, "-o", color=color, lw=2.5, ms=3)
    ax.set_title(title, fontsize=9)
    ax.set_aspect("equal")
    ax.set_xlabel("along the hand (m)")
    ax.set_ylabel("palm to back of the hand (m)")


def figure(motionkit, walk60: str, fbx_dir: str, path: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    made = []
    source, _ = motionkit.bvh.load(walk60, name="walk60 (feet)")
    made.append(source)
    before, added = import_fbx(os.path.join(fbx_dir, "ybot.fbx"), "YBot before")
    after, more = import_fbx(os.path.join(fbx_dir, "ybot.fbx"), "YBot after")
    made += added + more
    motionkit.retarget(source, before, floor_fit="off", plant_feet=False)
    motionkit.retarget(source, after)
    frame = _stance_frame(source, "lAnkle", np.arange(1, 183))
    fig, axes = plt.subplots(2, 3, figsize=(13, 8.5), constrained_layout=True)
    _leg_panel(axes[0, 0], source, ["lHip", "lKnee", "lAnkle", "lToeJoint"], frame,
               f"walk60 (capture), frame {frame}", "#1b9e77")
    leg = ["mixamorig:LeftUpLeg", "mixamorig:LeftLeg", "mixamorig:LeftFoot", "mixamorig:LeftToeBase",
           "mixamorig:LeftToe_End"]
    _leg_panel(axes[0, 1], before, leg, frame, "Y Bot before: hips scaled only", "#d95f02")
    _leg_panel(axes[0, 2], after, leg, frame, "Y Bot after: on its own floor", "#7570b3")

    punch_path = os.path.join(fbx_dir, "ybot@punch.fbx")
    fist_before, added = import_fbx(os.path.join(fbx_dir, "ybot.fbx"), "YBot fist before")
    fist_after, more = import_fbx(os.path.join(fbx_dir, "ybot.fbx"), "YBot fist after")
    made += added + more
    before_objects = set(bpy.data.objects)
    motionkit.retarget(punch_path, fist_after, imported_source="keep")
    punch = next(o for o in bpy.data.objects if o not in before_objects and o.type == 'ARMATURE')
    made.append(punch)
    pairs = [(a, b) for a, b in motionkit.retargeting.auto_map(punch, fist_before)
             if "Hand" not in a or a.endswith("Hand")]
    motionkit.retarget(punch, fist_before, bone_map=pairs)
    first, last = (int(v) for v in fist_after.animation_data.action.frame_range)
    index = "mixamorig:LeftHandIndex3"
    curl = []
    for f in range(first, last + 1):
        pts = _points(punch, ["mixamorig:LeftHand", index], f)
        hand = pts["mixamorig:LeftHand"]
        a, b = hand[1] - hand[0], pts[index][1] - pts[index][0]
        curl.append(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))
    fist = first + int(np.argmax(curl))
    _hand_panel(axes[1, 0], punch, "mixamorig:", fist, f"punch (FBX source), frame {fist}", "#1b9e77")
    _hand_panel(axes[1, 1], fist_before, "mixamorig:", fist, "Y Bot before: no finger mapped", "#d95f02")
    _hand_panel(axes[1, 2], fist_after, "mixamorig:", fist, "Y Bot after: every phalanx follows", "#7570b3")
    fig.suptitle("Feet on each rig's own floor (dashed) on a stance frame; the left hand on the punch's tightest "
                 "frame", fontsize=11)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    for obj in made:
        if obj.name in bpy.data.objects:
            bpy.data.objects.remove(obj)
