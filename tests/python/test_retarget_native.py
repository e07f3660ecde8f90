"""The native retarget binding's options (RetargetOptions): fields by name, bad values refused by name."""
import numpy as np
import pytest


def test_options_hold_what_they_are_given(native):
    options = native.RetargetOptions()
    assert options.root_motion == "scaled" and options.scale == 1.0 and options.posture_always == []
    options.root_motion, options.scale, options.unit_scale = "in_place", 0.87, 100.0
    options.space, options.up = (0.0, 0.0, 0.0, 1.0), (0.0, 1.0, 0.0)
    options.source_floor, options.target_floor = -0.5, 0.25
    options.posture_bones, options.posture_always = [1, 2], [4]
    assert options.root_motion == "in_place" and (options.scale, options.unit_scale) == (0.87, 100.0)
    np.testing.assert_array_equal(options.space, [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(options.up, [0.0, 1.0, 0.0])
    assert (options.source_floor, options.target_floor) == (-0.5, 0.25)
    assert (options.posture_bones, options.posture_always) == ([1, 2], [4])


def test_a_bad_root_motion_is_refused_by_name(native):
    options = native.RetargetOptions()
    with pytest.raises(ValueError, match="unknown root motion 'sideways'"):
        options.root_motion = "sideways"
    assert options.root_motion == "scaled"
