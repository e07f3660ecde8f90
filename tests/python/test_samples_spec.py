"""The sample characters differ the way real rigs differ, and the walk's math is right."""
import math

import characters
import numpy as np
import pytest
import walk
from scipy.spatial.transform import Rotation

SPECS = {s.name: s for s in characters.CHARACTERS}


@pytest.mark.parametrize("spec", characters.CHARACTERS, ids=lambda s: s.name)
def test_parents_come_before_children_and_names_are_unique(spec):
    seen = set()
    for bone in spec.bones:
        assert bone.parent is None or bone.parent in seen, bone.name
        seen.add(bone.name)
    assert len(seen) == len(spec.bones)
    assert sum(b.parent is None for b in spec.bones) == 1


@pytest.mark.parametrize("spec", characters.CHARACTERS, ids=lambda s: s.name)
def test_height_is_the_top_of_the_head(spec):
    assert spec.bone("head").tail[2] == pytest.approx(spec.proportions.height)
    feet = [b for b in spec.bones if b.canonical != "root"]  # a floor root lies on Z = 0
    assert min(b.tail[2] for b in feet) == pytest.approx(0.025)  # toes on the floor


def test_naming_schemes():
    assert SPECS["MixamoT"].canonical["thigh.L"] == "mixamorig:LeftUpLeg"
    assert SPECS["MixamoT"].canonical["shoulder.R"] == "mixamorig:RightShoulder"
    assert SPECS["RigifyA"].canonical["upper_arm.L"] == "upper_arm.L"
    assert SPECS["RigifyA"].canonical["neck.2"] == "spine.005"
    assert SPECS["UnrealA"].canonical["shin.R"] == "calf_r"


def _direction(bone):
    d = np.subtract(bone.tail, bone.head)
    return d / np.linalg.norm(d)


def test_t_pose_and_a_pose_arms():
    t_arm = _direction(SPECS["MixamoT"].bone("upper_arm.L"))
    a_arm = _direction(SPECS["RigifyA"].bone("upper_arm.L"))
    np.testing.assert_allclose(t_arm, [1, 0, 0], atol=1e-12)
    assert math.degrees(math.asin(-a_arm[2])) == pytest.approx(45.0)
    odd = _direction(SPECS["UnrealA"].bone("upper_arm.L"))
    assert odd[1] < -0.1  # arms forward of the coronal plane too


def test_proportions_rolls_and_chain_lengths_differ():
    heights = {s.proportions.height for s in characters.CHARACTERS}
    assert len(heights) == 3
    rolls = {s.name: s.bone("forearm.L").roll for s in characters.CHARACTERS}
    assert len(set(rolls.values())) == 3
    assert len([k for k in SPECS["RigifyA"].canonical if k.startswith("neck.")]) == 2
    assert len([k for k in SPECS["MixamoT"].canonical if k.startswith("neck.")]) == 1


def _scipy(q):
    """(w, x, y, z) -> scipy Rotation (which takes x, y, z, w)."""
    return Rotation.from_quat(np.roll(q, -1, axis=-1))


def test_quaternion_helpers_agree_with_scipy():
    rng = np.random.default_rng(3)
    a = np.roll(Rotation.random(50, random_state=1).as_quat(), 1, axis=-1)
    b = np.roll(Rotation.random(50, random_state=2).as_quat(), 1, axis=-1)
    v = rng.normal(size=(50, 3))
    np.testing.assert_allclose(_scipy(walk.mul(a, b)).as_matrix(), (_scipy(a) * _scipy(b)).as_matrix(),
                               atol=1e-12)
    np.testing.assert_allclose(walk.rotate(a, v), _scipy(a).apply(v), atol=1e-12)
    q = walk.axis_angle((0.0, 0.0, 1.0), np.array([0.3]))
    np.testing.assert_allclose(_scipy(q).as_rotvec(), [[0, 0, 0.3]], atol=1e-12)


def test_local_rotations_rebuild_the_authored_global_ones():
    """Composing M_i down the chain from random rest frames gives back Q_i = G_i B_i."""
    spec = SPECS["RigifyA"]
    times = np.linspace(0.0, 1.0, 7)
    G, _ = walk.global_rotations(spec, times)
    rest = {b.canonical: np.roll(Rotation.random(random_state=i).as_quat(), 1)
            for i, b in enumerate(spec.bones)}
    local = walk.local_rotations(spec, rest, G)
    by_name = {b.name: b for b in spec.bones}
    pose = {}
    for bone in spec.bones:
        B = _scipy(rest[bone.canonical])
        if bone.parent is None:
            pose[bone.name] = B * _scipy(local[bone.canonical])
        else:
            parent = by_name[bone.parent]
            Bp = _scipy(rest[parent.canonical])
            pose[bone.name] = pose[bone.parent] * Bp.inv() * B * _scipy(local[bone.canonical])
        expected = _scipy(G[bone.canonical]) * B
        np.testing.assert_allclose(pose[bone.name].as_matrix(), expected.as_matrix(), atol=1e-12)


def test_walk_loops_and_keeps_quaternions_continuous():
    spec = SPECS["MixamoT"]
    times = np.arange(61) / 30.0
    G, offset = walk.global_rotations(spec, times)
    rest = {b.canonical: np.array([1.0, 0.0, 0.0, 0.0]) for b in spec.bones}
    for key, q in walk.local_rotations(spec, rest, G).items():
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
        assert np.all(np.sum(q[1:] * q[:-1], axis=1) > 0.9), key  # no hemisphere flips
        np.testing.assert_allclose(q[0], q[-1], atol=1e-12)  # two whole cycles
    assert offset[-1, 1] == pytest.approx(-2 * walk.SPEED * walk.CYCLE_SECONDS)
