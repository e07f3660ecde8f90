"""The measure against Mixamo's own retargets (tests/common/san_protocol.py) held to references of its own:
scipy's rotations, the repository's quaternion forward kinematics (tests/common/bvh_reference.py), and
figures worked out by hand."""
import os

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import bvh_reference
import san_protocol as sp

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAN = os.path.join(os.path.dirname(ROOT), "shared", "data", "pairs", "san")


@pytest.fixture(scope="module")
def clip():
    path = os.path.join(SAN, "Aj", "Jumping.bvh")
    if not os.path.isfile(path):
        if os.environ.get("CI") == "true":
            pytest.fail(f"{path} is missing, and CI=true requires it")
        pytest.skip(f"{path} is absent (set up ../shared to run this test)")
    return sp.read_bvh(path)


def test_reads_the_hierarchy_without_end_sites(clip):
    assert len(clip.names) == 74 and clip.values.shape == (133, 225)  # 74 JOINTs, 6 + 73 x 3 channels
    assert clip.names[:3] == ["Hips", "Pelvis", "LeftUpLeg"] and clip.parents[:3] == [-1, 0, 1]
    np.testing.assert_array_equal(clip.offsets[2], [8.4797, -4.795502, -0.3791])
    assert abs(clip.frame_time - 0.016667) < 1e-12


def test_local_rotations_are_scipy_intrinsic_eulers_in_file_order(clip):
    """XYZ channels compose as R_x R_y R_z: scipy's intrinsic "XYZ". Float64 throughout: 1e-12."""
    rotations = sp.local_rotations(clip)
    for j in (0, 5, 30):
        angles = clip.values[:, clip.first[j] + len(clip.channels[j]) - 3:clip.first[j] + len(clip.channels[j])]
        expected = Rotation.from_euler("XYZ", angles, degrees=True).as_matrix()
        np.testing.assert_allclose(rotations[:, j], expected, rtol=0, atol=1e-12)


class _Skeleton:
    """The clip's hierarchy as bvh_reference reads it."""

    def __init__(self, clip):
        self.parents, self.offsets, self.channels, self.first_channels = (clip.parents, clip.offsets,
                                                                          clip.channels, clip.first)

    def __len__(self):
        return len(self.parents)


def test_forward_kinematics_agrees_with_the_quaternion_reference(clip):
    """Two float64 implementations (matrices here, quaternions there) over a 150 cm body: 1e-9 cm."""
    expected, _ = bvh_reference.forward_kinematics(_Skeleton(clip), clip.values)
    np.testing.assert_allclose(sp.clip_positions(clip), expected, rtol=0, atol=1e-9)


def test_height_is_the_toe_to_head_path_through_the_tree():
    """Root, a pelvis (zero offset), a 3-4-5 leg and toe, a spine and head: 5 + 2 + 3 + 4 = 14."""
    names = ["Hips", "Pelvis", "LeftUpLeg", "LeftToeBase", "Spine", "Head", "Hat"]
    parents = [-1, 0, 1, 2, 0, 4, 5]
    offsets = np.array([[0, 90, 0], [0, 0, 0], [3, -4, 0], [0, -2, 0], [0, 3, 0], [0, 4, 0], [0, 9, 0]], float)
    assert sp.height(names, parents, offsets) == pytest.approx(14.0, abs=1e-12)


def test_errors_split_the_root_from_the_pose():
    """Every joint moved by d along x: d/h over all joints, nothing in the pose, SAN's mean over the three
    coordinates d^2 / 3 / h^2 (x1000); one joint of four moved by d relative to the hips: d/4/h in both."""
    rng = np.random.default_rng(5)
    reference = rng.normal(size=(7, 4, 3))
    moved = reference + [2.0, 0.0, 0.0]
    figures = sp.errors(moved, reference, 10.0)
    assert figures["all"] == pytest.approx(20.0) and figures["pose"] == pytest.approx(0.0, abs=1e-12)
    assert figures["san_mse"] == pytest.approx(1000.0 * 4.0 / 3.0 / 100.0)
    bent = reference.copy()
    bent[:, 2] += [0.0, 0.0, 2.0]
    figures = sp.errors(bent, reference, 10.0)
    assert figures["all"] == pytest.approx(5.0) and figures["pose"] == pytest.approx(5.0)


def test_plain_copy_of_a_clip_onto_itself_is_the_clip(clip):
    np.testing.assert_allclose(sp.plain_copy(clip, clip), sp.clip_positions(clip), rtol=0, atol=1e-9)
