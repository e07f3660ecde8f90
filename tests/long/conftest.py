"""The long tier's fixtures: the Blender tier's own (tests/blender/conftest.py, run here as this conftest, so
that both tiers share one definition of mk, shared_dir, the empty scene and the rest), and tests/blender on
sys.path so that the long tests reuse its test modules' helpers."""
import os
import sys

_BLENDER_TESTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "blender")
if _BLENDER_TESTS not in sys.path:
    sys.path.insert(0, _BLENDER_TESTS)
# The file is run in this module's namespace (not imported as a second module named conftest): its
# ROOT, computed from __file__, is the repository's root from here too (the same depth).
with open(os.path.join(_BLENDER_TESTS, "conftest.py")) as _source:
    exec(compile(_source.read(), os.path.join(_BLENDER_TESTS, "conftest.py"), "exec"))
