"""The long tier: loops over many clips that the Blender suite keeps one representative case of
(`make test-long`; CI does not run it). The Blender suite's fixtures, shared rather than copied."""
import importlib.util
import os

_spec = importlib.util.spec_from_file_location(
    "blender_suite_conftest",
    os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "blender", "conftest.py"))
_suite = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_suite)

pytest_report_header = _suite.pytest_report_header
mk, animdata, native = _suite.mk, _suite.animdata, _suite.native
empty_scene, shared_dir, walk60 = _suite.empty_scene, _suite.shared_dir, _suite.walk60
