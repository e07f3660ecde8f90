"""A part of the body retargeted over a character's own animation, judged by Blender's
evaluation: Mixamo's Y Bot punching (its FBX, Blender's importer) onto a Mixamo character walking her own
walk (girl1's Right Strafe Walk, her FBX). The bones not retargeted keep every key to the bit and pose as
before; the bones retargeted pose as a whole-body retarget poses them, relative to their parents."""
import os

import bpy
import numpy as np
import pytest

import mixamo_pairs as mp
from rotations import matrix_angles

# Parent-relative orientations of one set of keys evaluated twice by Blender (float32 pose matrices
# composed over up to five parents): measured 6.6e-6, 6.0e-6 and 8.0e-6 degrees on 3.4, 4.3 and 5.2; about
# twelve times the largest.
SAME_POSE_DEG = 1e-4


@pytest.fixture()
def punch_and_walk(shared_dir):
    source = mp.import_fbx(os.path.join(shared_dir, "data", "fbx", "ybot@punch.fbx"))
    target = mp.import_fbx(os.path.join(shared_dir, "data", "pairs", "fbx", "girl1", "Right Strafe Walk.fbx"))
    return source, target


def _keys(mk, obj, action):
    """Every curve's keys (frames, values, handles as float32 bytes; interpolation and handle types)."""
    out = {}
    for fc in mk.animdata.fcurves(action, obj):
        points = fc.keyframe_points
        arrays = []
        for prop in ("co", "handle_left", "handle_right"):
            flat = np.empty(2 * len(points), dtype=np.float32)
            points.foreach_get(prop, flat)
            arrays.append(flat.tobytes())
        arrays.append(tuple((k.interpolation, k.handle_left_type, k.handle_right_type, k.easing) for k in points))
        out[(fc.data_path, fc.array_index)] = tuple(arrays)
    return out


def _local(obj, frames, names):
    """(frames, bones, 4, 4) each bone's pose matrix relative to its parent's, as Blender evaluates it."""
    out = np.empty((len(frames), len(names), 4, 4))
    for i, frame in enumerate(frames):
        bpy.context.scene.frame_set(int(frame))
        for j, name in enumerate(names):
            bone = obj.pose.bones[name]
            parent = np.array(bone.parent.matrix) if bone.parent else np.eye(4)
            out[i, j] = np.linalg.inv(parent) @ np.array(bone.matrix)
    return out


def _bone_of(data_path):
    return data_path.split('"')[1] if data_path.startswith("pose.bones[") else None


def test_arms_onto_a_character_walking_her_own_walk(mk, punch_and_walk):
    source, target = punch_and_walk
    walk = target.animation_data.action
    before = _keys(mk, target, walk)
    frames = np.arange(1, 30, 4)
    names = [b.name for b in target.data.bones]
    walking = _local(target, frames, names)
    whole = mp.rest_copy(target, "whole body")
    mk.retarget(source, whole, plant_feet=False)
    expected = _local(whole, frames, names)

    action = mk.retarget(source, target, parts="arms", into="current", plant_feet=False)
    assert action == walk and target.animation_data.action == walk
    after = _keys(mk, target, walk)
    arms = {n for n in names if any(k in n for k in ("Shoulder", "Arm", "Hand"))}
    untouched = [k for k in before if _bone_of(k[0]) not in arms]
    assert untouched and all(after[k] == before[k] for k in untouched)  # to the bit
    assert set(after) - set(before) <= {k for k in after if _bone_of(k[0]) in arms}
    got = _local(target, frames, names)
    others = [j for j, n in enumerate(names) if n not in arms]
    assert np.array_equal(got[:, others], walking[:, others])
    moved = [j for j, n in enumerate(names) if n in arms]
    worst = np.degrees(matrix_angles(got[:, moved], expected[:, moved]).max())
    print(f"\narms onto the walk: {len(moved)} bones, worst {worst:.2e} deg from the whole-body retarget")
    assert worst < SAME_POSE_DEG


def _basis(obj, frames, names):
    """(frames, bones, 4) the bones' basis rotations as Blender evaluates them (NLA included), w x y z."""
    out = np.empty((len(frames), len(names), 4))
    for i, frame in enumerate(frames):
        bpy.context.scene.frame_set(int(frame))
        for j, name in enumerate(names):
            out[i, j] = obj.pose.bones[name].matrix_basis.to_quaternion()
    return out


def _curve_quaternions(mk, obj, action, frames, names):
    """(frames, bones, 4) the action's own rotation_quaternion curves, by fcurve.evaluate."""
    curves = {(fc.data_path, fc.array_index): fc for fc in mk.animdata.fcurves(action, obj)}
    return np.array([[[curves[(f'pose.bones["{n}"].rotation_quaternion', k)].evaluate(f) for k in range(4)]
                      for n in names] for f in frames])


def _multiply(a, b):
    w1, v1, w2, v2 = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([w1 * w2 - np.sum(v1 * v2, -1, keepdims=True), w1 * v2 + w2 * v1 + np.cross(v1, v2)], -1)


def _slerp_from_identity(q, t):
    q = q * np.where(q[..., :1] < 0, -1.0, 1.0)
    angle = 2 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1, keepdims=True), q[..., :1])
    axis = q[..., 1:] / np.maximum(np.linalg.norm(q[..., 1:], axis=-1, keepdims=True), 1e-30)
    return np.concatenate([np.cos(t * angle / 2), np.sin(t * angle / 2) * axis], -1)


def _unit(q):
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


# Blender's NLA blend of float32 curves against the same blend computed here in float64 from
# fcurve.evaluate: measured 6.9e-7 at most (quaternion components, Add) on 3.4, 4.3 and 5.2; float32's
# relative step is 6e-8 and a Combine composes two rotations: about seven times the measure.
NLA_BLEND = 5e-6


@pytest.mark.parametrize("blend,influence", [("replace", 1.0), ("replace", 0.4), ("add", 1.0), ("add", 0.4)])
def test_arms_as_an_nla_track_above_the_walk(mk, punch_and_walk, blend, influence):
    """The retargeted arms on a track above the walk (which goes down onto a track of its own): Blender's
    NLA blends them as documented, Replace mixing each rotation's components by influence, Add (Combine)
    composing the walk's rotation with the retargeted one turned by influence; other bones as walked."""
    source, target = punch_and_walk
    walk = target.animation_data.action
    names = [b.name for b in target.data.bones]
    arms = [n for n in names if any(k in n for k in ("Shoulder", "Arm", "Hand"))]
    frames = np.arange(3, 30, 6)
    lower = _basis(target, frames, names)
    action = mk.retarget(source, target, parts="arms", into="nla", blend=blend, influence=influence,
                         plant_feet=False)
    tracks = target.animation_data.nla_tracks
    assert [t.strips[0].action for t in tracks] == [walk, action] and target.animation_data.action is None
    got = _basis(target, frames, names)
    others = [j for j, n in enumerate(names) if n not in arms]
    assert np.abs(got[:, others] - lower[:, others]).max() < NLA_BLEND
    moved = [names.index(n) for n in arms]
    strip = _curve_quaternions(mk, target, action, frames, arms)
    below = lower[:, moved] * np.where(np.sum(lower[:, moved] * strip, -1, keepdims=True) < 0, -1.0, 1.0)
    expected = _unit((1 - influence) * below + influence * strip) if blend == "replace" else \
        _multiply(lower[:, moved], _slerp_from_identity(strip, influence))
    sign = np.where(np.sum(got[:, moved] * expected, -1, keepdims=True) < 0, -1.0, 1.0)
    worst = np.abs(got[:, moved] * sign - expected).max()
    print(f"\n{blend} at {influence}: worst {worst:.1e} from the blend computed here")
    assert worst < NLA_BLEND


def test_arms_into_a_new_action_keep_the_others_keys(mk, punch_and_walk):
    source, target = punch_and_walk
    walk = target.animation_data.action
    before = _keys(mk, target, walk)
    action = mk.retarget(source, target, parts="arms", plant_feet=False)
    assert action != walk and target.animation_data.action == action and walk.use_fake_user
    assert _keys(mk, target, walk) == before
    after = _keys(mk, target, action)
    others = [k for k in before if _bone_of(k[0]) and not any(s in _bone_of(k[0]) for s in ("Shoulder", "Arm", "Hand"))]
    assert others and all(after[k] == before[k] for k in others)


def test_bad_choices_change_nothing(mk, punch_and_walk):
    source, target = punch_and_walk
    walk = target.animation_data.action
    before = _keys(mk, target, walk)
    actions = set(bpy.data.actions)
    with pytest.raises(ValueError, match="bones: 'tail' is not a bone of the target"):
        mk.retarget(source, target, bones=("tail",))
    with pytest.raises(ValueError, match="unknown body part 'wing'"):
        mk.retarget(source, target, parts=("arm.L", "wing"))
    target.animation_data.action = None
    with pytest.raises(ValueError, match="has no action to retarget into"):
        mk.retarget(source, target, parts="arms", into="current")
    target.animation_data.action = walk
    assert set(bpy.data.actions) == actions and _keys(mk, target, walk) == before
