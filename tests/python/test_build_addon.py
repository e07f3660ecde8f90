"""build_addon.py builds the add-on for one's own Blender on a machine without GoogleTest or Google
Benchmark: only --all (the native tests and benchmarks) needs them. CMake is asked to configure the build
as build_addon.py does, with both packages made unfindable."""
import os
import subprocess
import sys
import sysconfig

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)

import build_addon  # noqa: E402

WITHOUT_TEST_LIBRARIES = ["-DCMAKE_DISABLE_FIND_PACKAGE_GTest=ON", "-DCMAKE_DISABLE_FIND_PACKAGE_benchmark=ON"]


def _configure(tmp_path, everything):
    options = build_addon.cmake_options(sys.executable, sysconfig.get_paths()["include"], everything, False)
    return subprocess.run(["cmake", "-S", ROOT, "-B", str(tmp_path), *options, *WITHOUT_TEST_LIBRARIES],
                          capture_output=True, text=True)


def test_the_add_on_alone_needs_no_test_libraries(tmp_path):
    done = _configure(tmp_path, everything=False)
    assert done.returncode == 0, done.stdout + done.stderr


def test_all_does_need_them(tmp_path):
    """The check above can fail: asking for the tests without GoogleTest stops CMake."""
    done = _configure(tmp_path, everything=True)
    assert done.returncode != 0 and "GTest" in done.stdout + done.stderr
