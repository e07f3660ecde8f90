"""RetargetOptions in a real Blender: options= and keywords give the same retarget, the panel fills the
options from its settings, and the batch's check refuses a bad RetargetOptions naming the option.

The same plan computed twice is not bit-identical run to run (the native solve's threads: up to 3.4e-15
between two runs of the same code, measured on Blender 3.4 over 404,586 values), so keys compare to 3e-14,
about ten times that: far below what any option changes (in place against scaled moves the hips by
metres).
"""
import dataclasses

import bpy
import numpy as np
import pytest

import characters
import generate

SAME = 3e-14  # see the module docstring


@pytest.fixture()
def rigs(mk, walk60):
    source, _ = mk.bvh.load(walk60, name="walkT")
    target = generate.build_armature(characters.MIXAMO_T)
    yield source, target
    for obj in (source, target):
        bpy.data.objects.remove(obj)


def _values(plan):
    plan.resolve()
    return plan.channels, plan.values


def test_options_and_keywords_make_the_same_plan(mk, rigs):
    retargeting, RetargetOptions = mk.retargeting, mk.retargeting.RetargetOptions
    source, target = rigs
    keywords = dict(root="in_place", floor_fit="hips", plant_feet=False, chain_modes={"trunk": "MATCH"})
    by_keywords = _values(retargeting.plan(source, target, **keywords))
    by_options = _values(retargeting.plan(source, target, options=RetargetOptions(**keywords)))
    # A keyword replaces the options' field: root given apart from the rest.
    mixed = _values(retargeting.plan(source, target, None, None, RetargetOptions(
        floor_fit="hips", plant_feet=False, chain_modes={"trunk": "MATCH"}), root="in_place"))
    # The root motion where the options go, as scripts pass it fifth.
    fifth = _values(retargeting.plan(source, target, None, None, "in_place", floor_fit="hips", plant_feet=False,
                                     chain_modes={"trunk": "MATCH"}))
    for other in (by_options, mixed, fifth):
        assert other[0] == by_keywords[0]
        assert np.abs(other[1] - by_keywords[1]).max() <= SAME
    # The comparison can fail: the default root motion moves the hips elsewhere.
    scaled = _values(retargeting.plan(source, target, options=RetargetOptions(**{**keywords, "root": "scaled"})))
    assert np.abs(scaled[1] - by_keywords[1]).max() > 0.1


def test_retarget_with_options_keys_what_keywords_key(mk, rigs):
    source, target = rigs
    keywords = dict(root="offset", floor_fit="off", plant_feet=False, align_facing=False)
    frames = range(1, 183, 5)

    def keys(action):
        curves = mk.animdata.fcurves(action, target)  # 5.x's slotted actions have no action.fcurves
        return {(c.data_path, c.array_index): [c.evaluate(f) for f in frames] for c in curves}

    by_keywords = keys(mk.retarget(source, target, **keywords))
    by_options = keys(mk.retarget(source, target, options=mk.retargeting.RetargetOptions(**keywords)))
    assert by_options.keys() == by_keywords.keys()
    worst = max(np.abs(np.subtract(by_options[k], by_keywords[k])).max() for k in by_keywords)
    assert worst <= SAME


def test_kept_bones_read_only_the_reference_pose_options(mk, rigs):
    """Options that only move the clip (root motion, floors, feet) never change the bones kept."""
    source, target = rigs
    RetargetOptions = mk.retargeting.RetargetOptions
    base = mk.retargeting.kept_bones(source, target, options=RetargetOptions(chain_modes={"trunk": "MATCH"}))
    moved = mk.retargeting.kept_bones(source, target, options=RetargetOptions(
        chain_modes={"trunk": "MATCH"}, root="none", floor_fit="first_frame", plant_feet=False,
        target_floor=0.3))
    assert moved == base
    kept_trunk = mk.retargeting.kept_bones(source, target, chain_modes={"trunk": "KEEP"})
    assert kept_trunk != base  # the trunk's own mode does change them


@pytest.mark.parametrize("options,message", [
    (dict(options="sideways"), r"unknown root motion 'sideways'"),  # a str there is the root motion
    (dict(options=dict(root="none")), r"options must be a RetargetOptions"),
    (dict(root_motion="scaled"), r"unknown retarget option 'root_motion'"),
])
def test_check_options_refuses_what_retarget_would(mk, options, message):
    with pytest.raises(ValueError, match=message):
        mk.retargeting.check_options(**options)


def test_check_options_refuses_a_bad_retarget_options_naming_the_option(mk):
    RetargetOptions = mk.retargeting.RetargetOptions
    with pytest.raises(ValueError, match=r"unknown floor_fit 'knees'"):
        mk.retargeting.check_options(options=RetargetOptions(floor_fit="knees"))
    with pytest.raises(ValueError, match=r"ground must be True or False, not 'yes'"):
        mk.retargeting.check_options(options=RetargetOptions(), ground="yes")
    mk.retargeting.check_options(options=RetargetOptions(root="none"), plant_feet=False, keys="every")


def test_the_panel_fills_the_options_from_its_settings(mk):
    settings = bpy.context.scene.motionkit_retarget
    names = ("root_motion", "source_match", "match_frame", "target_match", "align_facing", "floor_root",
             "root_smoothing", "plant_feet", "floor_fit", "channels", "scale_horizontal")
    before = {n: getattr(settings, n) for n in names}
    try:
        settings.root_motion, settings.source_match, settings.match_frame = "in_place", 'FRAME', 7
        settings.target_match, settings.align_facing = 'CURRENT', False
        settings.floor_root, settings.root_smoothing, settings.floor_fit = "extract", 0.5, "hips"
        settings.plant_feet, settings.scale_horizontal = False, 1.25
        assert settings.retarget_options().channels == ("scale", "properties", "shape_keys")  # the default
        settings.channels = {"shape_keys", "scale"}
        options = settings.retarget_options()
        assert options.channels == ("scale", "shape_keys")
        assert (options.root, options.source_match, options.match_frame, options.target_match) == \
               ("in_place", 'FRAME', 7, 'CURRENT')
        assert (options.align_facing, options.floor_root, options.floor_fit) == (False, "extract", "hips")
        assert options.root_smoothing == pytest.approx(0.5, abs=1e-7)  # a float property holds float32
        assert options.scale_horizontal == 1.25  # exact in float32
        assert options.plant_feet is False and options.source_floor is None and options.target_floor is None
        settings.plant_feet = True
        assert settings.retarget_options().plant_feet is None  # planted where both rigs have feet
        assert settings.retarget_options().validate()
    finally:
        for n, v in before.items():
            setattr(settings, n, v)


def _same(ours, theirs) -> bool:
    """Equal, floats to float32's precision (a float property holds float32: 0.06 reads 0.0599999986)."""
    if isinstance(theirs, tuple) and isinstance(ours, tuple) and len(ours) == len(theirs):
        return all(_same(a, b) for a, b in zip(ours, theirs))
    if isinstance(theirs, float):
        return ours == pytest.approx(theirs, rel=1e-7)
    return ours == theirs


def test_a_fresh_panel_gives_the_defaults_of_retarget_options(mk):
    """The panel's property group and RetargetOptions are two writings of the same defaults: a fresh scene's
    panel fills every field of RetargetOptions as RetargetOptions() has it (contact_settings as the detection's
    defaults, which None stands for), so that the button and motionkit.retarget() do the same thing."""
    from motionkit.core.foot_contacts import ContactSettings
    from motionkit.core import retarget_options
    from motionkit.core.retarget_options import RetargetOptions
    scene = bpy.data.scenes.new("fresh panel")
    try:
        panel, defaults = scene.motionkit_retarget.retarget_options(), RetargetOptions()
        drifted = {}
        for name in retarget_options.NAMES:
            ours, theirs = getattr(panel, name), getattr(defaults, name)
            if name == "contact_settings":
                ours, theirs = dataclasses.astuple(ours or ContactSettings()), dataclasses.astuple(
                    theirs or ContactSettings())
            if not _same(ours, theirs):
                drifted[name] = (ours, theirs)
        assert not drifted, f"the panel's defaults (left) against RetargetOptions' (right): {drifted}"
    finally:
        bpy.data.scenes.remove(scene)
