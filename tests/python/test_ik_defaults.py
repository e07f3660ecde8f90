"""core/ik_defaults.py without Blender: the natural defaults on a hand-built humanoid and the mass model."""
import numpy as np
import pytest
from core import bone_mapping, ik_defaults


def humanoid():
    """A T-pose humanoid facing -Y, Z up, its rest frames with the bones' Y along them (rolls: X sideways
    or forwards as Blender's default roll gives)."""
    bones = []

    def add(name, parent, head, tail):
        bones.append((name, parent, np.array(head, float), np.array(tail, float)))

    add("hips", None, (0, 0, 1.0), (0, 0, 1.1))
    add("spine", "hips", (0, 0, 1.1), (0, 0, 1.3))
    add("chest", "spine", (0, 0, 1.3), (0, 0, 1.5))
    add("neck", "chest", (0, 0, 1.5), (0, 0, 1.6))
    add("head", "neck", (0, 0, 1.6), (0, 0, 1.8))
    for side, s in (("L", 1), ("R", -1)):
        add(f"shoulder.{side}", "chest", (0.02 * s, 0, 1.45), (0.18 * s, 0, 1.45))
        add(f"upper_arm.{side}", f"shoulder.{side}", (0.18 * s, 0, 1.45), (0.46 * s, 0, 1.45))
        add(f"forearm.{side}", f"upper_arm.{side}", (0.46 * s, 0, 1.45), (0.72 * s, 0, 1.45))
        add(f"hand.{side}", f"forearm.{side}", (0.72 * s, 0, 1.45), (0.8 * s, 0, 1.45))
        add(f"thigh.{side}", "hips", (0.1 * s, 0, 1.0), (0.1 * s, -0.01, 0.52))
        add(f"shin.{side}", f"thigh.{side}", (0.1 * s, -0.01, 0.52), (0.1 * s, 0, 0.1))
        add(f"foot.{side}", f"shin.{side}", (0.1 * s, 0, 0.1), (0.1 * s, -0.12, 0.03))
        add(f"toe.{side}", f"foot.{side}", (0.1 * s, -0.12, 0.03), (0.1 * s, -0.18, 0.03))
    names = [b[0] for b in bones]
    rig = bone_mapping.Rig(tuple(names), tuple(-1 if b[1] is None else names.index(b[1]) for b in bones),
                           np.array([b[2] for b in bones]), np.array([b[3] for b in bones]))
    axes = []
    for _, _, head, tail in bones:
        y = (tail - head) / np.linalg.norm(tail - head)
        up = np.array([0.0, 0.0, 1.0]) if abs(y[2]) < 0.9 else np.array([0.0, -1.0, 0.0])
        x = np.cross(y, up)
        x /= np.linalg.norm(x)
        axes.append(np.stack([x, y, np.cross(x, y)], axis=1))
    return rig, np.array(axes)


@pytest.fixture(scope="module")
def body():
    rig, axes = humanoid()
    labels = bone_mapping.classify(rig)
    return rig, axes, labels, ik_defaults.natural_joints(rig, labels, axes)


def test_a_humanoid_is_recognised_and_faces_where_its_feet_point(body):
    rig, _, labels, joints = body
    assert ik_defaults.is_humanoid(labels)
    np.testing.assert_allclose(joints.facing, [0.0, -1.0, 0.0], atol=1e-12)
    assert not ik_defaults.is_humanoid(bone_mapping.Body())


def test_stages_stiffness_and_masses(body):
    rig, _, labels, joints = body
    index = {n: i for i, n in enumerate(rig.names)}
    assert joints.stage[index[labels.hips]] == 2
    assert all(joints.stage[index[n]] == 1 for n in labels.spine)
    for key in ("shoulder.L", "upper_arm.L", "forearm.L", "hand.L", "thigh.R", "shin.R", "foot.R"):
        assert joints.stage[index[labels.limbs[key]]] == 0, key
    assert joints.stiffness[index[labels.spine[0]], 0] == pytest.approx(0.3)
    assert joints.mass.sum() == pytest.approx(1.0)
    # de Leva: a thigh is 14.16 % of the body, the trunk (hips, spine, clavicles) 43.46 %.
    assert joints.mass[index[labels.limbs["thigh.L"]]] == pytest.approx(0.1416, rel=1e-9)
    trunk = [index[n] for n in [labels.hips, *labels.spine, labels.limbs["shoulder.L"], labels.limbs["shoulder.R"]]]
    assert joints.mass[trunk].sum() == pytest.approx(0.4346, rel=1e-9)


def test_hinges_bend_the_human_way(body):
    """A knee's positive range moves the ankle backwards (+Y here), an elbow's moves the hand forwards (-Y):
    checked by turning the bone about the chosen axis through the whole range's far end."""
    rig, axes, labels, joints = body
    index = {n: i for i, n in enumerate(rig.names)}
    for key, towards in (("shin.L", np.array([0.0, 1.0, 0.0])), ("forearm.R", np.array([0.0, -1.0, 0.0]))):
        b = index[labels.limbs[key]]
        width = joints.limit_max[b] - joints.limit_min[b]
        axis = 0 if width[0] >= width[2] else 2
        far = joints.limit_max[b, axis] if joints.limit_max[b, axis] > -joints.limit_min[b, axis] \
            else joints.limit_min[b, axis]
        assert np.degrees(abs(far)) == pytest.approx(150.0)
        assert min(abs(joints.limit_max[b, axis]), abs(joints.limit_min[b, axis])) == 0.0  # straight: the stop
        a = axes[b][:, axis] * np.sign(far)
        moves = np.cross(a, axes[b][:, 1])  # the tail's motion for a positive turn about a
        assert moves @ towards > 0.9, key
        assert joints.soft[b].all()


def test_edited_settings_and_unknown_ones(body):
    rig, axes, labels, _ = body
    edited = ik_defaults.natural_joints(rig, labels, axes, ik_defaults.NaturalDefaults.from_dict({"knee_bend": 90}))
    b = rig.names.index(labels.limbs["shin.L"])
    assert np.degrees(np.max(edited.limit_max[b] - edited.limit_min[b])) == pytest.approx(90.0)
    with pytest.raises(ValueError, match="unknown natural-default settings: knee"):
        ik_defaults.NaturalDefaults.from_dict({"knee": 1})
