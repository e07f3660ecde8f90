"""core/follow: IK bones keyed to move rigidly with the bones they stand for, checked by the independent
forward kinematics of tests/common/rig_fk.py on random poses."""
import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

import characters
import rig_fk
from core import follow
from plain_rigs import from_spec


def _rig():
    spec = characters.UNREAL_A
    at = {b.canonical: b for b in spec.bones}
    extra = [characters.BoneSpec("ik_hand_root", "ik", at["root"].name, (0, 0, 0), (0, 0, 0.1), 0.0),
             characters.BoneSpec("ik_hand_gun", "ik", "ik_hand_root", at["hand.R"].head,
                                 (at["hand.R"].head[0], at["hand.R"].head[1], at["hand.R"].head[2] + 0.1), 0.0),
             characters.BoneSpec("ik_hand_l", "ik", "ik_hand_gun", at["hand.L"].head, at["hand.L"].tail, 0.3),
             characters.BoneSpec("SK:ik_foot_r", "ik", at["root"].name, at["foot.R"].head, at["foot.R"].tail, 0.0)]
    return from_spec(dataclasses.replace(spec, bones=spec.bones + tuple(extra)))


def test_followers_found_by_name_in_any_namespace():
    rig = _rig()
    found = {rig.names[f]: rig.names[b] for f, b in follow.followers(rig, rig.body).items()}
    assert found == {"ik_hand_gun": rig.body.limbs["hand.R"], "ik_hand_l": rig.body.limbs["hand.L"],
                     "SK:ik_foot_r": rig.body.limbs["foot.R"]}


def _pose_with_locations(rig, basis, locations):
    """rig_fk's recurrence with every bone's location channel (in its rest frame under its posed parent), as
    Blender composes it: head_b = head_p + G_p R_p^-1 (H_b - H_p) + G_p R_p^-1 R_b location_b."""
    rest = [rig_fk.rotation(r) for r in rig.unit_rest]
    frames = len(basis)
    turns, heads = [], np.empty((frames, len(rig), 3))
    for b, p in enumerate(rig.parents):
        frame = rest[b] if p < 0 else turns[p] * (rest[p].inv() * rest[b])
        anchor = rig.heads[b] if p < 0 else heads[:, p] + turns[p].apply(rest[p].inv().apply(rig.heads[b] - rig.heads[p]))
        heads[:, b] = anchor + frame.apply(locations[:, 3 * b:3 * b + 3])
        turns.append(frame * rig_fk.rotation(basis[:, 4 * b:4 * b + 4]))
    return turns, heads


def test_followers_move_rigidly_with_their_bones(core_native):
    rig = _rig()
    frames = 4
    basis = np.roll(Rotation.random(frames * len(rig), random_state=3).as_quat(), 1, axis=1).reshape(frames, -1)
    locations = np.zeros((frames, 3 * len(rig)))
    locations[:, :3] = np.random.default_rng(3).normal(size=(frames, 3))
    posed = core_native.armature_pose(rig.native, np.ascontiguousarray(basis), locations)
    pairs = follow.followers(rig, rig.body)
    follow.follow(rig, pairs, basis, locations, posed)
    turns, heads = _pose_with_locations(rig, basis, locations)
    for f, b in pairs.items():
        # world = pose * rest^-1, for the follower and the bone it follows: equal on every frame.
        mine = turns[f] * rig_fk.rotation(rig.unit_rest[f]).inv()
        theirs = turns[b] * rig_fk.rotation(rig.unit_rest[b]).inv()
        assert (mine.inv() * theirs).magnitude().max() < 1e-12
        at = heads[:, b] + theirs.apply(rig.heads[f] - rig.heads[b])
        assert np.abs(heads[:, f] - at).max() < 1e-12  # doubles through a chain of a few bones
