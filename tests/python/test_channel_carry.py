"""core/channel_carry: the extra channels' options, their data paths (read as Blender writes them, with quotes
and backslashes in names) and the report's line. No Blender needed."""
import pytest

from core import channel_carry as cc


@pytest.mark.parametrize("path,expected", [
    ('pose.bones["spine"]["squash"]', ("spine", "squash")),
    ('pose.bones["mixamorig:Left Arm"]["ik.fk"]', ("mixamorig:Left Arm", "ik.fk")),
    ('pose.bones["a\\"b"]["c\\\\d"]', ('a"b', "c\\d")),
    ('pose.bones["spine"].scale', None), ('pose.bones["spine"]["squash"].x', None), ('["squash"]', None),
])
def test_a_bone_property_path_gives_bone_and_property(path, expected):
    assert cc.bone_property(path) == expected


@pytest.mark.parametrize("path,expected", [
    ('["blink"]', "blink"), ('["say \\"hi\\""]', 'say "hi"'), ('pose.bones["x"]["blink"]', None),
    ('location', None), ('["a"]["b"]', None)])
def test_an_object_property_path_gives_the_property(path, expected):
    assert cc.object_property(path) == expected


@pytest.mark.parametrize("path,expected", [
    ('key_blocks["jawOpen"].value', "jawOpen"), ('key_blocks["mouth \\"O\\""].value', 'mouth "O"'),
    ('key_blocks["jawOpen"].slider_max', None), ('eval_time', None)])
def test_a_shape_key_path_gives_its_name(path, expected):
    assert cc.shape_key(path) == expected


@pytest.mark.parametrize("name", ["plain", 'quo"te', "back\\slash", '\\"both', "ünï côdé"])
def test_paths_made_are_read_back(name):
    assert cc.bone_property(cc.bone_property_path(name, name + "p")) == (name, name + "p")
    assert cc.object_property(cc.object_property_path(name)) == name
    assert cc.shape_key(cc.shape_key_path(name)) == name


def test_the_escape_is_blenders():
    """bpy.utils.escape_identifier: a backslash and a double quote get a backslash before them."""
    assert cc.escape('a"b\\c') == 'a\\"b\\\\c'
    assert cc.shape_key_path('x"y') == 'key_blocks["x\\"y"].value'


def test_motionkits_contacts_are_its_own_and_nothing_else():
    assert cc.is_own("motionkit_contact_heel") and cc.is_own("motionkit_contact_ball")
    assert not cc.is_own("contact_heel") and not cc.is_own("motionkit_frame_rate_x") and not cc.is_own("squash")


def test_the_map_renames_only_what_it_names():
    assert cc.target_name("jawOpen", None) == "jawOpen"
    assert cc.target_name("jawOpen", {}) == "jawOpen"
    assert cc.target_name("jawOpen", {"jawOpen": "JawOpen"}) == "JawOpen"
    assert cc.target_name("blink", {"jawOpen": "JawOpen"}) == "blink"


@pytest.mark.parametrize("channels", [(), ("scale",), ["properties", "shape_keys"], {"scale"}, cc.IDS])
def test_channels_of_known_ids_pass(channels):
    assert cc.check_channels(channels) == tuple(channels)


@pytest.mark.parametrize("channels,message", [
    ("scale", r"channels must be a list of"), (None, r"channels must be a list of"), (3, r"not 3"),
    (("scale", "location"), r"unknown channel 'location'"), (["Scale"], r"unknown channel 'Scale'")])
def test_bad_channels_are_refused_naming_the_value(channels, message):
    with pytest.raises(ValueError, match=message):
        cc.check_channels(channels)


@pytest.mark.parametrize("channel_map,message", [
    ("jawOpen", r"channel_map must be a .* dict or None, not 'jawOpen'"),
    ({"": "x"}, r"channel_map: '': 'x' is not a pair"), ({"x": None}, r"channel_map: 'x': None is not a pair"),
    ({1: "x"}, r"channel_map: 1: 'x'")])
def test_a_bad_channel_map_is_refused_naming_the_entry(channel_map, message):
    with pytest.raises(ValueError, match=message):
        cc.check_channel_map(channel_map)


def test_the_summary_names_each_left_out_channel_and_counts_the_rest():
    assert cc.summary([]) == ""
    one = [cc.LeftOut("shape_key", "tongueOut", "no target mesh has it")]
    assert cc.summary(one) == "1 channel not carried: tongueOut (no target mesh has it)"
    many = [cc.LeftOut("property", f'["p{i}"]', "missing") for i in range(8)]
    line = cc.summary(many, limit=2)
    assert line == '8 channels not carried: ["p0"] (missing); ["p1"] (missing); and 6 more'
