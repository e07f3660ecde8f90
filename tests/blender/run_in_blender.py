"""Runs the Blender test suite inside Blender: installs the zip, then pytest.

    tools/with_blender.sh 3.4 --background --factory-startup --python-exit-code 1 \
        --python tests/blender/run_in_blender.py -- dist/motionkit-...-py311.zip [--long] [pytest args]

With --long it runs the long tier instead, tests/long (`make test-long`): every clip of the loops whose one
representative case this suite keeps.

Blender's exit code is pytest's, so a failing or empty run is never green.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tools"))

import install_addon  # noqa: E402


def main() -> int:
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if not args:
        print("run_in_blender.py: pass the zip to test after --", file=sys.stderr)
        return 2
    zip_path, pytest_args = os.path.abspath(args[0]), args[1:]
    folder = os.path.join(ROOT, "tests", "long") if "--long" in pytest_args else HERE
    pytest_args = [a for a in pytest_args if a != "--long"]
    os.environ["MOTIONKIT_ZIP"] = zip_path
    os.environ["MOTIONKIT_MODULE"] = install_addon.install(zip_path)
    import pytest
    # Blender 3.4's own glTF exporter (io_scene_gltf2) has string literals with invalid escapes, which Python
    # 3.11 reports when the batch tests export glTF: Blender's warning, not MotionKit's.
    quiet = ["-W", "ignore:invalid escape sequence:DeprecationWarning"]
    code = pytest.main([folder, "-p", "no:cacheprovider", "-ra", *quiet, *pytest_args])
    if code == pytest.ExitCode.NO_TESTS_COLLECTED:
        print("run_in_blender.py: no test ran", file=sys.stderr)
    return int(code)


if __name__ == "__main__":
    sys.exit(main())
