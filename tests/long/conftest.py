"""The long tier: loops over every clip, character and variant that the Blender suite keeps one
representative case of (`make test-long`; CI does not run it). Its fixtures are the Blender suite's
(tests/blender/conftest.py), loaded once and shared, not copied; tests/blender is on sys.path so that the
long tests reuse its test modules' helpers."""
import importlib.util
import os
import sys

_BLENDER_TESTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "blender")
if _BLENDER_TESTS not in sys.path:
    sys.path.insert(0, _BLENDER_TESTS)
_spec = importlib.util.spec_from_file_location("blender_suite_conftest", os.path.join(_BLENDER_TESTS, "conftest.py"))
_suite = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_suite)
# pytest finds fixtures and hooks by the names a conftest holds: every public one of the suite's is held here.
globals().update({name: value for name, value in vars(_suite).items() if not name.startswith("_")})
