"""Feet on the floor for every placement of the target's armature, planted and not, by the check
tests/blender/test_production_files.py runs on one representative placement."""
import pytest

from test_production_files import VARIANTS, check_feet_on_the_floor


@pytest.mark.parametrize("plant", [True, False], ids=["planted", "not planted"])
@pytest.mark.parametrize("variant", list(VARIANTS))
def test_feet_stand_on_the_floor(mk, walk60, variant, plant):
    check_feet_on_the_floor(mk, walk60, variant, plant)
