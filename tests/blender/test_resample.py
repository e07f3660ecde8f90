"""Resample Keys and Reduce Keys in a real Blender, checked with Blender's own fcurve.evaluate."""
import importlib
import math

import bpy
import numpy as np
import pytest
import squad_reference
from keyed_objects import animated_empty

SCALAR_EXACT = ["catmull-rom", "centripetal", "chordal", "kochanek-bartels", "natural", "clamped",
                "not-a-knot", "monotone", "periodic"]
ROTATION_KINDS = ["squad", "slerp", "catmull-rom", "kochanek-bartels"]


def _float32(values):
    return np.asarray(values, dtype=np.float32).astype(np.float64)


def _keys(animdata, action, obj, path, index):
    fcurve = animdata.find_fcurve(action, obj, path, index)
    frames, values = animdata.read_keys(fcurve)
    return fcurve, frames.astype(np.float64), values.astype(np.float64)


def _handles(fcurve):
    points = fcurve.keyframe_points
    left = np.empty(2 * len(points), dtype=np.float32)
    right = np.empty(2 * len(points), dtype=np.float32)
    points.foreach_get("handle_left", left)
    points.foreach_get("handle_right", right)
    return left.reshape(-1, 2).astype(np.float64), right.reshape(-1, 2).astype(np.float64)


def _random_times_per_segment(frames, count, rng):
    # Blender returns a key's own value within 1e-4 frames of it (BEZT_BINARYSEARCH_THRESH),
    # so the times keep clear of the keys by more than that.
    u = rng.uniform(1e-3, 1.0 - 1e-3, size=(frames.size - 1, count))
    return _float32((frames[:-1, None] + u * np.diff(frames)[:, None]).ravel())  # Blender evaluates in float


def _hermite_from_keys(native, fcurve, frames, values):
    """The cubic Hermite curve that the written keys and handles define, evaluated natively."""
    left, right = _handles(fcurve)
    h_left = np.concatenate([[1.0], np.diff(frames)])
    h_right = np.concatenate([np.diff(frames), [1.0]])
    slopes_in = (values - left[:, 1]) / (h_left / 3.0)
    slopes_out = (right[:, 1] - values) / (h_right / 3.0)
    return slopes_in, slopes_out


@pytest.mark.parametrize("kind", SCALAR_EXACT)
def test_exact_keys_make_blender_draw_the_native_curve(mk, animdata, native, kind):
    """Blender's fcurve.evaluate equals the native curve at 100 random times per segment to 1e-6.

    Blender stores key and handle times as float32, whose spacing grows with the
    frame number (3.8e-6 frames between 32 and 64), so the agreement it allows
    is about |slope| x that spacing: this clip stays below frame 64 with slopes
    under 0.2 per frame to test 1e-6 itself.
    """
    rng = np.random.default_rng(3)
    frames = np.concatenate([[1.0], 1.0 + np.cumsum(rng.uniform(0.5, 2.5, size=30))])
    location = np.vstack([np.sin(frames / 6.0), 0.8 * np.cos(frames / 9.0), 0.5 * np.sin(frames / 4.0 + 1.0)])
    location += rng.normal(scale=0.05, size=location.shape)
    if kind == "periodic":
        location[:, -1] = location[:, 0]
    obj, action = animated_empty(animdata, frames, location)
    tcb = {"tension": 0.3, "bias": -0.2} if kind == "kochanek-bartels" else {}
    mk.resample(obj, step=2.0, scalar=kind, output='EXACT', **tcb)

    def per_key(count):
        return {name: np.full(count, value) for name, value in tcb.items()}

    new_frames = np.arange(frames[0], frames[-1], 2.0)  # the last old key is not on a whole frame
    # The keys: the chosen curve through the old keys (as Blender stored them) on the new frames.
    vector = native.interpolate(frames, np.ascontiguousarray(_float32(location).T), new_frames, kind=kind,
                                **per_key(frames.size))
    if kind == "periodic":
        vector[-1] = vector[0]
    slopes_in, slopes_out = native.hermite_form(new_frames, vector, kind=kind, **per_key(new_frames.size))
    times = _random_times_per_segment(new_frames, 100, rng)
    expected = native.interpolate(new_frames, vector, times, kind=kind, **per_key(new_frames.size))
    worst = 0.0
    for k in range(3):
        fcurve, key_frames, key_values = _keys(animdata, action, obj, "location", k)
        assert np.array_equal(key_frames, new_frames)
        assert np.allclose(key_values, vector[:, k], rtol=0, atol=1e-6)
        assert {p.interpolation for p in fcurve.keyframe_points} == {'BEZIER'}
        assert {p.handle_left_type for p in fcurve.keyframe_points} <= {'FREE', 'ALIGNED'}
        # The handles carry the curve's own slopes ...
        written_in, written_out = _hermite_from_keys(native, fcurve, key_frames, key_values)
        assert np.allclose(written_out[:-1], slopes_out[:-1, k], rtol=1e-4, atol=1e-5)
        assert np.allclose(written_in[1:], slopes_in[1:, k], rtol=1e-4, atol=1e-5)
        # ... so that between the keys Blender draws the native curve.
        got = np.array([fcurve.evaluate(t) for t in times])
        worst = max(worst, float(np.max(np.abs(got - expected[:, k]))))
    assert worst < 1e-6, worst


@pytest.mark.parametrize("kind, interpolation", [("linear", 'LINEAR'), ("stepped", 'CONSTANT')])
def test_linear_and_stepped_use_blenders_own_key_types(mk, animdata, native, kind, interpolation):
    frames = np.arange(1.0, 31.0)
    location = np.vstack([np.sin(frames / 4.0), np.cos(frames / 5.0), frames / 10.0])
    obj, action = animated_empty(animdata, frames, location)
    mk.resample(obj, step=3.0, scalar=kind)
    fcurve, new_frames, new_values = _keys(animdata, action, obj, "location", 0)
    assert {p.interpolation for p in fcurve.keyframe_points} == {interpolation}
    times = _random_times_per_segment(new_frames, 20, np.random.default_rng(0))
    expected = native.interpolate(new_frames, new_values, times, kind=kind)
    assert np.allclose([fcurve.evaluate(t) for t in times], expected, atol=1e-6)


def _rotating_bone_rig(animdata, native, mode, frames, quats):
    armature = bpy.data.armatures.new("Rig")
    obj = bpy.data.objects.new("Rig", armature)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    bone = armature.edit_bones.new("Arm")
    bone.tail = (0.0, 0.0, 1.0)
    bpy.ops.object.mode_set(mode='OBJECT')
    pose_bone = obj.pose.bones["Arm"]
    pose_bone.rotation_mode = mode
    rc = importlib.import_module(animdata.__name__.rsplit(".", 2)[0] + ".core.rotation_channels")
    prop, size = rc.channel_property(mode)
    values = rc.from_quaternions(native, mode, quats)
    action = animdata.new_action("RigAction")
    animdata.assign(obj, action)
    animdata.write_keys(obj, action, [(f'pose.bones["Arm"].{prop}', k, "Arm") for k in range(size)],
                        frames, values.T)
    return obj, action, prop, size


def _smooth_quaternions(count, seed, step=0.12):
    """A random rotation walk, about step radians per key on each axis (a brisk mocap pace)."""
    rng = np.random.default_rng(seed)
    vectors = np.cumsum(rng.normal(scale=step, size=(count, 3)), axis=0)
    angle = np.linalg.norm(vectors, axis=1, keepdims=True)
    axis = vectors / np.maximum(angle, 1e-12)
    return np.hstack([np.cos(angle / 2), np.sin(angle / 2) * axis])


def _pose_quaternions(obj, frames):
    """The bone's rotation as Blender evaluates it (depsgraph), per frame."""
    scene = bpy.context.scene
    out = []
    for frame in frames:
        scene.frame_set(int(np.floor(frame)), subframe=float(frame - np.floor(frame)))
        q = obj.pose.bones["Arm"].matrix_basis.to_quaternion()
        out.append((q.w, q.x, q.y, q.z))
    return np.array(out)


def _angle_between(a, b):
    """Rotation angle between quaternion rows, robust near zero (arccos of a float32 dot is not)."""
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    b = b * np.where(np.einsum("ij,ij->i", a, b) < 0, -1.0, 1.0)[:, None]
    return 4.0 * np.arctan2(np.linalg.norm(a - b, axis=1), np.linalg.norm(a + b, axis=1))


@pytest.mark.parametrize("mode", ['QUATERNION', 'XYZ', 'ZXY', 'AXIS_ANGLE'])
@pytest.mark.parametrize("kind", ROTATION_KINDS)
def test_rotations_go_over_the_sphere_in_every_rotation_mode(mk, animdata, native, mode, kind):
    frames = np.arange(1.0, 61.0, 2.5)
    quats = _smooth_quaternions(frames.size, 5)
    obj, action, prop, size = _rotating_bone_rig(animdata, native, mode, frames, quats)
    mk.resample(obj, fps=24.0, change_scene_rate=False, rotation=kind, output='EXACT')
    scene_fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    curves = [_keys(animdata, action, obj, f'pose.bones["Arm"].{prop}', k) for k in range(size)]
    new_frames = curves[0][1]
    assert np.allclose(np.diff(new_frames)[:-1], scene_fps / 24.0, atol=1e-4)
    expected = native.interpolate_rotations(frames, quats, new_frames, kind=kind)
    got = _pose_quaternions(obj, new_frames)
    assert np.max(_angle_between(got, expected)) < 1e-5  # float32 storage
    block = np.vstack([c[2] for c in curves]).T
    assert np.max(np.abs(np.diff(block, axis=0))) < 1.5  # continuous channels: no 2*pi or sign jumps
    # Between keys: Blender's per-channel Bezier equals the native Hermite of the written handles.
    rng = np.random.default_rng(1)
    for fcurve, kf, kv in curves:
        slopes_in, slopes_out = _hermite_from_keys(native, fcurve, kf, kv)
        times = _random_times_per_segment(kf, 20, rng)
        segment = np.searchsorted(kf, times, side="right") - 1
        segment = np.clip(segment, 0, kf.size - 2)
        h = kf[segment + 1] - kf[segment]
        u = (times - kf[segment]) / h
        hermite = ((2 * u**3 - 3 * u**2 + 1) * kv[segment] + (u**3 - 2 * u**2 + u) * h * slopes_out[segment]
                   + (-2 * u**3 + 3 * u**2) * kv[segment + 1] + (u**3 - u**2) * h * slopes_in[segment + 1])
        got = np.array([fcurve.evaluate(t) for t in times])
        bad = np.flatnonzero(np.abs(got - hermite) > 1e-5)
        assert not bad.size, (fcurve.data_path, fcurve.array_index, times[bad[:4]], got[bad[:4]], hermite[bad[:4]],
                              kf[:3], kf[-3:])
    # And that per-channel curve stays close to the sphere curve between keys. Slerp bends at
    # every old key, which a cubic between two new keys cannot follow; only its keys are exact.
    if kind == "slerp":
        return
    between = new_frames[:-1] + 0.5 * np.diff(new_frames)
    deviation = _angle_between(_pose_quaternions(obj, between),
                               native.interpolate_rotations(frames, quats, between, kind=kind))
    assert np.degrees(deviation.max()) < 0.5


# Squad resampled by Blender's keys against Shoemake's formula (tests/common/squad_reference.py, float64):
# the keys are stored in float32, each component to half an ulp (3e-8 at |q| <= 1), so the rotation Blender
# evaluates on a key is off by up to about 2 * sqrt(3) * 3e-8 = 1e-7 rad, and matrix_basis.to_quaternion
# (float32) adds as much; measured 3.4e-7 rad (Blender 3.4). The bound is about ten times that.
SQUAD_FLOAT32 = 3.5e-6


@pytest.mark.parametrize("mode", ['QUATERNION', 'XYZ'])
def test_squad_keys_are_shoemakes_formula(mk, animdata, mode):
    """resample(rotation='squad') from keys 2 frames apart onto every half frame (DENSE: each new key is the
    curve's value there): Blender's evaluated rotation on each new key is Shoemake's squad."""
    frames = np.arange(1.0, 41.0, 2.0)
    quats = _smooth_quaternions(frames.size, 7, step=0.35)
    obj, action, prop, size = _rotating_bone_rig(animdata, mk.native(), mode, frames, quats)
    mk.resample(obj, step=0.5, rotation="squad", output='DENSE')
    new_frames = _keys(animdata, action, obj, f'pose.bones["Arm"].{prop}', 0)[1]
    assert new_frames.size == 2 * (frames.size - 1) * 2 + 1
    got = _pose_quaternions(obj, new_frames)
    want = squad_reference.squad(frames, quats, new_frames)
    worst = _angle_between(got, want).max()
    print(f"\nsquad through Blender's keys ({mode}) against Shoemake's formula: worst {worst:.3g} rad")
    assert worst < SQUAD_FLOAT32


def test_euler_channels_come_back_continuous_across_the_flip(mk, animdata, native):
    """A spin past 180 degrees about Z stays one continuous Euler curve, as Blender's compat Euler."""
    frames = np.arange(1.0, 21.0)
    angles = np.radians(np.linspace(0.0, 540.0, frames.size))
    quats = np.stack([np.cos(angles / 2), 0 * angles, 0 * angles, np.sin(angles / 2)], axis=1)
    obj, action, prop, _ = _rotating_bone_rig(animdata, native, 'XYZ', frames, quats)
    mk.resample(obj, step=0.5, rotation="squad", output='DENSE')
    _, new_frames, z = _keys(animdata, action, obj, f'pose.bones["Arm"].{prop}', 2)
    assert np.all(np.diff(z) > 0) and z[-1] == pytest.approx(np.radians(540.0), abs=1e-4)


def test_new_frame_rate_rescales_keys_and_the_scene(mk, animdata):
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 60, 1.0
    scene.frame_start, scene.frame_end = 1, 121
    frames = np.arange(1.0, 122.0)
    location = np.vstack([np.sin(frames / 10.0), frames / 60.0, np.zeros_like(frames)])
    obj, action = animated_empty(animdata, frames, location)
    try:
        mk.resample(obj, fps=24.0, change_scene_rate=True, scalar="natural")
        _, new_frames, y = _keys(animdata, action, obj, "location", 1)
        assert scene.render.fps == 24 and scene.frame_end == 49
        assert np.allclose(new_frames, np.arange(1.0, 50.0))
        assert np.allclose(y, (new_frames - 1.0) / 24.0 + 1.0 / 60.0, atol=1e-5)  # same time, same value
    finally:
        scene.render.fps, scene.render.fps_base = 24, 1.0
        scene.frame_start, scene.frame_end = 1, 250


def test_bad_requests_change_nothing(mk, animdata):
    frames = np.arange(1.0, 101.0)
    location = np.vstack([np.sin(frames), np.cos(frames), frames])
    obj, action = animated_empty(animdata, frames, location)
    before = [animdata.read_keys(f) for f in animdata.fcurves(action, obj)]
    for kwargs, message in [({"step": 2.0, "scalar": "polynomial"}, "Runge"),
                            ({"step": -1.0}, "frame step must be positive"),
                            ({"step": 2.0, "scalar": "bogus"}, "unknown scalar interpolant"),
                            ({"step": 2.0, "scalar": "periodic"}, "periodic spline needs equal")]:
        with pytest.raises(ValueError, match=message):
            mk.resample(obj, **kwargs)
    after = [animdata.read_keys(f) for f in animdata.fcurves(action, obj)]
    assert all(np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) for a, b in zip(before, after))


def test_operator_reports_errors_and_resamples_selected_objects(mk, animdata):
    frames = np.arange(1.0, 101.0)
    obj, action = animated_empty(animdata, frames, np.vstack([np.sin(frames), np.cos(frames), frames]))
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    with pytest.raises(RuntimeError, match="Runge"):
        bpy.ops.motionkit.resample_keys('EXEC_DEFAULT', timing='STEP', step=2.0, scalar="polynomial")
    assert len(animdata.find_fcurve(action, obj, "location", 0).keyframe_points) == 100
    assert bpy.ops.motionkit.resample_keys('EXEC_DEFAULT', timing='STEP', step=4.0) == {'FINISHED'}
    assert len(animdata.find_fcurve(action, obj, "location", 0).keyframe_points) == 26
    resampled = [animdata.find_fcurve(action, obj, "location", k) for k in range(3)]
    dense = np.arange(1.0, 101.0, 0.25)
    before = np.array([[fc.evaluate(t) for t in dense] for fc in resampled])
    assert bpy.ops.motionkit.reduce_keys('EXEC_DEFAULT', tolerance=1e-3) == {'FINISHED'}
    reduced = [animdata.find_fcurve(action, obj, "location", k) for k in range(3)]
    # location is one group keyed together (sin and cos of the frame need every key at step 4): no more
    # keys than before, and the curves within the tolerance of the ones they replace.
    assert sum(len(fc.keyframe_points) for fc in reduced) <= 3 * 26
    after = np.array([[fc.evaluate(t) for t in dense] for fc in reduced])
    assert np.max(np.abs(after - before)) <= 1e-3 + 1e-6


def test_reduce_keys_stays_within_tolerance(mk, animdata, native):
    frames = np.arange(1.0, 401.0)
    location = np.vstack([np.sin(frames / 15.0), 0.2 * np.cos(frames / 7.0), frames / 100.0])
    obj, action = animated_empty(animdata, frames, location)
    dense = np.arange(1.0, 400.0 + 1e-9, 0.1)
    original = np.array([[animdata.find_fcurve(action, obj, "location", k).evaluate(t) for t in dense]
                         for k in range(3)])
    before, after = mk.reduce_keys(obj, tolerance=1e-3, samples_per_frame=4)
    assert before == 1200 and after < 200
    reduced = np.array([[animdata.find_fcurve(action, obj, "location", k).evaluate(t) for t in dense]
                        for k in range(3)])
    assert np.max(np.abs(reduced - original)) <= 1e-3 * 1.01 + 1e-6
    kept, _ = animdata.read_keys(animdata.find_fcurve(action, obj, "location", 0))
    assert np.allclose(kept, np.round(kept))  # whole frames where the original keys were


@pytest.mark.parametrize("mode", ['QUATERNION', 'ZXY', 'XYZ'])
def test_reduce_keys_on_a_rotation_honours_the_angle(mk, animdata, native, mode):
    frames = np.arange(1.0, 301.0)
    vectors = np.stack([0.8 * np.sin(frames / 20.0), 0.5 * np.cos(frames / 13.0), 0.3 * np.sin(frames / 7.0)], 1)
    angle = np.linalg.norm(vectors, axis=1, keepdims=True)
    quats = np.hstack([np.cos(angle / 2), np.sin(angle / 2) * vectors / angle])
    obj, action, prop, size = _rotating_bone_rig(animdata, native, mode, frames, quats)
    dense = np.arange(1.0, 300.0, 0.25)
    original = _pose_quaternions(obj, dense)
    tolerance = math.radians(0.2)
    before, after = mk.reduce_keys(obj, rotation_tolerance=tolerance, samples_per_frame=4)
    reduced = _pose_quaternions(obj, dense)
    assert after < before / 3
    assert np.max(_angle_between(reduced, original)) <= tolerance * 1.01 + 1e-6


def test_reduce_keys_on_walk60_stays_within_tolerance_everywhere(mk, animdata, shared_dir, capsys):
    """The imported capture, reduced to 1 mm and 0.1 degrees, checked at ten points per frame."""
    import os
    obj, action = mk.bvh.load(os.path.join(shared_dir, "data", "bvh", "walk60.bvh"))
    curves = list(animdata.fcurves(action, obj))
    channels = [(f.data_path, f.array_index) for f in curves]
    first, last = action.frame_range
    dense = np.arange(first, last + 1e-9, 0.1)
    original, _ = animdata.sample(action, obj, channels, dense)
    tolerance, rotation_tolerance = 1e-3, math.radians(0.1)
    before, after = mk.reduce_keys(obj, tolerance, rotation_tolerance, samples_per_frame=4)
    reduced, _ = animdata.sample(action, obj, channels, dense)
    rotation_rows = {}
    for row, (path, index) in enumerate(channels):
        if path.endswith("rotation_quaternion"):
            rotation_rows.setdefault(path, [None] * 4)[index] = row
        else:
            assert np.max(np.abs(reduced[row] - original[row])) <= tolerance * (1 + 1e-6) + 1e-6, path
    worst = 0.0
    for path, rows in rotation_rows.items():
        angle = _angle_between(original[rows].T, reduced[rows].T)
        worst = max(worst, float(angle.max()))
    assert worst <= rotation_tolerance * (1 + 1e-3) + 1e-6
    assert after < before / 2
    with capsys.disabled():
        print(f"\nwalk60 key reduction: {before} keys -> {after} ({100 * after / before:.1f} %), "
              f"worst rotation error {math.degrees(worst):.4f} deg")


def test_a_stepped_curve_stays_stepped(mk, animdata):
    """0/1 curves held with CONSTANT keys (MotionKit's foot contacts) resample as steps, whatever the
    interpolant chosen for the other curves: no spline overshooting below 0 or above 1."""
    obj = bpy.data.objects.new("holder", None)
    bpy.context.scene.collection.objects.link(obj)
    obj["contact"] = 0.0
    action = animdata.new_action("steps")
    frames = np.arange(1, 61, dtype=np.float64)
    steps = (np.sin(frames / 4) > 0).astype(np.float64)
    animdata.write_keys(obj, action, [('["contact"]', 0), ("location", 0)], frames,
                        np.vstack([steps, np.sin(frames / 7)]), interpolation='CONSTANT')
    animdata.assign(obj, action)
    fc = animdata.find_fcurve(action, obj, "location", 0)
    fc.keyframe_points[3].interpolation = 'BEZIER'  # one key that does not hold: resampled as a spline
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 60, 1.0  # keys at 60 fps onto 24: new keys between the old
    try:
        mk.resample([obj], fps=24.0, scalar="catmull-rom")
    finally:
        scene.render.fps, scene.render.fps_base = 24, 1.0
    contact = animdata.find_fcurve(action, obj, '["contact"]', 0)
    values = animdata.read_keys(contact)[1]
    assert set(np.unique(values)) <= {0.0, 1.0}
    assert {k.interpolation for k in contact.keyframe_points} == {'CONSTANT'}
    assert animdata.find_fcurve(action, obj, "location", 0).keyframe_points[0].interpolation != 'CONSTANT'


def _all_keys(animdata):
    """Every action's keys and handles, and the scene's timing: what a refused call must leave as it was."""
    scene = bpy.context.scene
    keys = {}
    for obj in bpy.data.objects:
        action = animdata.assigned_action(obj)
        for fc in (animdata.fcurves(action, obj) if action else []):
            keys[(obj.name, fc.data_path, fc.array_index)] = [
                tuple(k.co) + tuple(k.handle_left) + tuple(k.handle_right) for k in fc.keyframe_points]
    return keys, set(bpy.data.actions), (scene.render.fps, scene.render.fps_base, scene.frame_start,
                                         scene.frame_end)


def _same(a, b):
    """_all_keys equal, NaN included (a NaN key must still be there, untouched)."""
    return a[1:] == b[1:] and a[0].keys() == b[0].keys() and all(
        np.array_equal(np.array(a[0][k]), np.array(b[0][k]), equal_nan=True) for k in a[0])


@pytest.mark.parametrize("call", ["resample", "reduce_keys", "reduce_keys world"])
def test_an_object_without_an_action_or_keys_is_named(mk, animdata, call):
    run = {"resample": lambda o: mk.resample(o, step=2.0), "reduce_keys": lambda o: mk.reduce_keys(o),
           "reduce_keys world": lambda o: mk.reduce_keys(o, space='WORLD')}[call]
    verb = "resample" if call == "resample" else "reduce"
    bare = bpy.data.objects.new("Bare", None)
    bpy.context.scene.collection.objects.link(bare)
    before = _all_keys(animdata)
    with pytest.raises(ValueError, match=rf"^'Bare' has no action to {verb}$"):
        run(bare)
    empty = bpy.data.objects.new("Unkeyed", None)
    bpy.context.scene.collection.objects.link(empty)
    animdata.assign(empty, animdata.new_action("Nothing"))
    before = _all_keys(animdata)
    with pytest.raises(ValueError, match=rf"^'Unkeyed' has no keys to {verb}$"):
        run(empty)
    assert _same(_all_keys(animdata), before)


@pytest.mark.parametrize("call", ["resample", "reduce_keys"])
@pytest.mark.parametrize("where", ["value", "handle"])
def test_a_nan_key_is_named_and_changes_nothing(mk, animdata, call, where):
    """A NaN in the source action (a broken script's key, a bad import) is refused naming the object, the
    curve and the frame, before anything is computed: otherwise it would spread through every curve the
    work computes from it."""
    frames = np.arange(1.0, 41.0)
    obj, action = animated_empty(animdata, frames, np.vstack([np.sin(frames / 5), np.cos(frames / 5), frames]))
    point = animdata.find_fcurve(action, obj, "location", 1).keyframe_points[6]
    if where == "value":
        point.co.y = float("nan")
        animdata.find_fcurve(action, obj, "location", 1).update()  # handles recomputed, as an edit would
    else:
        point.handle_right_type = 'FREE'
        point.handle_right.y = float("nan")
    before = _all_keys(animdata)
    what = "key" if where == "value" else "handle"
    with pytest.raises(ValueError, match=rf"^{call}: 'Mover' location\[1\] has a non-finite {what} at frame 7; "
                                         r"nothing was changed$"):
        mk.resample(obj, step=2.0) if call == "resample" else mk.reduce_keys(obj)
    assert _same(_all_keys(animdata), before)
