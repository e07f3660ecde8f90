"""A game rig's IK bones keyed to follow the hands and feet: Unreal's mannequin layout
(ik_foot_root with ik_foot_l/r, ik_hand_root with ik_hand_gun and ik_hand_l/r under it) added to the
Unreal-named sample, a capture retargeted onto it, judged by Blender's evaluation: each IK bone moves
rigidly with the bone it stands for (its pose times its rest's inverse equals that bone's) on every frame."""
import dataclasses

import bpy
import numpy as np

import characters
import generate
from rotations import matrix_angles

# Two float32 armature matrices composed through a chain of four to seven bones and compared: measured at
# most 2.2e-5 degrees and 8e-7 of the height (Blender 3.4, 4.3, 5.2); about ten times.
TURN_DEG = 2e-4
MOVE = 8e-6


def _unreal_with_ik_bones():
    spec = characters.UNREAL_A
    at = {b.canonical: b for b in spec.bones}
    root = at["root"].name
    up = lambda p: (p[0], p[1], p[2] + 0.1)  # noqa: E731
    bones = [characters.BoneSpec("ik_foot_root", "ik", root, (0, 0, 0), (0, 0, 0.1), 0.0),
             characters.BoneSpec("ik_hand_root", "ik", root, (0, 0, 0), (0, 0, 0.1), 0.0)]
    for side, s in (("L", "l"), ("R", "r")):
        foot = at[f"foot.{side}"]
        bones.append(characters.BoneSpec(f"ik_foot_{s}", "ik", "ik_foot_root", foot.head, foot.tail, foot.roll))
    hand_r = at["hand.R"]
    bones.append(characters.BoneSpec("ik_hand_gun", "ik", "ik_hand_root", hand_r.head, up(hand_r.head), 0.0))
    for side, s in (("L", "l"), ("R", "r")):
        hand = at[f"hand.{side}"]
        bones.append(characters.BoneSpec(f"ik_hand_{s}", "ik", "ik_hand_gun", hand.head, hand.tail, hand.roll))
    return dataclasses.replace(spec, bones=spec.bones + tuple(bones))


def test_ik_bones_follow_the_hands_and_feet(mk, walk60):
    source, _ = mk.bvh.load(walk60)
    spec = _unreal_with_ik_bones()
    target = generate.build_armature(spec)
    mk.retarget(source, target)
    at = {b.canonical: b.name for b in spec.bones}
    followed = {"ik_foot_l": at["foot.L"], "ik_foot_r": at["foot.R"], "ik_hand_gun": at["hand.R"],
                "ik_hand_l": at["hand.L"], "ik_hand_r": at["hand.R"]}
    height = max(b.tail[2] for b in spec.bones)
    worst_turn = worst_move = 0.0
    moved = 0.0
    for frame in range(1, 182, 9):
        bpy.context.scene.frame_set(frame)
        for ik, bone in followed.items():
            mine = np.array(target.pose.bones[ik].matrix) @ np.linalg.inv(np.array(target.data.bones[ik].matrix_local))
            theirs = np.array(target.pose.bones[bone].matrix) @ np.linalg.inv(
                np.array(target.data.bones[bone].matrix_local))
            worst_turn = max(worst_turn, float(np.degrees(matrix_angles(mine, theirs))))
            worst_move = max(worst_move, float(np.linalg.norm(mine[:3, 3] - theirs[:3, 3])) / height)
            moved = max(moved, float(np.linalg.norm(np.array(target.pose.bones[ik].head)
                                                    - np.array(target.data.bones[ik].head_local))))
    print(f"\nIK bones on their hands and feet: worst {worst_turn:.1e} deg, {worst_move:.1e} of the height")
    assert moved > 0.1 * height  # they travel with the body: not left at rest
    assert worst_turn < TURN_DEG and worst_move < MOVE
