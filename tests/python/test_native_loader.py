"""The rules that decide whether a built package fits the running Python."""
import json
import sys

from core import native_loader
import pytest


def test_zip_names_follow_the_pattern():
    assert native_loader.zip_name("0.1.0", "linux-x64", "3.11") == "motionkit-0.1.0-linux-x64-py311.zip"
    assert native_loader.zip_name("1.2.3", "linux-x64", "3.14") == "motionkit-1.2.3-linux-x64-py314.zip"


def test_a_fitting_build_has_no_complaint():
    info = {"version": "0.1.0", "python": "3.11", "platform": "linux-x64"}
    assert native_loader.mismatch_message(info, "3.11", "linux-x64") == ""


def test_another_python_is_named_with_both_versions():
    info = {"version": "0.1.0", "python": "3.11", "platform": "linux-x64", "blender": "3.4.1"}
    message = native_loader.mismatch_message(info, "3.14", "linux-x64")
    assert message == (
        "MotionKit 0.1.0 was built for Python 3.11 on linux-x64 (Blender 3.4.1), but this Blender "
        "runs Python 3.14 on linux-x64. Install motionkit-0.1.0-linux-x64-py314.zip instead "
        "(python3 build_addon.py --blender <this blender> builds it).")


def test_another_platform_is_a_mismatch_too():
    info = {"version": "0.1.0", "python": "3.11", "platform": "windows-x64"}
    assert "built for Python 3.11 on windows-x64" in native_loader.mismatch_message(info, "3.11", "linux-x64")


def test_source_folder_without_build_is_explained(tmp_path):
    status = native_loader.load("motionkit", str(tmp_path))
    assert not status.ok
    assert "build_info.json not found" in status.message and "build_addon.py" in status.message


def test_unreadable_build_info_is_explained(tmp_path):
    (tmp_path / "build_info.json").write_text("{not json")
    status = native_loader.load("motionkit", str(tmp_path))
    assert not status.ok and "cannot be read" in status.message


def test_mismatch_does_not_try_to_import(tmp_path):
    (tmp_path / "build_info.json").write_text(json.dumps(
        {"version": "0.1.0", "python": "2.7", "platform": native_loader.running_platform()}))
    status = native_loader.load("package_that_does_not_exist", str(tmp_path))
    assert not status.ok and "built for Python 2.7" in status.message


def test_running_python_and_platform():
    assert native_loader.running_python() == "%d.%d" % sys.version_info[:2]
    assert native_loader.running_platform() in ("linux-x64", "linux-arm64")


def test_native_module_works_from_plain_python(native):
    import numpy as np
    assert native.build_info()["python"] == native_loader.running_python()
    a = np.ones((2, 3))
    assert native._testing.data_address(a) == a.ctypes.data
    with pytest.raises(native.MotionKitError, match="curve 1, key 0"):
        native.keyframe_co(np.array([0.0]), np.array([[1.0], [np.inf]]))
