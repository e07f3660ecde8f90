"""The Rigify cases of tests/blender/test_control_rigs.py over every clip, with FK and with legs in IK
(the Blender suite keeps walk60 with legs in IK): the same checks and the same bounds."""
import os

import pytest

from control_rig_checks import (NECK_DEG, SLIDE_M, STANCE_FRAMES, append, check_turns, keyed_bones,
                                rigify_feet_slide, rigify_neck_and_head, rigify_turns)
from control_rig_checks import rigify_file  # noqa: F401  (a fixture)

CLIPS = ("bvh/walk60.bvh", "bvh/more/walk_and_turn_left.bvh")
CASES = [(clip, controls) for clip in CLIPS for controls in ("fk", "auto")]


@pytest.fixture
def rig(rigify_file):
    return append(rigify_file, "rig")[0]


@pytest.mark.parametrize("clip, controls", CASES)
def test_rigify_deform_bones_turn_as_the_source_bones_do(mk, rig, shared_dir, clip, controls):
    whole, turn, direction = rigify_turns(mk, rig, os.path.join(shared_dir, "data", clip), controls)
    check_turns(whole, turn, direction, controls, clip)


@pytest.mark.parametrize("clip, controls", CASES)
def test_rigify_keys_controls_and_plants_the_feet(mk, rig, shared_dir, clip, controls):
    slide, where, stance, farthest, _ = rigify_feet_slide(mk, rig, os.path.join(shared_dir, "data", clip), controls)
    keyed = keyed_bones(rig)
    assert not [b for b in keyed if b.startswith(("DEF-", "ORG-", "MCH-"))], keyed
    switch = rig.pose.bones["thigh_parent.L"]["IK_FK"], rig.pose.bones["upper_arm_parent.L"]["IK_FK"]
    assert tuple(float(v) for v in switch) == ((0.0, 1.0) if controls == "auto" else (1.0, 1.0))
    print(f"\n{clip} {controls}: feet slide at most {slide * 1000:.4f} mm beyond the source's ({where}; "
          f"{stance} stance frames, no point moving more than {farthest * 1000:.3f} mm through one)")
    assert stance >= STANCE_FRAMES and slide <= SLIDE_M, (stance, where)


@pytest.mark.parametrize("clip, controls", CASES)
def test_rigify_neck_and_head_point_as_the_source_does(mk, rig, shared_dir, clip, controls):
    worst, _ = rigify_neck_and_head(mk, rig, os.path.join(shared_dir, "data", clip), controls)
    print(f"\n{clip} {controls}: neck and head {({n: round(float(v), 5) for n, v in worst.items()})} deg")
    assert max(worst.values()) < NECK_DEG, worst
