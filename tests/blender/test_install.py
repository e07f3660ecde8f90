"""The packaged zip installs, enables and loads its native core in this Blender."""
import glob
import json
import os
import subprocess
import sys
import zipfile

import addon_utils
import bpy
import numpy as np
import pytest

import conftest
from conftest import ROOT


def test_enabled_from_the_temporary_user_folder(mk):
    user = os.environ["MOTIONKIT_TEST_USER"]
    assert os.path.realpath(mk.__file__).startswith(os.path.realpath(user))
    loaded_default, loaded_state = addon_utils.check(mk.__name__)
    assert loaded_default and loaded_state
    expected = "bl_ext.user_default.motionkit" if bpy.app.version >= (4, 2, 0) else "motionkit"
    assert mk.__name__ == expected


def test_import_motionkit_works_however_it_was_installed(mk):
    import motionkit
    assert motionkit is mk


def test_the_public_modules_import_by_their_short_names(mk):
    """Scripts import the public modules at the package's top, whatever layer holds them."""
    import importlib
    for name in ("animdata", "bone_mapping", "bvh", "contacts", "foot_contacts", "ik", "pose_channels",
                 "resampling", "retargeting", "rotation_channels"):
        module = importlib.import_module(f"motionkit.{name}")
        assert module is getattr(mk, name), name
    from motionkit.ik import Effector
    assert Effector is mk.ik.Effector


def test_native_core_is_built_for_this_python(native):
    info = native.build_info()
    assert info["python"] == "%d.%d" % sys.version_info[:2]
    assert info["version"] == native.__version__
    assert info["eigen"].split(".")[0] in ("3", "5")


def test_ui_and_preferences_are_registered(mk):
    panel = bpy.types.MOTIONKIT_PT_main
    assert panel.bl_category == "MotionKit" and panel.bl_space_type == 'VIEW_3D'
    assert bpy.context.preferences.addons[mk.__name__].preferences is not None


def test_disable_and_enable_again(mk):
    addon_utils.disable(mk.__name__, default_set=True)
    try:
        assert not hasattr(bpy.types, "MOTIONKIT_PT_main")
    finally:
        assert addon_utils.enable(mk.__name__, default_set=True) is not None
    assert hasattr(bpy.types, "MOTIONKIT_PT_main")


def test_numpy_arrays_cross_without_copies(native):
    a = np.arange(12.0).reshape(3, 4)
    assert native._testing.data_address(a) == a.ctypes.data
    # A slice that is still C-contiguous is seen in place too.
    assert native._testing.data_address(a[1:]) == a[1:].ctypes.data
    # Anything that would need a copy is refused instead of silently copied.
    with pytest.raises(TypeError):
        native._testing.data_address(a[:, ::2])
    with pytest.raises(TypeError):
        native._testing.data_address(a.astype(np.float32))
    with pytest.raises(TypeError):
        native._testing.data_address(np.asfortranarray(a))


def test_outputs_are_returned_as_native_allocated_arrays(native):
    """The one output rule: a function returns its outputs, arrays the module allocated (C-contiguous, owning
    their memory), so that nothing is copied on the way out either."""
    frames = np.array([1.0, 2.0, 5.0])
    values = np.array([[0.5, 1.5, 2.5], [-1.0, 0.0, 1.0]])
    co = native.keyframe_co(frames, values)
    assert co.dtype == np.float32 and co.flags.c_contiguous and co.flags.owndata
    np.testing.assert_array_equal(co, [[1, 0.5, 2, 1.5, 5, 2.5], [1, -1, 2, 0, 5, 1]])
    with pytest.raises(TypeError):  # the old in-place form is gone
        native.keyframe_co(frames, values, np.zeros((2, 6), np.float32))


def test_native_errors_become_python_exceptions(native):
    values = np.array([[0.0, np.nan]])
    with pytest.raises(native.MotionKitError, match=r"curve 0, key 1 \(frame 2.000000\) is not finite"):
        native.keyframe_co(np.array([1.0, 2.0]), values)
    assert issubclass(native.MotionKitError, ValueError)


def _run_enable_in_fresh_blender(zip_path, tmp_path):
    """Installs zip_path in a new Blender with an empty user folder; returns its output."""
    env = conftest.fresh_blender_env(tmp_path)
    probe = ("import bpy; m = bpy.context.preferences.addons; "
             "print('MOTIONKIT_ENABLED', any(a.module.endswith('motionkit') for a in m))")
    cmd = [bpy.app.binary_path, "--background", "--factory-startup", "--python-exit-code", "1",
           "--python", os.path.join(ROOT, "tools", "install_addon.py"),
           "--python-expr", probe, "--", str(zip_path)]
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    return out.returncode, out.stdout + out.stderr


def _tracebacks_about_motionkit(output):
    """Python tracebacks in output whose frames or exception mention MotionKit.

    A traceback runs from its header through indented frame lines to the first
    unindented line, the exception. (Debian's 5.2 prints one of its own at every
    start, for the extensions add-on's missing cattrs; that one is not ours.)
    """
    found, block = [], None
    for line in output.splitlines():
        if line.startswith("Traceback (most recent call last)"):
            block = [line]
        elif block is not None:
            block.append(line)
            if line and not line[0].isspace():
                if "motionkit" in "\n".join(block).lower():
                    found.append("\n".join(block))
                block = None
    return found


def _zip_with_build_info(source_zip, target_zip, **changes):
    with zipfile.ZipFile(source_zip) as src, zipfile.ZipFile(target_zip, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename.endswith("build_info.json"):
                info = json.loads(data)
                info.update(changes)
                data = json.dumps(info).encode()
            dst.writestr(item, data)


def test_a_zip_for_another_python_explains_itself(tmp_path):
    bad = tmp_path / "motionkit-wrong-python.zip"
    _zip_with_build_info(os.environ["MOTIONKIT_ZIP"], bad, python="3.99", blender="9.9.9")
    code, output = _run_enable_in_fresh_blender(bad, tmp_path)
    running = "%d.%d" % sys.version_info[:2]
    assert code == 0, output
    assert "MOTIONKIT_ENABLED True" in output
    assert (f"MotionKit 0.1.0 was built for Python 3.99 on linux-x64 (Blender 9.9.9), "
            f"but this Blender runs Python {running}") in output
    assert f"-py{running.replace('.', '')}.zip" in output
    assert not _tracebacks_about_motionkit(output), output


def test_the_zips_of_the_other_blenders_explain_themselves(tmp_path):
    """The real artefacts: each other Blender's zip (3.4's py311, 4.3's py313, 5.2's py314) in this one."""
    running = "py%d%d" % sys.version_info[:2]
    others = sorted(z for z in glob.glob(os.path.join(ROOT, "dist", "motionkit-*.zip")) if running not in z)
    if not others:
        if os.environ.get("CI") == "true":
            pytest.fail("CI builds every Blender's zip; the other Blenders' zips are missing from dist/")
        pytest.skip("only this Blender's zip is built")
    for other in others:
        with zipfile.ZipFile(other) as z:
            built = json.loads(z.read("motionkit/build_info.json"))["python"]
        folder = tmp_path / os.path.basename(other)
        folder.mkdir()
        code, output = _run_enable_in_fresh_blender(other, folder)
        assert code == 0, output
        assert f"built for Python {built}" in output, other
        assert f"this Blender runs Python {sys.version_info[0]}.{sys.version_info[1]}" in output, other
        assert not _tracebacks_about_motionkit(output), output
