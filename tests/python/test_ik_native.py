"""The native full-body IK binding (ik_solve): arguments, results and errors."""
import numpy as np
import pytest

import rig_fk

# The two-arm rig's targets, judged by scipy's forward kinematics: the solver stops within its tolerance,
# 3e-7 of the rig's size (1.3e-6 on this 4.3 rig); measured 1.19e-6, held to about ten times that.
MET = 1e-5


def chain_arrays(lengths=(1.0, 0.7)):
    """Bones along +X from the origin, each the child of the one before: parents, rest, heads, lengths."""
    n = len(lengths)
    heads = np.zeros((n, 3))
    heads[1:, 0] = np.cumsum(lengths)[:-1]
    # The rest orientation turns Y onto +X: -90 degrees about Z.
    rest = np.tile([np.cos(-np.pi / 4), 0.0, 0.0, np.sin(-np.pi / 4)], (n, 1))
    return [i - 1 for i in range(n)], rest, heads, np.asarray(lengths, dtype=float)


def chain(native, lengths=(1.0, 0.7)):
    parents, rest, heads, lengths = chain_arrays(lengths)
    return native.Rig([f"b{i}" for i in range(len(parents))], parents, rest, heads, lengths)


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
                          [native.IkEffector(1, name="hand")], joints=native.IkJoints(locked=locked),
                          options=native.IkOptions(root_rotation=True, tolerance=1e-10))
    assert isinstance(out, native.IkResult)
    assert out.rotations.shape == (1, 8) and out.scales.shape == (1, 2)
    assert out.errors.shape == (1, 1) and out.errors[0, 0] < 1e-10
    assert out.iterations.dtype == np.int32
    d = np.linalg.norm(target)
    elbow = np.arccos((d * d - 1.0 - 0.49) / (2 * 0.7))
    angle = 2 * np.arctan2(out.rotations[0, 7], out.rotations[0, 4])  # about Z
    assert abs(angle - elbow) < 1e-8
    np.testing.assert_array_equal(out.scales, 1.0)


def test_pins_and_excluded_bones(native):
    arrays = chain_arrays((1.0, 1.0, 1.0))
    rig = native.Rig(["b0", "b1", "b2"], *arrays)
    frames = 5
    rot = identity(frames, 3)
    targets = np.zeros((frames, 6))
    targets[:, 0:3] = [2.0, 1.0, 0.0]  # only the last bone need turn: a quarter turn about Z
    excluded = np.array([False, True, False])
    out = native.ik_solve(rig, rot, np.zeros((1, 3)), targets, np.zeros((frames, 0)),
                          [native.IkEffector(2), native.IkEffector(0, pin=True)],
                          joints=native.IkJoints(excluded=excluded), options=native.IkOptions(root_rotation=True))
    np.testing.assert_array_equal(out.rotations[:, 4:8], rot[:, 4:8])  # excluded: as it came
    # Judged by the test's own forward kinematics (scipy) of the returned pose: the tip reached, the pin held.
    _, _, tails = rig_fk.pose(*arrays, out.rotations, out.root_locations)
    _, _, rest_tails = rig_fk.pose(*arrays, rot)
    assert np.linalg.norm(tails[:, 2] - targets[:, 0:3], axis=1).max() < 1e-5
    assert np.linalg.norm(tails[:, 0] - rest_tails[:, 0], axis=1).max() < 1e-5


def test_errors_name_the_effector_and_frame(native):
    rig = chain(native)
    targets = np.zeros((4, 3))
    targets[2, 1] = np.nan
    with pytest.raises(native.MotionKitError, match=r"effector 'hand'.*frame index 2"):
        native.ik_solve(rig, identity(1, 2), np.zeros((1, 3)), targets, np.zeros((4, 0)),
                        [native.IkEffector(1, name="hand")])
    with pytest.raises(TypeError):  # effectors are IkEffector, with their fields checked by name
        native.IkEffector(1, pinned=True)
    with pytest.raises(TypeError):  # a dict is no effector
        native.ik_solve(rig, identity(1, 2), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 0)),
                        [{"bone": 1}])
    with pytest.raises(native.MotionKitError, match="effector 0 'nowhere' has no bone"):
        native.ik_solve(rig, identity(1, 2), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 0)),
                        [native.IkEffector(-1, name="nowhere")])
    with pytest.raises(native.MotionKitError, match=r"limit_min must have shape \(2, 3\)"):
        native.ik_solve(rig, identity(1, 2), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 0)),
                        [native.IkEffector(1)], joints=native.IkJoints(limit_min=np.zeros((3, 3))))
    with pytest.raises(TypeError):  # float32 is not converted silently
        native.ik_solve(rig, identity(1, 2).astype(np.float32), np.zeros((1, 3)), np.zeros((1, 3)),
                        np.zeros((1, 0)), [native.IkEffector(1)])


def test_options_and_tables_are_named_checked_fields(native):
    """IkOptions and IkJoints: the defaults ik.hpp documents, every field settable by name, a bad value named
    by its field; None is the defaults; and the fields reach the solver."""
    o = native.IkOptions()
    defaults = dict(method="dls", max_iterations=64, tolerance=0.0, max_step=0.3, damping=0.0,
                    regularization=1e-4, reference="previous", orientation_scale=0.0, root_translation=False,
                    root_rotation=False, warm_start=True, threads=0, size=0.0, priorities=True, balance=False,
                    up=[0.0, 0.0, 1.0], balance_margin=0.0)
    assert {name: getattr(o, name) for name in defaults} == defaults
    assert {n for n in dir(o) if not n.startswith("_")} == set(defaults)
    o = native.IkOptions(method="ccd", reference="input", up=(0.0, 1.0, 0.0), max_iterations=3)
    assert (o.method, o.reference, o.up, o.max_iterations) == ("ccd", "input", [0.0, 1.0, 0.0], 3)
    with pytest.raises(native.MotionKitError, match=r"IkOptions\.method: unknown method 'fabrik'"):
        native.IkOptions(method="fabrik")
    with pytest.raises(native.MotionKitError, match=r"IkOptions\.reference: unknown reference 'rest'"):
        o.reference = "rest"
    assert o.reference == "input"  # a refused value leaves the field as it was
    with pytest.raises(TypeError, match="IkOptions: no field 'iterations'"):
        native.IkOptions(iterations=3)
    with pytest.raises(TypeError, match="IkJoints: no field 'limits'"):
        native.IkJoints(limits=np.zeros((2, 3)))
    with pytest.raises(TypeError, match=r"IkJoints\.limit_min: expected a C-order float64 array"):
        native.IkJoints(limit_min=np.zeros((2, 3), dtype=np.float32))  # not converted silently
    with pytest.raises(TypeError, match=r"IkJoints\.locked: expected a C-order bool array"):
        native.IkJoints(locked=np.zeros((2, 3)))
    j = native.IkJoints(stage=[0, 1])  # stage is converted, as it always was
    assert j.stage.dtype == np.int32 and j.limit_min is None
    j.stage = None
    assert j.stage is None

    rig = chain(native)
    args = (rig, identity(1, 2), np.zeros((1, 3)), np.array([[0.9, 0.8, 0.3]]), np.zeros((1, 0)),
            [native.IkEffector(1)])
    plain = native.ik_solve(*args)
    same = native.ik_solve(*args, joints=native.IkJoints(), options=native.IkOptions())
    np.testing.assert_array_equal(plain.rotations, same.rotations)
    capped = native.ik_solve(*args, options=native.IkOptions(max_iterations=1))
    assert plain.iterations[0] > 1 and capped.iterations[0] == 1
    locked = native.ik_solve(*args, joints=native.IkJoints(locked=np.ones((2, 3), dtype=bool)))
    np.testing.assert_array_equal(locked.rotations, args[1])  # every axis locked: nothing moves


def test_part_of_a_rig_solves_as_the_whole_given_its_size(native):
    """The add-on solves only the effectors' bones and their ancestors: with the whole rig's size (which
    the damping and the regulariser's fade scale with) the part gives the whole's numbers, bit for bit;
    and effectors that share no unknown give the same numbers on one thread as on two."""
    # A root with two 3-bone arms; the whole rig also has a long tail the effector does not hang from.
    names, parents, heads, lengths = ["root"], [-1], [[0.0, 0.0, 0.0]], [0.2]
    for side in (1.0, -1.0):
        for i in range(3):
            names.append(f"arm{side:+.0f}{i}")
            parents.append(0 if i == 0 else len(names) - 2)
            heads.append([side * 0.3 * i, 0.0, 0.2])
            lengths.append(0.3)
    for i in range(4):
        names.append(f"tail{i}")
        parents.append(0 if i == 0 else len(names) - 2)
        heads.append([0.0, -1.0 * i - 0.5, 0.0])
        lengths.append(1.0)
    n = len(names)
    rest = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    rest[1:7] = [np.cos(-np.pi / 4), 0.0, 0.0, np.sin(-np.pi / 4)]
    whole = native.Rig(names, parents, rest, np.array(heads), np.array(lengths))
    frames = 30
    rotations = identity(frames, n)
    t = np.linspace(0, 1, frames)[:, None]
    targets = np.hstack([[0.5, 0.3, 0.2] + 0.1 * np.sin(3 * t), [-0.5, 0.3, 0.2] + 0.1 * np.cos(2 * t)])
    effectors = [native.IkEffector(3), native.IkEffector(6)]
    out = native.ik_solve(whole, rotations, np.zeros((1, 3)), targets, np.zeros((frames, 0)), effectors,
                          options=native.IkOptions(threads=1))
    part = list(range(7))
    piece = native.Rig([names[i] for i in part], [parents[i] for i in part], rest[part], np.array(heads)[part],
                       np.array(lengths)[part])
    size = float(np.linalg.norm(np.ptp(np.vstack([heads, whole_tails(heads, rest, lengths)]), axis=0)))
    for threads in (1, 2):
        got = native.ik_solve(piece, identity(frames, 7), np.zeros((1, 3)), targets, np.zeros((frames, 0)),
                              effectors, options=native.IkOptions(size=size, threads=threads))
        np.testing.assert_array_equal(got.rotations, out.rotations[:, :28])
        np.testing.assert_array_equal(got.errors, out.errors)
    # Judged by the test's own forward kinematics (scipy) of the returned pose, not the solver's errors.
    _, _, tails = rig_fk.pose(parents, rest, np.array(heads), np.array(lengths), out.rotations,
                              out.root_locations)
    missed = max(np.linalg.norm(tails[:, 3] - targets[:, 0:3], axis=1).max(),
                 np.linalg.norm(tails[:, 6] - targets[:, 3:6], axis=1).max())
    print(f"\ntwo arms on their targets: worst {missed:.2e} (rig size {size:.2f})")
    assert missed < MET


def whole_tails(heads, rest, lengths):
    """Rest tails: each head plus its rest orientation's Y axis times the length."""
    w, x, y, z = np.asarray(rest).T
    y_axis = np.stack([2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)], axis=1)
    return np.asarray(heads) + np.asarray(lengths)[:, None] * y_axis
