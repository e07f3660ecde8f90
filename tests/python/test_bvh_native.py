"""The native BVH reader/writer, rotations and pose conversion, against independent references."""
import math

import bvh_cases
import bvh_reference
import numpy as np
import pytest
from rotations import quaternion_angles
from scipy.spatial.transform import Rotation

ORDERS = bvh_cases.ORDERS
CASES = bvh_cases.cases()


def wxyz(rotation):
    return np.roll(rotation.as_quat(), 1, axis=-1)


def same_rotation(q1, q2, atol=1e-12):
    """Every pair within atol radians of each other (the angle between them, not |q1 . q2| ~ 1)."""
    return quaternion_angles(q1, q2).max() < atol


@pytest.mark.parametrize("order", ORDERS)
def test_euler_to_quaternion_matches_scipy(native, order):
    rng = np.random.default_rng(1)
    angles = rng.uniform(-np.pi, np.pi, (200, 3))
    out = native.euler_to_quaternion(angles, order)
    assert same_rotation(out, wxyz(Rotation.from_euler(order, angles)))


@pytest.mark.parametrize("order", ORDERS)
def test_quaternion_to_euler_matches_scipy_principal_angles(native, order):
    rotations = Rotation.random(300, random_state=2)
    out = native.quaternion_to_euler(np.ascontiguousarray(wxyz(rotations)), order, continuous=False)
    expected = rotations.as_euler(order)
    np.testing.assert_allclose(out, expected, atol=1e-9)


@pytest.mark.parametrize("order", ORDERS)
def test_continuous_euler_has_no_jumps_and_same_rotations(native, order):
    t = np.linspace(0, 4 * np.pi, 400)[:, None]
    angles = np.hstack([t[:, :1] * 1.3, 0.6 * np.sin(t[:, :1]), -t[:, :1]])
    q = wxyz(Rotation.from_euler(order, angles))
    out = native.quaternion_to_euler(np.ascontiguousarray(q), order, continuous=True)
    assert np.max(np.abs(np.diff(out, axis=0))) < 0.2  # smooth input, smooth angles
    assert same_rotation(wxyz(Rotation.from_euler(order, out)), q, atol=1e-9)


def test_blender_mode_reverses_letters(native):
    assert native._testing.blender_euler_mode("ZXY") == "YXZ"
    with pytest.raises(native.MotionKitError, match="unknown Euler order 'XYX'"):
        native.quaternion_to_euler(np.array([[1.0, 0, 0, 0]]), "XYX")


def reference_fk(skeleton, values):
    """FK written independently with scipy: Q_i = Q_p R_i, p_i = p_p + Q_p t_i."""
    names, parents, offsets = skeleton.names, skeleton.parents, skeleton.offsets
    frames, joints = values.shape[0], len(names)
    pos = np.zeros((frames, joints, 3))
    rot = [None] * joints
    for j in range(joints):
        t = np.tile(offsets[j], (frames, 1))
        r = Rotation.identity(frames)
        for k, channel in enumerate(skeleton.channels[j]):
            column = values[:, skeleton.first_channels[j] + k]
            axis = "XYZ".index(channel[0])
            if channel.endswith("position"):
                t[:, axis] = column
            else:
                r = r * Rotation.from_euler(channel[0].lower(), np.radians(column))
        if parents[j] < 0:
            rot[j], pos[:, j] = r, t
        else:
            p = parents[j]
            rot[j], pos[:, j] = rot[p] * r, pos[:, p] + rot[p].apply(t)
    return pos, rot


@pytest.mark.parametrize("name, text", CASES, ids=[c[0] for c in CASES])
def test_the_numpy_fk_reference_matches_scipy_on_every_layout(native, name, text):
    """bvh_reference, which the BVH import tests in Blender hold imports to, against scipy's rotations."""
    skeleton, motion = native._testing.parse_bvh(text, name)
    positions, orientations = bvh_reference.forward_kinematics(skeleton, motion.values)
    ref_pos, ref_rot = reference_fk(skeleton, np.asarray(motion.values))
    np.testing.assert_allclose(positions, ref_pos, atol=1e-12)
    for j in range(len(skeleton)):
        assert same_rotation(orientations[:, j], wxyz(ref_rot[j]), atol=1e-12)


def test_the_numpy_fk_reference_matches_scipy_on_the_real_files(native, shared_files):
    for path in shared_files:
        skeleton, motion = native.read_bvh(path)
        positions, _ = bvh_reference.forward_kinematics(skeleton, motion.values)
        ref_pos, _ = reference_fk(skeleton, np.asarray(motion.values))
        np.testing.assert_allclose(positions, ref_pos, atol=1e-12 * max(1.0, np.abs(ref_pos).max()), err_msg=path)


def test_the_real_walk_has_the_briefs_shape(native, shared_files):
    walk = [p for p in shared_files if p.endswith("walk60.bvh")][0]
    skeleton, motion = native.read_bvh(walk)
    assert len(skeleton) == 25 and sum(skeleton.end_sites) == 5
    assert motion.frames == 182 and motion.frame_time == pytest.approx(1 / 60, abs=1e-6)
    assert skeleton.names[0] == "RootJoint" and "lWrist_end" in skeleton.names


@pytest.mark.parametrize("name, text", CASES, ids=[c[0] for c in CASES])
def test_format_then_parse_gives_back_the_same_numbers(native, name, text):
    skeleton, motion = native._testing.parse_bvh(text, name)
    again_skeleton, again = native._testing.parse_bvh(native._testing.format_bvh(skeleton, motion), "again")
    assert again_skeleton.names == skeleton.names and again_skeleton.channels == skeleton.channels
    np.testing.assert_array_equal(again_skeleton.offsets, skeleton.offsets)
    np.testing.assert_array_equal(np.asarray(again.values), np.asarray(motion.values))
    assert again.frame_time == motion.frame_time


def test_motion_values_are_a_view_not_a_copy(native):
    skeleton, motion = native._testing.parse_bvh(CASES[0][1], "x")
    a, b = motion.values, motion.values
    assert a.ctypes.data == b.ctypes.data and a.shape == (motion.frames, skeleton.channel_count)


def test_a_broken_file_names_file_line_and_token(native, tmp_path):
    text = CASES[0][1].replace("CHANNELS 3 Xrotation Yrotation Zrotation", "CHANNELS 3 Xrotation Yrotation Wrotation", 1)
    path = tmp_path / "broken.bvh"
    path.write_text(text)
    with pytest.raises(native.MotionKitError, match=r"broken\.bvh:9:\d+: .*Wrotation"):
        native.read_bvh(str(path))
    with pytest.raises(native.MotionKitError, match="cannot open"):
        native.read_bvh(str(tmp_path / "missing.bvh"))


def random_unit_quaternions(n, seed):
    return np.ascontiguousarray(wxyz(Rotation.random(n, random_state=seed)))


@pytest.mark.parametrize("name, text", CASES, ids=[c[0] for c in CASES])
def test_pose_conversion_round_trips(native, name, text):
    """bvh_to_pose then pose_to_bvh gives back the same joint rotations and translations."""
    skeleton, motion = native._testing.parse_bvh(text, name)
    joints, frames = len(skeleton), motion.frames
    rest = random_unit_quaternions(joints, 5)
    conversion = wxyz(Rotation.from_euler("x", 90, degrees=True))
    values = np.ascontiguousarray(motion.values)
    rotations, locations = native.bvh_to_pose(skeleton, values, rest, conversion, 2.5)
    back = native.pose_to_bvh(skeleton, rotations, locations, rest, conversion, 2.5)
    pos_a, rot_a = bvh_reference.forward_kinematics(skeleton, values)
    pos_b, rot_b = bvh_reference.forward_kinematics(skeleton, back)
    if name == "sparse_channels":
        # Joints with fewer than three rotation channels keep only those axes.
        np.testing.assert_allclose(pos_b, pos_a, atol=1e-9)
        return
    np.testing.assert_allclose(pos_b, pos_a, atol=1e-9)
    assert same_rotation(rot_b, rot_a, atol=1e-9)


def test_pose_conversion_of_one_hand_derived_bone(native):
    """Root rotated 90 degrees about BVH Z; bone rest rotated 90 degrees about Y."""
    skeleton, motion = native._testing.parse_bvh(
        "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
        "End Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n1 2 3 90 0 0\n", "hand")
    rest = np.array([[math.cos(math.pi / 4), 0, math.sin(math.pi / 4), 0], [1, 0, 0, 0]])
    rotations, locations = native.bvh_to_pose(skeleton, np.ascontiguousarray(motion.values), rest,
                                              np.array([1.0, 0, 0, 0]), 1.0)
    # B = Ry(90) takes x to -z and z to x, so B^-1 takes z to -x:
    # M = B^-1 Rz(90) B is 90 degrees about -x.
    expected = wxyz(Rotation.from_euler("x", -90, degrees=True))
    assert same_rotation(rotations[0, :4], expected)
    # l = B^-1 (1, 2, 3): B^-1 takes x to z, y to y, z to -x, giving (-3, 2, 1).
    np.testing.assert_allclose(locations[0, :3], [-3, 2, 1], atol=1e-12)


def test_fcurve_evaluation_by_hand(native):
    # Curve 0: linear keys (0, 0) (10, 10); curve 1: constant (0, 1) (5, 2).
    co = np.array([[0, 0], [10, 10], [0, 1], [5, 2]], dtype=np.float64)
    interp = np.array([1, 1, 0, 0], dtype=np.int32)
    offsets = np.array([0, 2, 4], dtype=np.int32)
    times = np.array([-5.0, 0.0, 2.5, 5.0, 12.0])
    out = native.evaluate_fcurves(co, co, co, interp, offsets, np.array([1, 0], dtype=np.int32), times)
    np.testing.assert_allclose(out[0], [-5, 0, 2.5, 5, 12])  # linear extrapolation
    np.testing.assert_allclose(out[1], [1, 1, 1, 2, 2])


def test_names_that_are_not_utf8_still_read(native, tmp_path):
    path = tmp_path / "latin1.bvh"
    path.write_bytes(b"HIERARCHY\nROOT Caf\xe9\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\n"
                     b"MOTION\nFrames: 1\nFrame Time: 0.1\n0\n")
    skeleton, _ = native.read_bvh(str(path))
    assert skeleton.names == ["Caf\ufffd"]
