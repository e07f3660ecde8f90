"""core/control_rig: the control rig maps (JSON), the measured parent relations and the keys' mathematics."""
import copy
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core import control_rig as cr

RNG = np.random.default_rng(5)


def _matrix(rotation, t):
    m = np.eye(4)
    m[:3, :3] = rotation.as_matrix()
    m[:3, 3] = t
    return m


def _random(n):
    return np.array([_matrix(r, RNG.normal(size=3)) for r in Rotation.random(n, random_state=RNG.integers(1 << 30))])


def test_the_rigify_preset_reads_and_names_its_bones():
    rigify = cr.presets()["rigify"]
    assert rigify.label == "Rigify" and rigify.detect_property == "rig_id"
    names = rigify.bones_named()
    for bone in ("torso", "upper_arm_fk.L", "hand_ik.R", "thigh_ik_target.L", "DEF-spine.006", "MCH-shin_ik.R"):
        assert bone in names
    assert [limb.name for limb in rigify.limbs] == ["arm.L", "leg.L", "arm.R", "leg.R"]
    assert rigify.limb("leg.L").switch.property == "IK_FK"
    assert rigify.missing(names) == [] and rigify.missing(names[1:]) == [names[0]]
    assert cr.detect(names, ["rig_id"]) is rigify and cr.detect(names, []) is None
    assert cr.metarig_of(["rigify_type"]) is rigify


def test_limb_modes():
    rigify = cr.presets()["rigify"]
    assert cr.limb_modes(rigify, "auto") == {"arm.L": "fk", "leg.L": "ik", "arm.R": "fk", "leg.R": "ik"}
    assert set(cr.limb_modes(rigify, "ik").values()) == {"ik"}
    assert cr.limb_modes(rigify, "fk", {"leg.R": "ik"})["leg.R"] == "ik"
    with pytest.raises(ValueError, match="no limb 'leg.X'"):
        cr.limb_modes(rigify, "auto", {"leg.X": "ik"})
    with pytest.raises(ValueError, match="mode must be 'fk' or 'ik'"):
        cr.limb_modes(rigify, "auto", {"leg.L": "both"})
    with pytest.raises(ValueError, match="controls must be"):
        cr.limb_modes(rigify, "sideways")


def _minimal():
    return {"format": cr.FORMAT, "version": 1, "id": "mini",
            "controls": [{"control": "C-hips", "bone": "hips", "location": True}],
            "limbs": [{"name": "leg.L", "kind": "leg", "chain": ["thigh", "shin", "foot"],
                       "fk": [{"control": "C-thigh", "bone": "thigh"}],
                       "ik": [{"control": "IK-foot", "bone": "foot", "location": True}],
                       "pole": "IK-pole", "switch": {"bone": "props", "property": "ik", "fk": 0, "ik": 1}}]}


@pytest.mark.parametrize("change, message", [
    (lambda d: d.update(format="other"), '"format" must be'),
    (lambda d: d.update(version=2), 'unsupported "version" 2'),
    (lambda d: d.update(extra=1), r"unknown key\(s\) \['extra'\]"),
    (lambda d: d["controls"][0].update(bone=""), '"bone" must be a bone name'),
    (lambda d: d["controls"][0].update(location="yes"), '"location" must be true or false'),
    (lambda d: d["limbs"][0].update(chain=["a", "b"]), "three deform bones"),
    (lambda d: d["limbs"][0].update(kind="tail"), '"kind" must be'),
    (lambda d: d["limbs"][0].pop("switch"), 'needs a "switch"'),
    (lambda d: d["limbs"][0]["switch"].update(ik="on"), '"ik" must be a finite number'),
    (lambda d: d["limbs"][0].update(ik=[{"control": "IK-x", "bone": "shin"}]), "must drive the chain's end bone"),
    (lambda d: d["controls"].append({"control": "C-thigh", "bone": "thigh"}), "keyed by two entries"),
    (lambda d: d.update(controls=[], limbs=[]), "nothing to key"),
    (lambda d: d.update(skeleton=[{"bone": "hips"}]), "not in \"skeleton\""),
])
def test_map_errors_name_the_place(change, message, tmp_path):
    data = _minimal()
    change(data)
    path = tmp_path / "rig.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(ValueError, match=message) as error:
        cr.load(path)
    assert str(path) in str(error.value)


def test_map_file_that_is_not_json_says_the_line(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{\n "format": "motionkit-control-rig",\n "version": 1,,\n}', encoding="utf-8")
    with pytest.raises(ValueError, match=r"broken.json, line 3: not JSON"):
        cr.load(path)


def test_a_map_without_skeleton_takes_the_driven_bones():
    parsed = cr.parse(_minimal())
    assert {s.bone for s in parsed.skeleton} == {"hips", "thigh", "shin", "foot"}
    assert copy.deepcopy(parsed) == parsed


def test_quaternions_and_matrices_agree_with_scipy():
    rotations = Rotation.random(500, random_state=3)
    q_xyzw = rotations.as_quat()
    q = np.concatenate([q_xyzw[:, 3:], q_xyzw[:, :3]], axis=1)
    m = cr.matrices(q, RNG.normal(size=(500, 3)))
    assert np.allclose(m[:, :3, :3], rotations.as_matrix(), atol=1e-12)
    back = cr.quaternions(m)
    assert np.allclose(np.abs(np.sum(back * q, axis=1)), 1.0, atol=1e-12)
    # Near-half turns, where the trace is smallest (the other branches of Shepperd's method).
    half = Rotation.from_rotvec(np.pi * 0.999999 * np.eye(3))
    h = half.as_quat()
    got = cr.quaternions(cr.matrices(np.concatenate([h[:, 3:], h[:, :3]], axis=1), np.zeros((3, 3))))
    assert np.allclose(np.abs(np.sum(got * np.concatenate([h[:, 3:], h[:, :3]], axis=1), axis=1)), 1, atol=1e-12)


def test_fit_relation_finds_a_rigid_follower_and_a_split_one():
    samples = 5
    a, b, c = _random(samples), _random(samples), _random(samples)
    offset = _random(1)[0]
    rigid = b @ offset
    relation, why = cr.fit_relation(rigid, {"a": a, "b": b, "c": c}, size=1.0)
    assert why == "" and relation.rigid and relation.rotation_of == "b"
    assert np.allclose(relation.evaluate({"a": a, "b": b, "c": c}.__getitem__, samples), rigid, atol=1e-12)
    # A Copy Rotation from c at full influence: c's rotation, a's point.
    split = np.repeat(np.eye(4)[None], samples, axis=0)
    split[:, :3, :3] = c[:, :3, :3] @ offset[:3, :3]
    split[:, :3, 3] = (a @ np.array([0.1, 0.2, 0.3, 1.0]))[:, :3]
    relation, why = cr.fit_relation(split, {"a": a, "b": b, "c": c}, size=1.0)
    assert (relation.rotation_of, relation.location_of) == ("c", "a") and not relation.rigid
    assert np.allclose(relation.evaluate({"a": a, "b": b, "c": c}.__getitem__, samples), split, atol=1e-12)
    # The armature itself (None) when it does not move; nothing at all for a blend.
    fixed = np.repeat(offset[None], samples, axis=0)
    assert cr.fit_relation(fixed, {"a": a}, size=1.0)[0].rotation_of is None
    blend = np.array([_matrix(Rotation.from_matrix(x[:3, :3]) * Rotation.from_rotvec([0.3 * k, 0, 0]), x[:3, 3])
                      for k, x in enumerate(a)])
    relation, why = cr.fit_relation(blend, {"a": a, "b": b}, size=1.0)
    assert relation is None and "rotation follows no single bone" in why
    scaled = rigid.copy()
    scaled[:, :3, :3] *= 1.1
    assert "scaled" in cr.fit_relation(scaled, {"b": b}, size=1.0)[1]


def test_order_puts_parents_first_and_names_a_cycle():
    eye = np.eye(3)
    rel = lambda k: cr.Relation(k, eye, k, np.zeros(3))  # noqa: E731
    assert cr.order({"c2": rel("c1"), "c1": rel("d0"), "c3": rel("c2")}, {"d0"}) == ["c1", "c2", "c3"]
    with pytest.raises(ValueError, match="cycle"):
        cr.order({"c1": rel("c2"), "c2": rel("c1")}, set())


def test_basis_puts_the_bone_at_its_target_with_and_without_local_location():
    parent, target = _random(50), _random(50)
    offset = _random(1)[0]
    b = cr.basis(parent, offset, target)
    assert np.allclose(parent @ offset @ b, target, atol=1e-10)
    b = cr.basis(parent, offset, target, local_location=False)
    translation = np.repeat(np.eye(4)[None], 50, axis=0)
    translation[:, :3, 3] = b[:, :3, 3]
    rotation = b.copy()
    rotation[:, :3, 3] = 0
    assert np.allclose(parent @ translation @ offset @ rotation, target, atol=1e-10)


def test_pole_positions_lie_in_the_limb_plane_on_the_bent_side():
    n = 200
    upper = RNG.normal(size=(n, 3))
    end = upper + RNG.normal(size=(n, 3))
    bend = np.cross(end - upper, RNG.normal(size=(n, 3)))
    bend *= (RNG.uniform(0.05, 0.5, size=(n, 1)) / np.linalg.norm(bend, axis=1, keepdims=True))
    lower = (upper + end) / 2 + bend
    fallback = RNG.normal(size=(n, 3))
    distance, bias = 0.7, 1e-3
    pole = cr.pole_positions(upper, lower, end, fallback, distance, bias)
    normal = np.cross(end - upper, lower - upper)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    off_plane = np.abs(np.sum((pole - lower) * normal, axis=1))
    # Per sample: the straight-limb bias (bias x the limb's length, sideways) against this sample's bend
    # tilts the pole out of the plane by at most bias * length / (|bend| - bias * length).
    length = np.linalg.norm(end - upper, axis=1)
    tilt = bias * length / (np.linalg.norm(bend, axis=1) - bias * length)
    assert np.max(off_plane / (distance * tilt)) <= 1 + 1e-9
    assert np.allclose(np.linalg.norm(pole - lower, axis=1), distance)
    assert np.all(np.sum((pole - lower) * bend, axis=1) > 0)
    # A straight limb keeps a plane: the one through the limb and the fallback, on the fallback's side,
    # square to the limb.
    straight = cr.pole_positions(upper, (upper + end) / 2, end, fallback, distance, bias)
    out = straight - (upper + end) / 2
    axis = (end - upper) / length[:, None]
    plane_normal = np.cross(axis, fallback)
    plane_normal /= np.linalg.norm(plane_normal, axis=1, keepdims=True)
    assert np.abs(np.sum(out * plane_normal, axis=1)).max() < 1e-12 * distance
    assert np.abs(np.sum(out * axis, axis=1)).max() < 1e-12 * distance
    assert np.all(np.sum(out * fallback, axis=1) > 0)
    assert np.allclose(np.linalg.norm(out, axis=1), distance)
