"""Fixtures for tests that run inside a real Blender (see run_in_blender.py)."""
import importlib
import os
import sys

import bpy
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED = os.path.join(os.path.dirname(ROOT), "shared")
for path in (ROOT, os.path.join(ROOT, "tools"), os.path.join(ROOT, "blend_samples"),
             os.path.join(ROOT, "tests", "common")):
    if path not in sys.path:
        sys.path.insert(0, path)


def pytest_report_header(config):
    return (f"Blender {bpy.app.version_string}, Python {sys.version.split()[0]}, "
            f"MotionKit module {os.environ.get('MOTIONKIT_MODULE')}")


@pytest.fixture(scope="session")
def mk():
    """The installed MotionKit package (motionkit or bl_ext.user_default.motionkit)."""
    return importlib.import_module(os.environ["MOTIONKIT_MODULE"])


@pytest.fixture(scope="session")
def animdata(mk):
    return importlib.import_module(mk.__name__ + ".blender.animdata")


@pytest.fixture(scope="session")
def native(mk):
    return mk.native()


def fresh_blender_env(folder):
    """The environment for a Blender of its own, run by a test: an empty user folder under `folder`, so that
    installing the add-on there never overwrites the files (the native module among them) that this
    session's Blender has loaded."""
    user = os.path.join(str(folder), "user")
    return dict(os.environ, BLENDER_USER_RESOURCES=user, BLENDER_USER_CONFIG=os.path.join(user, "config"),
                BLENDER_USER_SCRIPTS=os.path.join(user, "scripts"), BLENDER_USER_EXTENSIONS=os.path.join(user, "ext"),
                BLENDER_USER_DATAFILES=os.path.join(user, "data"))


def clear_scene():
    """Removes every object and the data they used, without touching preferences."""
    for collection in (bpy.data.objects, bpy.data.armatures, bpy.data.meshes, bpy.data.actions,
                       bpy.data.materials, bpy.data.cameras, bpy.data.lights):
        for item in list(collection):
            collection.remove(item)


@pytest.fixture(autouse=True)
def empty_scene():
    """An empty scene, and the scene's frame rate and range as they were afterwards (a BVH import with
    update_scene_fps changes them; later tests must not inherit that)."""
    scene = bpy.context.scene
    kept = (scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end, scene.frame_current)
    clear_scene()
    yield scene
    clear_scene()
    scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end = kept[:4]
    scene.frame_set(kept[4])


@pytest.fixture(scope="session")
def shared_dir():
    """../shared beside the repository: required under CI, a visible skip elsewhere."""
    if not os.path.isdir(os.path.join(SHARED, "data", "bvh")):
        if os.environ.get("CI") == "true":
            pytest.fail(f"{SHARED}/data/bvh is missing, and CI=true requires it")
        pytest.skip(f"{SHARED}/data/bvh is absent (set up ../shared to run this test)")
    return SHARED


@pytest.fixture()
def walk60(shared_dir):
    """The real motion capture walk beside the repository."""
    return os.path.join(shared_dir, "data", "bvh", "walk60.bvh")
