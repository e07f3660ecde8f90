"""Planted feet on every real clip of ../shared/data/bvh (and more/) onto every sample character, by the
checks tests/blender/test_retarget.py runs on one representative pair."""
import os

import pytest

import characters
import shared_data
from conftest import SHARED
from test_retarget import check_planted_feet

CLIPS = shared_data.bvh_files(os.path.join(SHARED, "data", "bvh"))


def test_the_real_captures_are_there():
    """The clips the loop below runs on: none found fails under CI=true, and skips elsewhere."""
    if CLIPS:
        return
    if os.environ.get("CI") == "true":
        pytest.fail(f"no .bvh files under {SHARED}/data/bvh, and CI=true requires them")
    pytest.skip(f"no .bvh files under {SHARED}/data/bvh")


@pytest.mark.parametrize("path", CLIPS, ids=os.path.basename)
@pytest.mark.parametrize("spec", characters.CHARACTERS, ids=lambda s: s.name)
def test_planted_feet_do_not_slide_on_any_clip(mk, shared_dir, spec, path):
    check_planted_feet(mk, mk.retargeting, path, spec)
