"""The native full-body IK binding (ik_solve): arguments, results and errors."""
import numpy as np
import pytest


def chain(native, lengths=(1.0, 0.7)):
    """Bones along +X from the origin, each the child of the one before."""
    n = len(lengths)
    heads = np.zeros((n, 3))
    heads[1:, 0] = np.cumsum(lengths)[:-1]
    # The rest orientation turns Y onto +X: -90 degrees about Z.
    rest = np.tile([np.cos(-np.pi / 4), 0.0, 0.0, np.sin(-np.pi / 4)], (n, 1))
    return native.Rig([f"b{i}" for i in range(n)], [i - 1 for i in range(n)], rest, heads,
                      np.asarray(lengths, dtype=float))


def identity(frames, bones):
    q = np.zeros((frames, 4 * bones))
    q[:, 0::4] = 1.0
    return q


def test_two_bone_arm_reaches_and_returns_every_array(native):
    rig = chain(native)
    target = np.array([[0.9, 0.8, 0.0]])
    locked = np.zeros((2, 3), dtype=bool)
    locked[:, :2] = True  # hinges about Z
    start = identity(1, 2)
    start[0, 4:8] = [np.cos(0.15), 0, 0, np.sin(0.15)]  # elbow bent a little
    out = native.ik_solve(rig, start, np.zeros((1, 3)), target, np.zeros((1, 0)),
                          [{"name": "hand", "bone": 1}], locked=locked, root_rotation=True, tolerance=1e-10)
    assert set(out) == {"rotations", "root_locations", "scales", "errors", "iterations"}
    assert out["rotations"].shape == (1, 8) and out["scales"].shape == (1, 2)
    assert out["errors"].shape == (1, 1) and out["errors"][0, 0] < 1e-10
    assert out["iterations"].dtype == np.int32
    d = np.linalg.norm(target)
    elbow = np.arccos((d * d - 1.0 - 0.49) / (2 * 0.7))
    angle = 2 * np.arctan2(out["rotations"][0, 7], out["rotations"][0, 4])  # about Z
    assert abs(angle - elbow) < 1e-8
    np.testing.assert_array_equal(out["scales"], 1.0)


def test_pins_and_excluded_bones(native):
    rig = chain(native, (1.0, 1.0, 1.0))
    frames = 5
    rot = identity(frames, 3)
    targets = np.zeros((frames, 6))
    targets[:, 0:3] = [2.0, 1.0, 0.0]  # only the last bone need turn: a quarter turn about Z
    excluded = np.array([False, True, False])
    out = native.ik_solve(rig, rot, np.zeros((1, 3)), targets, np.zeros((frames, 0)),
                          [{"bone": 2}, {"bone": 0, "pin": True}], excluded=excluded, root_rotation=True)
    np.testing.assert_array_equal(out["rotations"][:, 4:8], rot[:, 4:8])  # excluded: as it came
    assert np.all(out["errors"] < 1e-5)  # reached, and the pin held


def test_errors_name_the_effector_and_frame(native):
    rig = chain(native)
    targets = np.zeros((4, 3))
    targets[2, 1] = np.nan
    with pytest.raises(native.MotionKitError, match=r"effector 'hand'.*frame index 2"):
        native.ik_solve(rig, identity(1, 2), np.zeros((1, 3)), targets, np.zeros((4, 0)),
                        [{"name": "hand", "bone": 1}])
    with pytest.raises(native.MotionKitError, match="unknown effector key 'pinned'"):
        native.ik_solve(rig, identity(1, 2), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 0)),
                        [{"bone": 1, "pinned": True}])
    with pytest.raises(native.MotionKitError, match="unknown method"):
        native.ik_solve(rig, identity(1, 2), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 0)),
                        [{"bone": 1}], method="fabrik")
    with pytest.raises(native.MotionKitError, match=r"limit_min must have shape \(2, 3\)"):
        native.ik_solve(rig, identity(1, 2), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 0)),
                        [{"bone": 1}], limit_min=np.zeros((3, 3)))
    with pytest.raises(TypeError):  # float32 is not converted silently
        native.ik_solve(rig, identity(1, 2).astype(np.float32), np.zeros((1, 3)), np.zeros((1, 3)),
                        np.zeros((1, 0)), [{"bone": 1}])
