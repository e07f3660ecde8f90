"""Blender's human metarig, built by the Rigify add-on that ships with Blender, under a real capture (walk60)
and Y Bot's Mixamo clips (FBX) with the defaults: its feet on its floor on the source's stance frames,
planted or not, by the tests' own rule (test_production_files: stances.stance on the source, each foot's
lowest of ankle and ball read back through Blender's evaluation, the source's height above its floor
scaled by the leg ratio).

The metarig is the rig among the tests' whose feet carry a third bone: a heel (heel.02) across the back of
each foot, a child of the foot beside the toe, lying on the floor where the ball joint rides 1.7 cm above
it. Its floor is the lowest of its foot bones at rest (the heel's), as on every rig; a standing foot's joints
ride as high above it as at rest (its ball 1.7 cm), so that the foot stands on its heel and sole instead of
sinking by its ball's height.
"""
import importlib
import os

import bpy
import numpy as np
import pytest
from mathutils import Matrix, Quaternion

import stances
from test_bone_mapping_metarig import metarig  # noqa: F401  (the fixture)
from test_production_files import (_feet, _lowest, _rest_joints, _stance, _world_leg, fbx_dir,  # noqa: F401
                                   import_fbx)

# A foot's lowest point on the source's stance frames against where the source's stands, scaled by the leg
# ratio, in legs. The feet's solve puts the ankle and the ball on their targets to float32 precision, as on
# the other rigs (test_production_files.FLOOR_ERROR); measured on Blender 3.4, 4.3 and 5.2, planted or not:
# walk60 5e-7, the kick 1.4e-6, the punch 1.3e-6, and no foot below the floor or the source's scaled height
# by more than 7e-7; about ten times the worst.
METARIG_FLOOR_ERROR = 1e-5


def _stance_errors(mk, source, target, plan, src_floor):
    """(errors (frames, 2) signed, in legs; the source's stance frames (frames, 2); lowest point below the
    floor or the source's scaled height, in legs) by the tests' own rule: each foot's lowest joint as far
    above where the target's joints stand at rest as the source's above where its stand, scaled. src_floor:
    the world Z the source's foot joints stand at (its floor, where they stand on it)."""
    frames = plan.frames
    src_feet, tgt_feet = _feet(mk, source), _feet(mk, target)
    src_low, src_ankles = _lowest(source, src_feet, frames)
    tgt_low, _ = _lowest(target, tgt_feet, frames)
    tgt_floor = _rest_joints(target, tgt_feet)
    leg = _world_leg(target, tgt_feet)
    ratio = plan.path_scale * target.matrix_world.to_scale()[0] / source.matrix_world.to_scale()[0]
    wanted = tgt_floor + ratio * (src_low - src_floor)
    stance = _stance(src_low, src_ankles, _world_leg(source, src_feet),
                     mk.animdata.frame_rate(source.animation_data.action))
    below = (tgt_low - np.minimum(wanted, tgt_floor)).min() / leg
    return (tgt_low - wanted) / leg, stance, below


def check_on_the_floor(mk, name, source, metarig, src_floor, plant, steps):  # noqa: F811
    """The source retargeted onto the metarig with the defaults (plant_feet as given): its feet on the
    source's stance frames within METARIG_FLOOR_ERROR of the leg; steps: how many stance frames each foot
    has at least (the rule finds the stances it should)."""
    plan = mk.retargeting.plan(source, metarig, plant_feet=plant)
    mk.retargeting.apply(plan)
    error, stance, below = _stance_errors(mk, source, metarig, plan, src_floor)
    off = np.abs(np.where(stance, error, 0.0))
    worst = np.unravel_index(np.argmax(off), off.shape)
    print(f"\n{name} onto the metarig, planted {plant}: stance error median {100 * np.median(off[stance]):.5f} "
          f"%, worst {100 * off.max():.5f} % of the leg (foot {'LR'[worst[1]]}, frame {plan.frames[worst[0]]:g}, "
          f"{100 * error[worst]:+.5f} %; {stance.sum()} foot-frames); lowest below the floor or the source's "
          f"height {100 * below:.5f} % of the leg")
    assert stance.sum(axis=0).min() >= steps
    assert off.max() < METARIG_FLOOR_ERROR
    assert below > -METARIG_FLOOR_ERROR  # nor any foot deeper than the source's, scaled: the same precision


@pytest.mark.parametrize("plant", [True, False], ids=["planted", "not planted"])
def test_walk60_onto_the_metarig_stands_on_its_floor(mk, walk60, metarig, plant):  # noqa: F811
    source, _ = mk.bvh.load(walk60)
    bpy.context.view_layer.update()
    # walk60's capture floor: its root's origin level, where the clip's feet come down.
    check_on_the_floor(mk, "walk60", source, metarig, 0.0, plant, steps=30)


@pytest.mark.parametrize("plant", [True, False], ids=["planted", "not planted"])
@pytest.mark.parametrize("clip", ["kick", "punch"])
def test_a_mixamo_clip_onto_the_metarig_stands_on_its_floor(mk, fbx_dir, metarig, clip, plant):  # noqa: F811
    """Y Bot's clips through Blender's FBX importer (centimetres, scaled 0.01, turned 90 degrees)."""
    source = import_fbx(os.path.join(fbx_dir, f"ybot@{clip}.fbx"))
    bpy.context.view_layer.update()
    check_on_the_floor(mk, clip, source, metarig, _rest_joints(source, _feet(mk, source)), plant, steps=10)


# Foot points through the native pose against Blender's own (float32 rest matrices, bones about a metre from
# the origin): measured 5.7e-7 m on Blender 3.4, 4.3 and 5.2; about ten times that.
POINT_M = 5e-6


def test_the_feet_are_held_by_their_ankles_and_balls(mk, metarig):  # noqa: F811
    """The feet's solve (and the contacts it reads) holds each foot by its ankle and its ball, the toe's head,
    as the floor and the tests measure them, not by the heel bone beside the toe (which continues the shin
    more straightly): each point where Blender's depsgraph puts the foot's and toe's heads, in a pose that
    bends the legs and rolls the feet (a heel-held foot leaves its ball free to roll about the ankle-heel
    line)."""
    contacts = importlib.import_module(mk.__name__ + ".features.contacts")
    pose_channels = importlib.import_module(mk.__name__ + ".blender.pose_channels")
    turns = {"thigh.L": ((1, 0, 0), 0.5), "shin.L": ((1, 0, 0), -0.7), "foot.L": ((0.3, 0.2, 1), 0.6),
             "thigh.R": ((0, 0, 1), 0.3), "shin.R": ((1, 0.2, 0), -0.4), "foot.R": ((1, 0, 0.4), -0.8)}
    for name, (axis, angle) in turns.items():
        bone = metarig.pose.bones[name]
        bone.rotation_mode = 'QUATERNION'
        bone.rotation_quaternion = Quaternion(axis, angle)
    metarig.matrix_world = Matrix.Translation((0.2, -0.1, 0.05))
    bpy.context.view_layer.update()
    rig = pose_channels.read_rig(metarig)
    rotations, locations = pose_channels.current_pose(metarig, rig.names)
    feet = contacts.find_feet(metarig)
    points, _ = contacts.foot_points(rig, rotations.reshape(1, -1), locations.reshape(1, -1), feet)
    world = metarig.matrix_world
    expected = [tuple(world @ metarig.pose.bones[name].head) for foot in feet for name in (foot.foot, foot.toe)]
    off = np.linalg.norm(points[0] - np.array(expected), axis=1)
    print(f"\nmetarig foot points (ankle, ball; L, R) off Blender's: {off} m")
    assert [f.toe for f in feet] == ["toe.L", "toe.R"]
    assert off.max() < POINT_M


# A stance's slide on the target (the tests' own rule: stances.stance on the source, runs of at least 0.08 s,
# each ankle's stray across the floor as Blender evaluates it) against the source's own, scaled by the legs'
# ratio: 2 mm beyond it is what a planted foot may add (the eased blends at a contact's ends; a held one keeps
# to a thousandth of a millimetre).
SLIDE_SLACK = 2e-3


def stance_slides(mk, source, target, plan):
    """[(target's slide, the source's scaled)] per stance of the source, world metres."""
    frames = plan.frames
    src_feet, tgt_feet = _feet(mk, source), _feet(mk, target)
    src_low, src_ankles = _lowest(source, src_feet, frames)
    _, tgt_ankles = _lowest(target, tgt_feet, frames)
    fps = mk.animdata.frame_rate(source.animation_data.action)
    src_leg = _world_leg(source, src_feet)
    stance = stances.stance(src_low, src_ankles, src_leg, fps)
    shortest = int(np.ceil(0.08 * fps))
    ratio = _world_leg(target, tgt_feet) / src_leg
    return [(t[3], ratio * s[3]) for s, t in zip(stances.slides(src_ankles, stance, shortest),
                                                 stances.slides(tgt_ankles, stance, shortest))]


def test_a_planted_foot_slides_no_more_than_the_source_s(mk, walk60, metarig):  # noqa: F811
    """walk60 onto the metarig, whose legs and feet are proportioned apart from the capture's: every stance
    the source holds stays held, no slide beyond the source's own, scaled."""
    source = mk.bvh.load(walk60)[0]
    plan = mk.retargeting.plan(source, metarig)
    mk.retargeting.apply(plan)
    slides = stance_slides(mk, source, metarig, plan)
    print("\nwalk60 onto the metarig: slides (mm, target / source scaled) "
          + " ".join(f"{1000 * t:.1f}/{1000 * s:.1f}" for t, s in slides))
    assert len(slides) >= 5
    assert all(t <= s + SLIDE_SLACK for t, s in slides), slides
