"""Bulk key writing and reading through motionkit.animdata, in this Blender's action world."""
import bpy
import numpy as np
import pytest


def make_armature(name="Rig", bones=("Root", "Arm")):
    arm = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, arm)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    parent = None
    for i, bone_name in enumerate(bones):
        eb = arm.edit_bones.new(bone_name)
        eb.head, eb.tail = (0, 0, i), (0, 0, i + 1)
        eb.parent = parent
        parent = eb
    bpy.ops.object.mode_set(mode='OBJECT')
    return obj


def test_keys_written_in_bulk_drive_the_pose(animdata):
    obj = make_armature()
    action = animdata.new_action("Test")
    frames = np.arange(1.0, 11.0)
    t = (frames - 1) / 9
    quat = np.stack([np.cos(t), np.sin(t), np.zeros_like(t), np.zeros_like(t)])
    loc = np.stack([t, 2 * t, -t])
    bone = 'pose.bones["Arm"]'
    channels = [(f"{bone}.rotation_quaternion", i, "Arm") for i in range(4)]
    channels += [(f"{bone}.location", i, "Arm") for i in range(3)]
    animdata.write_keys(obj, action, channels, frames, np.vstack([quat, loc]))
    animdata.assign(obj, action)
    assert animdata.assigned_action(obj) == action
    scene = bpy.context.scene
    for k in (0, 4, 9):
        scene.frame_set(int(frames[k]))
        pose_bone = obj.pose.bones["Arm"]
        np.testing.assert_allclose(pose_bone.rotation_quaternion, quat[:, k], atol=1e-6)
        np.testing.assert_allclose(pose_bone.location, loc[:, k], atol=1e-6)
    assert [c.data_path for c in animdata.fcurves(action, obj)][:1] == [f"{bone}.rotation_quaternion"]
    # The bone's curves are grouped under its name, where the Graph Editor shows them: the action's groups
    # (legacy) or the channel bag's (5.x).
    curves = animdata.fcurves(action, obj)
    groups = action.groups if not animdata.LAYERED else \
        action.layers[0].strips[0].channelbag(obj.animation_data.action_slot).groups
    assert "Arm" in groups and all(fc.group is not None and fc.group.name == "Arm" for fc in curves)


def test_curves_that_do_not_play_are_sampled_as_blender_plays_them(animdata):
    """An F-curve with no keys (Blender 5.2's FBX import and append leave such curves on Y Bot's action) and a
    muted one leave their property as it stands, in Blender's evaluation and in sample(): the bone's own
    rotation, not a zero quaternion."""
    obj = make_armature()
    action = animdata.new_action("Empty curves")
    bone = 'pose.bones["Arm"]'
    animdata.write_keys(obj, action, [(f'pose.bones["Root"].location', 0, "Root")], np.array([1.0, 5.0]),
                        np.array([[0.0, 1.0]]))
    empty = animdata.new_fcurves(action, obj, [(f"{bone}.rotation_quaternion", i, "Arm") for i in range(4)])
    muted = animdata.new_fcurves(action, obj, [(f"{bone}.location", 0, "Arm")])[0]
    muted.keyframe_points.insert(1.0, 3.0)
    muted.mute = True
    assert all(len(fc.keyframe_points) == 0 for fc in empty)
    animdata.assign(obj, action)
    pose_bone = obj.pose.bones["Arm"]
    pose_bone.rotation_quaternion = (0.8, 0.6, 0.0, 0.0)
    pose_bone.location = (0.25, 0.0, 0.0)
    bpy.context.scene.frame_set(3)
    played = [*pose_bone.rotation_quaternion, pose_bone.location[0]]
    channels = [(f"{bone}.rotation_quaternion", i) for i in range(4)] + [(f"{bone}.location", 0)]
    values, found = animdata.sample(action, obj, channels, np.array([3.0]), static=np.array(played))
    np.testing.assert_allclose(played, [0.8, 0.6, 0.0, 0.0, 0.25], atol=1e-7)  # float32 properties
    assert np.array_equal(values[:, 0], played) and not found.any()


def test_curves_live_where_this_blender_keeps_them(animdata):
    obj = make_armature()
    action = animdata.new_action("Where")
    animdata.write_keys(obj, action, [("location", 0)], [1.0, 2.0], [[0.0, 1.0]])
    animdata.assign(obj, action)
    if animdata.LAYERED:
        assert not hasattr(action, "fcurves")  # 5.x removed it
        slot = obj.animation_data.action_slot
        assert slot is not None and slot.target_id_type == 'OBJECT'
        bag = action.layers[0].strips[0].channelbag(slot)
        assert [fc.data_path for fc in bag.fcurves] == ["location"]
    else:
        assert [fc.data_path for fc in action.fcurves] == ["location"]


def test_the_feature_tests_agree_with_the_release_notes(animdata):
    """animdata and pose_channels feature-test Blender's world; the release notes date it: legacy actions
    (action.fcurves) through 4.3, slotted ones from 4.4; bone selection on the bones through 4.x, on the pose
    bones from 5.0; key enums copied straight from a uint8 buffer from 4.0 (seen on 4.3 and 5.2), through
    the keys' bytes before."""
    import motionkit
    assert animdata.LAYERED == (bpy.app.version >= (4, 4, 0))
    assert motionkit.pose_channels.BONE_SELECTION_ON_POSE == (bpy.app.version >= (5, 0, 0))
    obj = make_armature()
    animdata.write_keys(obj, animdata.new_action("Ways"), [("location", 0)], np.arange(1.0, 6.0), [np.zeros(5)])
    assert animdata._enum_way["interpolation"] == ("uint8" if bpy.app.version >= (4, 0, 0) else "keys")


@pytest.mark.skipif(bpy.app.version < (4, 4, 0), reason="legacy actions have no slots")
def test_one_action_animates_two_armatures_through_their_own_slots(animdata):
    a, b = make_armature("A"), make_armature("B")
    action = animdata.new_action("Shared")
    animdata.write_keys(a, action, [("location", 0)], [1.0, 2.0], [[1.0, 1.0]])
    animdata.write_keys(b, action, [("location", 0)], [1.0, 2.0], [[5.0, 5.0]])
    animdata.assign(a, action)
    animdata.assign(b, action)
    bpy.context.scene.frame_set(1)
    assert a.location.x == pytest.approx(1.0) and b.location.x == pytest.approx(5.0)
    assert len(animdata.fcurves(action, a)) == 1 and len(animdata.fcurves(action, b)) == 1


def test_a_million_keys_read_back_exactly(animdata):
    obj = make_armature()
    action = animdata.new_action("Million")
    n_curves, n_keys = 100, 10_000
    rng = np.random.default_rng(7)
    frames = np.arange(1, n_keys + 1, dtype=np.float64)
    values = rng.normal(scale=3.0, size=(n_curves, n_keys))
    channels = [(f'["prop{c}"]', 0) for c in range(n_curves)]
    written = animdata.write_keys(obj, action, channels, frames, values)
    expected = values.astype(np.float32)
    for c, fcurve in enumerate(written):
        got_frames, got_values = animdata.read_keys(fcurve)
        np.testing.assert_array_equal(got_frames, frames.astype(np.float32))
        np.testing.assert_array_equal(got_values, expected[c])
    # Blender's own evaluation, at every one of the million keys.
    evaluated = np.array([[fc.evaluate(f) for f in frames] for fc in written], dtype=np.float64)
    np.testing.assert_array_equal(evaluated, expected.astype(np.float64))
    # And between keys the curves are the linear segments asked for.
    fc = written[3]
    mid = np.array([fc.evaluate(f + 0.25) for f in frames[:-1]])
    e = expected[3].astype(np.float64)
    np.testing.assert_allclose(mid, 0.75 * e[:-1] + 0.25 * e[1:], rtol=1e-5, atol=1e-5)


def _rna(points, prop):
    out = np.empty(2 * len(points), dtype=np.float32)
    points.foreach_get(prop, out)
    return out


def test_the_key_array_path_agrees_with_rna(animdata):
    """Keys are read and written through the keys' own array where its layout checks out: every key's
    co and handles must be what RNA's foreach_get reports, and short curves take RNA's way."""
    obj = make_armature()
    action = animdata.new_action("Layout")
    rng = np.random.default_rng(3)
    frames = np.cumsum(rng.uniform(0.5, 2.0, 500))
    values = rng.normal(size=(2, 500))
    written = animdata.write_keys(obj, action, [("location", 0), ("location", 1)], frames, values,
                                  interpolation='BEZIER')
    for fcurve, row in zip(written, values):
        points = fcurve.keyframe_points
        view = animdata._key_view(points)
        assert view is not None, "the key array's layout check failed on this Blender"
        for prop in ("co", "handle_left", "handle_right"):
            np.testing.assert_array_equal(animdata._read_co(points, view, prop), _rna(points, prop), err_msg=prop)
        np.testing.assert_array_equal(animdata.read_keys(fcurve)[1], row.astype(np.float32))
    # Switched off, RNA's way writes the same keys (and Blender computes the same handles from them).
    expected = {prop: _rna(written[0].keyframe_points, prop) for prop in ("co", "handle_left", "handle_right")}
    animdata.KEY_ARRAY = False
    try:
        (again,) = animdata.write_keys(obj, action, [("location", 0)], frames, values[:1], interpolation='BEZIER')
        assert animdata._co_view(again.keyframe_points) is None
        for prop, keys in expected.items():
            np.testing.assert_array_equal(animdata._read_co(again.keyframe_points, None, prop), keys, err_msg=prop)
    finally:
        animdata.KEY_ARRAY = True
    (single,) = animdata.write_keys(obj, action, [("location", 2)], [7.0], [[1.5]])
    assert animdata._key_view(single.keyframe_points) is None
    assert tuple(single.keyframe_points[0].co) == (7.0, 1.5)
    assert [a.tolist() for a in animdata.read_keys(single)] == [[7.0], [1.5]]


def test_rewriting_a_channel_replaces_its_keys(animdata):
    obj = make_armature()
    action = animdata.new_action("Again")
    animdata.write_keys(obj, action, [("location", 2)], np.arange(10.0), np.zeros((1, 10)))
    (fc,) = animdata.write_keys(obj, action, [("location", 2)], [3.0, 4.0], [[1.0, 2.0]],
                                interpolation='BEZIER')
    assert len(fc.keyframe_points) == 2
    assert {k.interpolation for k in fc.keyframe_points} == {'BEZIER'}
    assert len(animdata.fcurves(action, obj)) == 1


@pytest.mark.parametrize("interpolation", ['CONSTANT', 'LINEAR', 'BEZIER'])
def test_every_key_gets_its_interpolation_and_handle_types(animdata, interpolation):
    # Each Blender takes these byte-sized enums in bulk a different way (and
    # 3.x silently drops some), so every key is read back one by one here.
    obj = make_armature()
    n = 257
    frames = np.arange(n, dtype=np.float64)
    values = np.sin(frames)[np.newaxis, :]
    rng = np.random.default_rng(3)
    aligned = rng.random((1, n)) < 0.5
    handles = animdata.Handles(frames - 0.3, values - 0.1, frames + 0.3, values + 0.1, aligned) \
        if interpolation == 'BEZIER' else None
    for _ in range(2):  # the second time, the way found the first time
        (fc,) = animdata.write_keys(obj, animdata.new_action("Types"), [("location", 0)], frames, values,
                                    interpolation=interpolation, handles=handles)
        assert [k.interpolation for k in fc.keyframe_points] == [interpolation] * n
        if handles is not None:
            expected = ['ALIGNED' if a else 'FREE' for a in aligned[0]]
            assert [k.handle_left_type for k in fc.keyframe_points] == expected
            assert [k.handle_right_type for k in fc.keyframe_points] == expected
            np.testing.assert_allclose([k.handle_right[0] for k in fc.keyframe_points], frames + 0.3, atol=1e-5)


@pytest.mark.parametrize("frames, values, message", [
    ([1.0, 2.0, 3.0], [[0.0, np.nan, 1.0]], r"location\[1\] at frame 2 \(key 1\) is nan"),
    ([1.0, 2.0, 3.0], [[0.0, 1.0, np.inf]], r"location\[1\] at frame 3 \(key 2\) is inf"),
    ([1.0, np.inf, 3.0], [[0.0, 1.0, 2.0]], r"frame time at key 1 is inf"),
    ([1.0, 3.0, 2.0], [[0.0, 1.0, 2.0]], r"key 2 \(2.000000\) does not come after key 1"),
    ([1.0, 2.0], [[0.0, 1.0, 2.0]], r"expected values of shape \(1, 2\)"),
])
def test_bad_keys_are_refused_and_change_nothing(animdata, frames, values, message):
    obj = make_armature()
    action = animdata.new_action("Bad")
    with pytest.raises(ValueError, match=message):
        animdata.write_keys(obj, action, [("location", 1)], frames, values)
    assert len(animdata.fcurves(action, obj)) == 0
    if animdata.LAYERED:
        assert len(action.slots) == 0 and len(action.layers) == 0


def test_unknown_interpolation_is_refused(animdata):
    obj = make_armature()
    with pytest.raises(ValueError, match="unknown interpolation 'SPLINE'"):
        animdata.write_keys(obj, animdata.new_action("X"), [("location", 0)], [1.0], [[0.0]],
                            interpolation='SPLINE')


def _keys_and_handles(fcurve):
    return {prop: _rna(fcurve.keyframe_points, prop) for prop in ("co", "handle_left", "handle_right")}


def test_new_values_move_keys_and_handles_as_rna_does(animdata):
    """set_key_values through the keys' own array writes, bit for bit, what RNA's foreach_set way writes:
    each value rounded from float64, each handle moved by the shift rounded to float32 and added in
    float32. Values near 1000 moved to values near 0: the shift's rounding (float32 near 1000) is then
    much coarser than the new value's, so adding it in float64 instead gives other handles."""
    obj = make_armature()
    action = animdata.new_action("Move")
    rng = np.random.default_rng(11)
    n = 2000
    frames = np.cumsum(rng.uniform(0.5, 2.0, n))
    values = 1000.0 + rng.normal(size=(1, n))
    aligned = rng.random((1, n)) < 0.5
    handles = animdata.Handles(frames - 0.3, values - rng.uniform(0, 1, n), frames + 0.3,
                               values + rng.uniform(0, 1, n), aligned)
    new = rng.normal(size=(1, n))
    kinds = {"free": dict(interpolation='BEZIER', handles=animdata.Handles(*handles[:4], np.zeros_like(aligned))),
             "aligned or free": dict(interpolation='BEZIER', handles=handles),
             "automatic": dict(interpolation='BEZIER'), "linear": {}}
    for kind, options in kinds.items():
        curves = {}
        for way, index in (("rna", 0), ("key array", 1)):
            (fcurve,) = animdata.write_keys(obj, action, [(f'["{kind}"]', index)], frames, values, **options)
            curves[way] = fcurve
        before = _keys_and_handles(curves["rna"])
        animdata.KEY_ARRAY = False
        try:
            animdata.set_key_values(obj, action, [(f'["{kind}"]', 0)], new)
        finally:
            animdata.KEY_ARRAY = True
        assert animdata._co_view(curves["key array"].keyframe_points) is not None, "no key array on this Blender"
        animdata.set_key_values(obj, action, [(f'["{kind}"]', 1)], new)
        expected, got = _keys_and_handles(curves["rna"]), _keys_and_handles(curves["key array"])
        for prop in expected:
            np.testing.assert_array_equal(got[prop], expected[prop], err_msg=f"{kind}: {prop}")
        np.testing.assert_array_equal(got["co"][1::2], new[0].astype(np.float32), err_msg=kind)
        np.testing.assert_array_equal(got["co"][0::2], before["co"][0::2], err_msg=kind)
        if kind == "free":  # Blender leaves FREE handles where they are put: the rule itself, computed here
            shift = (new[0] - before["co"][1::2]).astype(np.float32)
            for prop in ("handle_left", "handle_right"):
                np.testing.assert_array_equal(got[prop][1::2], before[prop][1::2] + shift, err_msg=prop)
                np.testing.assert_array_equal(got[prop][0::2], before[prop][0::2], err_msg=prop)
        between = frames[:-1] + 0.37
        np.testing.assert_array_equal([curves["key array"].evaluate(f) for f in between],
                                      [curves["rna"].evaluate(f) for f in between], err_msg=kind)


@pytest.mark.parametrize("channel, row, message", [
    (("location", 2), [1.0, 2.0, 3.0], r"location\[2\] has no curve keys, not 3"),
    (("rotation_euler", 0), [1.0, 2.0, 3.0], r"rotation_euler\[0\] has 2 keys, not 3"),
    (("location", 1), [1.0, np.nan, 3.0], r"location\[1\] would get a non-finite value"),
])
def test_new_values_refused_change_no_curve(animdata, channel, row, message):
    obj = make_armature()
    action = animdata.new_action("Refused")
    written = animdata.write_keys(obj, action, [("location", 0), ("location", 1)], [1.0, 2.0, 3.0],
                                  [[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]], interpolation='BEZIER')
    written += animdata.write_keys(obj, action, [("rotation_euler", 0)], [1.0, 2.0], [[0.5, 0.7]])
    before = [_keys_and_handles(fcurve) for fcurve in written]
    with pytest.raises(ValueError, match=message):
        # The first channel is fine and comes first: it must not have changed either.
        animdata.set_key_values(obj, action, [("location", 0), channel], [[9.0, 9.0, 9.0], row])
    with pytest.raises(ValueError, match=r"3 rows of values for 2 channels"):
        animdata.set_key_values(obj, action, [("location", 0), ("location", 1)], [[9.0, 9.0, 9.0]] * 3)
    for fcurve, keys in zip(written, before):
        for prop, array in _keys_and_handles(fcurve).items():
            np.testing.assert_array_equal(array, keys[prop], err_msg=prop)
