"""Tests that run in plain Python (Debian's python3, the one Blender 3.4 embeds)."""
import glob
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path[:0] = [os.path.join(ROOT, "addon"), os.path.join(ROOT, "blend_samples"),
                os.path.join(ROOT, "tests", "common")]
SHARED_BVH = os.path.join(os.path.dirname(ROOT), "shared", "data", "bvh")

import shared_data  # noqa: E402  (tests/common, on the path above)


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


def shared_bvh_files():
    """The real motion capture files beside the repository."""
    if not os.path.isdir(SHARED_BVH):
        return []
    return shared_data.bvh_files(SHARED_BVH)


@pytest.fixture(scope="session")
def shared_files():
    files = shared_bvh_files()
    if not files:
        if os.environ.get("CI") == "true":
            pytest.fail(f"{SHARED_BVH} is missing, and CI=true requires it")
        pytest.skip(f"{SHARED_BVH} is absent: the real-data checks need ../shared")
    return files


@pytest.fixture()
def core_native(native, monkeypatch):
    """core's own handle on the native module (core.native_state) pointed at the one built for this
    interpreter, for the core stages that pose natively (a source tree has no package to load it from)."""
    import types
    from core import native_state
    monkeypatch.setattr(native_state, "status", types.SimpleNamespace(ok=True, module=native, message=""))
    return native


@pytest.fixture(scope="session")
def shared_bodies():
    """../shared, where its data/bodies (the Mixamo characters' skinned meshes) is."""
    shared = os.path.join(os.path.dirname(ROOT), "shared")
    if not os.path.isdir(os.path.join(shared, "data", "bodies")):
        if os.environ.get("CI") == "true":
            pytest.fail(f"{shared}/data/bodies is missing, and CI=true requires it")
        pytest.skip("../shared/data/bodies is absent: the body checks need ../shared")
    return shared
