"""core/reference_pose: which chains keep the target's posture and which take the source's direction."""
import json

import numpy as np
import pytest

from core import bone_mapping as bm
from core import reference_pose as rp


def _body(prefix=""):
    limbs = {}
    for s in bm.SIDES:
        for key in bm.ARM_KEYS + bm.LEG_KEYS:
            limbs[f"{key}.{s}"] = f"{prefix}{key}.{s}"
    return bm.Body(hips="hips", spine=["spine"], neck=["neck"], head="head", limbs=limbs,
                   fingers={"index.L": ["index1.L", "index2.L"]})


def _heads(arm_drop_deg=0.0, leg_spread_deg=0.0, knee_bend_deg=0.0):
    """A figure facing -Y, left at +X: arms out at arm_drop_deg below horizontal, legs spread by
    leg_spread_deg from vertical, knees bent forward by knee_bend_deg with the ankle kept under the hip."""
    heads = {"hips": (0, 0, 1.0), "spine": (0, 0, 1.1), "neck": (0, 0, 1.5), "head": (0, 0, 1.6)}
    drop, spread, bend = np.radians([arm_drop_deg, leg_spread_deg, knee_bend_deg])
    for s, x in (("L", 1.0), ("R", -1.0)):
        shoulder = np.array([0.05 * x, 0, 1.45])
        arm = np.array([x * np.cos(drop), 0, -np.sin(drop)])
        heads[f"shoulder.{s}"] = shoulder
        heads[f"upper_arm.{s}"] = shoulder + 0.1 * np.array([x, 0, 0])
        for i, key in enumerate(("forearm", "hand"), start=1):
            heads[f"{key}.{s}"] = heads[f"upper_arm.{s}"] + 0.3 * i * arm
        hip = np.array([0.1 * x, 0, 0.95])
        down = np.array([x * np.sin(spread), 0, -np.cos(spread)])
        knee = hip + 0.45 * down + 0.45 * np.sin(bend) * np.array([0, -1, 0])
        heads.update({f"thigh.{s}": hip, f"shin.{s}": knee, f"foot.{s}": hip + 0.9 * np.cos(bend) * down,
                      f"toe.{s}": hip + 0.9 * np.cos(bend) * down + np.array([0, -0.1, 0])})
    return {name: np.asarray(p, dtype=float) for name, p in heads.items()}


def _limbs(**pose):
    return rp.Limbs(_body(), _heads(**pose))


def _modes(chains):
    return {c.chain: c.mode for c in chains}


def test_alike_rigs_keep_every_posture_but_the_fingers():
    chains = rp.decide(_limbs(), _limbs(knee_bend_deg=20.0))
    assert _modes(chains) == {"trunk": "KEEP", "arm.L": "KEEP", "arm.R": "KEEP", "leg.L": "KEEP", "leg.R": "KEEP",
                              "fingers.L": "MATCH", "fingers.R": "MATCH"}
    assert not any(c.by_user for c in chains)


def test_t_against_a_arms_and_spread_legs_are_poses_and_matched():
    chains = {c.chain: c for c in rp.decide(_limbs(leg_spread_deg=45.0), _limbs(arm_drop_deg=45.0))}
    for side in bm.SIDES:
        # The limbs' lines, from the built figures: 45 degrees apart, to the rounding of the trigonometry.
        assert chains[f"arm.{side}"].mode == "MATCH" and chains[f"arm.{side}"].angle == pytest.approx(45.0, abs=1e-9)
        assert chains[f"leg.{side}"].mode == "MATCH" and chains[f"leg.{side}"].angle == pytest.approx(45.0, abs=1e-9)
    assert chains["trunk"].mode == "KEEP"


def test_the_threshold_lies_between_a_lowered_arm_and_an_a_pose():
    below = _modes(rp.decide(_limbs(), _limbs(arm_drop_deg=rp.LIMB_POSE_ANGLE - 0.5)))
    above = _modes(rp.decide(_limbs(), _limbs(arm_drop_deg=rp.LIMB_POSE_ANGLE + 0.5)))
    assert below["arm.L"] == "KEEP" and above["arm.L"] == "MATCH"


def test_the_users_modes_win_and_are_marked():
    chains = {c.chain: c for c in rp.decide(_limbs(), _limbs(arm_drop_deg=45.0), {"arm.L": "KEEP",
                                                                                  "trunk": "MATCH"})}
    assert (chains["arm.L"].mode, chains["arm.L"].by_user) == ("KEEP", True)
    assert (chains["trunk"].mode, chains["trunk"].by_user) == ("MATCH", True)
    assert (chains["arm.R"].mode, chains["arm.R"].by_user) == ("MATCH", False)


def test_an_unlabelled_limb_is_matched_and_measured_as_nothing():
    body = _body()
    del body.limbs["thigh.L"]
    chains = {c.chain: c for c in rp.decide(rp.Limbs(body, _heads()), _limbs())}
    assert chains["leg.L"].mode == "MATCH" and np.isnan(chains["leg.L"].angle)


@pytest.mark.parametrize("modes, message", [
    ({"spine": "KEEP"}, "unknown chain 'spine'"),
    ({"arm.L": "keep"}, "unknown mode 'keep'"),
])
def test_bad_modes_are_named(modes, message):
    with pytest.raises(ValueError, match=message):
        rp.decide(_limbs(), _limbs(), modes)


def test_kept_bones_follow_the_nearest_labelled_bone_above():
    body = _body()
    names = ["root", "hips", "pelvis", "thigh.L", "spine", "shoulder.L", "upper_arm.L", "upper_arm_twist.L",
             "hand.L", "index1.L", "thumb_helper.L", "index2.L"]
    parents = [-1, 0, 1, 2, 1, 4, 5, 6, 6, 8, 8, 9]
    chains = rp.decide(_limbs(), _limbs(arm_drop_deg=45.0))  # arms matched, trunk and legs kept
    kept = {names[b] for b in rp.kept_bones(names, parents, body, chains)}
    # The floor root above the hips is on no chain; the pelvis between hips and thigh is the trunk's; a
    # twist bone is its limb's; an unlabelled bone under the hand is that hand's fingers'.
    assert kept == {"hips", "pelvis", "thigh.L", "spine"}
    keep_all = rp.decide(_limbs(), _limbs(), {c: "KEEP" for c in rp.CHAINS})
    kept = {names[b] for b in rp.kept_bones(names, parents, body, keep_all)}
    assert kept == set(names) - {"root"}


def test_chain_modes_are_saved_with_the_map(tmp_path):
    path = tmp_path / "map.json"
    bm.save_map(path, [("Hips", "hips")], chains={"trunk": "MATCH", "arm.L": "KEEP"})
    assert json.loads(path.read_text())["version"] == 2
    assert bm.load_map(path) == [("Hips", "hips")]
    assert bm.load_chains(path) == {"trunk": "MATCH", "arm.L": "KEEP"}
    bm.save_map(path, [("Hips", "hips")])
    assert json.loads(path.read_text())["version"] == 1 and bm.load_chains(path) == {}


def test_bad_chain_modes_in_a_map_name_the_file(tmp_path):
    path = tmp_path / "map.json"
    path.write_text(json.dumps({"format": bm.MAP_FORMAT, "version": 2, "pairs": [], "chains": {"tail": "KEEP"}}))
    with pytest.raises(ValueError, match=r"map\.json: chain_modes: unknown chain 'tail'"):
        bm.load_chains(path)


def test_a_trunk_lying_another_way_or_a_zero_pose_matches_every_chain():
    lying = {name: np.array([p[2], p[1], -p[0]]) for name, p in _heads().items()}  # turned 90 deg about Y
    chains = rp.decide(_limbs(), rp.Limbs(_body(), lying))
    assert _modes(chains) == {c: "MATCH" for c in rp.CHAINS}
    assert {c.chain: round(c.angle, 9) for c in chains}["trunk"] == 90.0
    zero = rp.Limbs(_body(), _heads(), zero_pose=True)
    assert _modes(rp.decide(_limbs(), zero)) == {c: "MATCH" for c in rp.CHAINS}
    assert _modes(rp.decide(zero, _limbs(), {"trunk": "KEEP"}))["trunk"] == "KEEP"


def test_a_trunk_leaning_less_than_a_pose_keeps():
    lean = np.radians(rp.TRUNK_POSE_ANGLE - 1.0)
    heads = _heads()
    hips = heads["hips"]
    for name in ("spine", "neck", "head"):
        v = heads[name] - hips
        heads[name] = hips + np.array([v[0], -np.sin(lean) * v[2], np.cos(lean) * v[2]])
    assert _modes(rp.decide(_limbs(), rp.Limbs(_body(), heads)))["trunk"] == "KEEP"
