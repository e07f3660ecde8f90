"""core.rotation_keys: the F-curve channels and values a plan keys, each bone in the rotation mode its rig was
read with, judged by scipy (Blender's Euler 'XYZ' is scipy's extrinsic "xyz") and by the rotations they
stand for."""
import dataclasses

import characters
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core import rotation_channels
from core.rig_data import PoseChannels
from core.rotation_keys import Keyer, bone_path
from plain_rigs import from_spec
from rotations import quaternion_angles

# Quaternions back from Euler angles or axis-angle go through sin and cos of values of order pi: a few
# float64 ulps of pi (1e-15) each, well inside 1e-12.
ROUND_TRIP = 1e-12


def _wxyz(rotation):
    return np.roll(rotation.as_quat(), 1, axis=-1)


def _smooth(n, seed):
    vectors = np.cumsum(np.random.default_rng(seed).normal(scale=0.3, size=(n, 3)), axis=0)
    return _wxyz(Rotation.from_rotvec(vectors))


def test_each_bone_is_keyed_in_its_own_mode(core_native):
    modes = ("QUATERNION", "XYZ", "AXIS_ANGLE", "ZXY")
    previous = (np.array([1.0, 0, 0, 0]), np.zeros(3), np.array([0.0, 0, 1, 0]), np.zeros(3))
    keyer = Keyer(("a", 'b"q', "c", "d"), modes, previous)
    q = np.hstack([_smooth(200, seed) for seed in range(4)])
    channels, values = keyer(q)
    assert [c[0] for c in channels[:4]] == ['pose.bones["a"].rotation_quaternion'] * 4
    assert channels[4] == ('pose.bones["b\\"q"].rotation_euler', 0, 'b"q')
    assert values.shape == (4 + 3 + 4 + 3, 200)
    xyz = Rotation.from_euler("xyz", values[4:7].T)
    assert quaternion_angles(_wxyz(xyz), q[:, 4:8]).max() < ROUND_TRIP
    zxy = Rotation.from_euler("zxy", values[11:14][[2, 0, 1]].T)  # Blender's ZXY: Z, then X, then Y
    assert quaternion_angles(_wxyz(zxy), q[:, 12:16]).max() < ROUND_TRIP
    axis_angle = values[7:11].T
    back = rotation_channels.to_quaternions(core_native, "AXIS_ANGLE", axis_angle)
    assert quaternion_angles(back, q[:, 8:12]).max() < ROUND_TRIP


def test_keys_continue_from_where_the_bone_stands(core_native):
    """A quaternion key on the far hemisphere from the bone's current value is flipped onto its side, as
    Blender's own keying keeps a curve from jumping."""
    keyer = Keyer(("a",), ("QUATERNION",), (np.array([-1.0, 0, 0, 0]),))
    q = np.array([[1.0, 0, 0, 0], [np.cos(0.1), np.sin(0.1), 0, 0]])
    _, values = keyer(q)
    assert values[0, 0] == pytest.approx(-1.0) and values[0, 1] < 0


def test_placeholders_are_the_channels_alone(core_native):
    keyer = Keyer(("a", "b"), ("XYZ", "QUATERNION"), (np.zeros(3), np.array([1.0, 0, 0, 0])))
    channels, values = keyer(np.tile([1.0, 0, 0, 0], (5, 2)), placeholder=True)
    assert len(channels) == 7 and values.shape == (7, 5) and not values.any()


def test_a_rig_s_keyer_takes_its_modes_and_a_rig_without_channels_says_so(core_native):
    rig = from_spec(characters.MIXAMO_T)
    with pytest.raises(ValueError, match="no rotation modes"):
        Keyer.of(rig, [0])
    modes = tuple("XYZ" if i % 2 else "QUATERNION" for i in range(len(rig)))
    values = tuple(np.zeros(3) if m == "XYZ" else np.array([1.0, 0, 0, 0]) for m in modes)
    read = dataclasses.replace(rig, channels=PoseChannels(rig.name, modes, values, np.zeros((len(rig), 3))))
    keyer = Keyer.of(read, [1, 2])
    assert keyer.names == (rig.names[1], rig.names[2]) and keyer.modes == ("XYZ", "QUATERNION")
    assert np.allclose(read.channels.basis, [1.0, 0, 0, 0])


def test_a_rotation_that_is_none_is_refused_naming_the_rig(core_native):
    channels = PoseChannels("Rig", ("QUATERNION",), (np.zeros(4),), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="'Rig' pose rotation"):
        channels.basis


def test_a_bone_s_path_quotes_its_name():
    assert bone_path('arm "L"\\') == 'pose.bones["arm \\"L\\"\\\\"]'


def test_quaternion_keys_are_rotation_channels_own_continuity(core_native):
    """The quaternion keys' hemisphere continuity is rotation_channels.from_quaternions', flip for flip, on
    a clip whose quaternions are flipped at random, into a block of a larger array (out)."""
    rng = np.random.default_rng(5)
    q = np.hstack([_smooth(300, seed) for seed in range(3)]).reshape(300, 3, 4)
    q *= np.where(rng.random((300, 3, 1)) < 0.3, -1.0, 1.0)
    previous = np.array([[-1.0, 0, 0, 0], [1.0, 0, 0, 0], [0.0, 1.0, 0, 0]])
    expected = rotation_channels.from_quaternions(core_native, "QUATERNION", q, previous)
    out = np.full((20, 300), np.nan)
    _, values = Keyer(("a", "b", "c"), ("QUATERNION",) * 3, tuple(previous))(q.reshape(300, 12), out=out[4:16])
    assert np.shares_memory(values, out)
    assert np.array_equal(out[4:16], expected.transpose(1, 2, 0).reshape(12, 300))
    assert np.isnan(out[:4]).all() and np.isnan(out[16:]).all()
