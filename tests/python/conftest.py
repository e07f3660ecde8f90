"""Tests that run in plain Python (Debian's python3, the one Blender 3.4 embeds)."""
import glob
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path[:0] = [os.path.join(ROOT, "addon"), os.path.join(ROOT, "blend_samples")]


@pytest.fixture(scope="session")
def native():
    """The _native module built for this interpreter by build_addon.py --all."""
    tag = "py%d%d" % sys.version_info[:2]
    build = os.path.join(ROOT, "build", tag)
    if not glob.glob(os.path.join(build, "_native*.so")):
        pytest.fail(f"{build}/_native*.so is missing: run `make build-3.4` (or build_addon.py) first")
    sys.path.insert(0, build)
    import _native
    return _native
