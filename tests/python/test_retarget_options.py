"""core/retarget_options: the retarget's options as one validated value (no Blender needed).

The defaults are written out here as motionkit.retarget documents them (and as the Retarget panel's
properties default), not read from the code; every bad value must be refused with a ValueError that
names the option and the value; keywords and the dataclass must make the same options.
"""
import dataclasses
import math

import numpy as np
import pytest

from core import chain_modes, retarget_options
from core.foot_contacts import ContactSettings
from core.retarget_options import RetargetOptions, check_frame_range, from_keywords

DOCUMENTED_DEFAULTS = dict(
    root="scaled", scale_horizontal=1.0, source_match="REST", match_frame=None, target_match="REST",
    align_facing=True, floor_root="auto", root_smoothing=0.25, root_motion_onto="auto", plant_feet=None,
    contact_settings=None, source_floor=None, target_floor=None, floor_fit="legs", chain_modes=None, parts="whole",
    bones=None, into="new", blend="replace", influence=1.0, channels=("scale", "properties", "shape_keys"),
    channel_map=None, two_hands=True, prop_space="bone", body="auto", body_strength=1.0,
    body_touches=True)


def test_defaults_are_the_documented_ones_and_valid():
    options = RetargetOptions()
    assert dataclasses.asdict(options) == DOCUMENTED_DEFAULTS
    assert options.validate() is options


def test_every_field_is_an_option_and_the_data_are_not():
    """plan()'s options, one field each; the bone map and the frame range stay the call's arguments."""
    assert set(retarget_options.NAMES) == set(DOCUMENTED_DEFAULTS)
    assert not {"bone_map", "frame_range"} & set(retarget_options.NAMES)


GOOD = [
    dict(root=r) for r in ("scaled", "in_place", "offset", "none")] + [
    dict(floor_fit=f) for f in ("legs", "hips", "off", "first_frame")] + [
    dict(floor_root=f) for f in ("auto", "still", "copy", "extract")] + [
    dict(root_motion_onto=w) for w in ("auto", "hips", "root", "object")] + [
    dict(root_motion_onto="root", floor_root="extract"), dict(root_motion_onto="object", floor_root="still"),
    dict(root_motion_onto="hips", floor_root="still"), dict(root_motion_onto="auto", floor_root="copy"),
    dict(source_match="FRAME", match_frame=0), dict(source_match="FRAME", match_frame=np.float64(12.5)),
    dict(scale_horizontal=0), dict(scale_horizontal=np.float32(1.3)), dict(scale_horizontal=2),
    dict(target_match="CURRENT"), dict(root_smoothing=0), dict(root_smoothing=np.float32(2.0)),
    dict(plant_feet=True), dict(plant_feet=np.bool_(False)), dict(align_facing=False),
    dict(source_floor=-0.02, target_floor=np.int64(1)), dict(contact_settings=ContactSettings(min_gap=0.0)),
    dict(chain_modes={"trunk": "MATCH", "leg.L": "KEEP"}), dict(chain_modes={}),
    dict(parts="arms"), dict(parts=("arm.L", "hand.L")), dict(bones=("mixamorig:LeftArm",)),
    dict(into="current"), dict(into="nla", blend="add", influence=0.25), dict(influence=np.float32(0.0)),
    dict(channels=()), dict(channels=["shape_keys"]), dict(channels=("scale", "properties")),
    dict(channel_map={}), dict(channel_map={"mouthSmile_L": "smile.L", "squash": "stretch"}),
    dict(body="off"), dict(body_strength=0), dict(body_strength=np.float32(0.5)),
]


@pytest.mark.parametrize("values", GOOD, ids=lambda v: "-".join(f"{k}={v[k]}" for k in v))
def test_good_values_pass(values):
    assert RetargetOptions(**values).validate() == RetargetOptions(**values)


BAD = [  # (field values, what the message must say: the option and the value)
    (dict(root="sideways"), r"unknown root motion 'sideways'"),
    (dict(root=None), r"unknown root motion None"),
    (dict(floor_root="up"), r"unknown floor root motion 'up'"),
    (dict(floor_fit="knees"), r"unknown floor_fit 'knees'"),
    (dict(root_motion_onto="feet"), r"unknown root_motion_onto 'feet'"),
    (dict(root_motion_onto=None), r"unknown root_motion_onto None"),
    (dict(root_motion_onto="root", floor_root="copy"),
     r"root_motion_onto 'root' moves the floor root itself \('extract'\): floor_root must be 'auto' or 'extract', "
     r"not 'copy'"),
    (dict(root_motion_onto="object", floor_root="extract"), r"floor_root must be 'auto' or 'still', not 'extract'"),
    (dict(root_motion_onto="hips", floor_root="copy"), r"floor_root must be 'auto' or 'still', not 'copy'"),
    (dict(root_smoothing=-1.0), r"root_smoothing must be a non-negative number of seconds, not -1\.0"),
    (dict(scale_horizontal=-0.5), r"scale_horizontal must be a non-negative number, not -0\.5"),
    (dict(scale_horizontal=float("inf")), r"scale_horizontal must be .*, not inf"),
    (dict(scale_horizontal=True), r"scale_horizontal must be .*, not True"),
    (dict(scale_horizontal="wide"), r"scale_horizontal must be .*, not 'wide'"),
    (dict(root_smoothing=float("nan")), r"root_smoothing must be .*, not nan"),
    (dict(root_smoothing=True), r"root_smoothing must be .*, not True"),
    (dict(root_smoothing="soft"), r"root_smoothing must be .*, not 'soft'"),
    (dict(source_match="POSE"), r"source_match 'POSE'"),
    (dict(target_match="FRAME"), r"target_match 'FRAME'"),
    (dict(source_match="FRAME"), r"source match pose on a frame needs match_frame"),
    (dict(match_frame="first"), r"match_frame must be a frame number or None, not 'first'"),
    (dict(match_frame=math.inf), r"match_frame must be a frame number or None, not inf"),
    (dict(plant_feet="yes"), r"plant_feet must be True, False or None, not 'yes'"),
    (dict(plant_feet=1), r"plant_feet must be True, False or None, not 1"),
    (dict(align_facing="no"), r"align_facing must be True or False, not 'no'"),
    (dict(source_floor="floor"), r"source_floor must be a height in metres or None, not 'floor'"),
    (dict(target_floor=float("inf")), r"target_floor must be a height in metres or None, not inf"),
    (dict(contact_settings="loose"), r"contact_settings must be a ContactSettings, not 'loose'"),
    (dict(contact_settings={"blend": 0.1}), r"contact_settings must be a ContactSettings, not \{'blend': 0\.1\}"),
    (dict(chain_modes={"tail": "KEEP"}), r"chain_modes: unknown chain 'tail'"),
    (dict(chain_modes={"arm.L": "BEND"}), r"chain_modes\['arm\.L'\]: unknown mode 'BEND'"),
    (dict(parts="torso"), r"unknown body parts preset 'torso'"),
    (dict(parts=("arm.L", "tail")), r"unknown body part 'tail'"),
    (dict(parts=()), r"parts is empty"),
    (dict(bones="LeftArm"), r"bones must be a non-empty list of target bone names or None, not 'LeftArm'"),
    (dict(bones=()), r"bones must be a non-empty list"),
    (dict(into="old"), r"unknown into 'old'"),
    (dict(two_hands="yes"), r"two_hands must be True or False, not 'yes'"),
    (dict(prop_space="pocket"), r"unknown prop_space 'pocket'"),
    (dict(body="on"), r"unknown body 'on'; expected one of \['auto', 'off'\]"),
    (dict(body_strength=2), r"body_strength must be a number from 0 to 1, not 2"),
    (dict(body_touches=1), r"body_touches must be True or False, not 1"),
    (dict(blend="multiply"), r"unknown blend 'multiply'"),
    (dict(influence=1.5), r"influence must be a number from 0 to 1, not 1\.5"),
    (dict(influence=True), r"influence must be a number from 0 to 1, not True"),
    (dict(channels="scale"), r"channels must be a list of \['scale', 'properties', 'shape_keys'\], not 'scale'"),
    (dict(channels=None), r"channels must be a list of .*, not None"),
    (dict(channels=("scale", "rotation")), r"unknown channel 'rotation'"),
    (dict(channel_map=[("a", "b")]), r"channel_map must be a \{source name: target name\} dict or None, not \["),
    (dict(channel_map={"jawOpen": ""}), r"channel_map: 'jawOpen': '' is not a pair of non-empty names"),
    (dict(channel_map={"jawOpen": 3}), r"channel_map: 'jawOpen': 3 is not a pair"),
]


def test_every_option_has_a_bad_value_here():
    """A field added without a check of its own shows here (align_facing, two_hands... every one)."""
    covered = {name for values, _ in BAD for name in values}
    assert covered == set(retarget_options.NAMES)


@pytest.mark.parametrize("values,message", BAD, ids=lambda v: str(v)[:40] if isinstance(v, dict) else "")
def test_a_bad_value_is_refused_naming_option_and_value(values, message):
    with pytest.raises(ValueError, match=message):
        RetargetOptions(**values).validate()
    # The same through keywords: from_keywords builds, validate refuses.
    with pytest.raises(ValueError, match=message):
        from_keywords(**values).validate()


def test_chain_modes_are_checked_by_the_reference_pose_stage():
    """One check of a chain mode, the reference pose's own: the options and a saved map agree."""
    with pytest.raises(ValueError) as by_options:
        RetargetOptions(chain_modes={"neck": "KEEP"}).validate()
    with pytest.raises(ValueError) as by_stage:
        chain_modes.check_modes({"neck": "KEEP"})
    assert str(by_options.value) == str(by_stage.value)


KEYWORDS = [dict(), dict(root="none"), dict(floor_fit="hips", plant_feet=False),
            dict(source_match="FRAME", match_frame=3, target_match="CURRENT", align_facing=False),
            dict(contact_settings=ContactSettings(blend=0.2), chain_modes={"arm.R": "MATCH"},
                 floor_fit="first_frame"),
            dict(DOCUMENTED_DEFAULTS, root="offset", root_smoothing=1.0, source_floor=0.1, target_floor=-0.1)]


@pytest.mark.parametrize("keywords", KEYWORDS, ids=lambda v: "-".join(v) or "none")
def test_keywords_make_the_same_options_as_the_dataclass(keywords):
    assert from_keywords(**keywords) == RetargetOptions(**keywords)
    assert from_keywords(None, **keywords) == RetargetOptions(**keywords)
    assert from_keywords(RetargetOptions(**keywords)) == RetargetOptions(**keywords)


def test_keywords_replace_the_given_options_fields_and_leave_it_alone():
    given = RetargetOptions(root="none", floor_fit="hips", plant_feet=False)
    made = from_keywords(given, floor_fit="off", align_facing=False)
    assert made == RetargetOptions(root="none", floor_fit="off", plant_feet=False, align_facing=False)
    assert given == RetargetOptions(root="none", floor_fit="hips", plant_feet=False)


def test_a_root_motion_passed_where_the_options_go_is_the_root():
    """plan(source, target, map, range, "in_place"): scripts pass the root motion fifth."""
    assert from_keywords("in_place") == RetargetOptions(root="in_place")
    assert from_keywords("in_place", floor_fit="off") == RetargetOptions(root="in_place", floor_fit="off")


def test_an_unknown_keyword_or_options_is_a_type_error_naming_it():
    with pytest.raises(TypeError, match=r"unknown retarget option 'roots'"):
        from_keywords(roots="scaled")
    with pytest.raises(TypeError, match=r"options must be a RetargetOptions, not \{'root': 'none'\}"):
        from_keywords({"root": "none"})


def test_reference_keeps_only_what_the_reference_pose_depends_on():
    options = RetargetOptions(root="none", source_match="FRAME", match_frame=4, target_match="CURRENT",
                              align_facing=False, floor_root="still", root_smoothing=1.0,
                              plant_feet=False, contact_settings=ContactSettings(), source_floor=0.5,
                              target_floor=0.25, floor_fit="off", chain_modes={"trunk": "MATCH"})
    assert options.reference() == RetargetOptions(source_match="FRAME", match_frame=4, target_match="CURRENT",
                                                  align_facing=False, chain_modes={"trunk": "MATCH"})


@pytest.mark.parametrize("frame_range", [None, (1, 10), [0.5, 2.5], (np.int64(3), np.float64(4))])
def test_a_frame_range_of_two_numbers_passes(frame_range):
    check_frame_range(frame_range)


@pytest.mark.parametrize("frame_range", ["all", (1,), (1, 2, 3), (1, math.nan), (True, 4), {1: 2}])
def test_a_bad_frame_range_is_refused_naming_it(frame_range):
    with pytest.raises(ValueError, match=r"frame_range must be \(first, last\) frames, not "):
        check_frame_range(frame_range)


def test_the_old_ground_keyword_is_floor_fit_first_frame_and_says_so():
    with pytest.warns(DeprecationWarning, match=r"ground=True is floor_fit='first_frame'"):
        assert from_keywords(ground=True) == RetargetOptions(floor_fit="first_frame")
    with pytest.warns(DeprecationWarning):
        assert from_keywords(ground=np.bool_(False), floor_fit="hips") == RetargetOptions(floor_fit="hips")
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match=r"say different things"):
        from_keywords(ground=True, floor_fit="legs")
    for bad in (1.5, None):
        with pytest.raises(ValueError, match=rf"ground must be True or False, not {bad}"):
            from_keywords(ground=bad)
