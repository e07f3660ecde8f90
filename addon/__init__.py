"""MotionKit: retarget, full-body IK and keyframe resampling with a native core.

Blender 3.4 installs this package as a legacy add-on (bl_info); 4.2 and later
install it as an extension (blender_manifest.toml, written by build_addon.py).
"""

bl_info = {
    "name": "MotionKit",
    "author": "MotionKit developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > MotionKit",
    "description": "Motion retargeting, full-body IK and keyframe resampling with a native solver",
    "category": "Animation",
}

import sys

import bpy

# The public API for scripts: motionkit.retarget(...), motionkit.bvh.load(...), motionkit.ik.bake(...), ...
from .blender import animdata, pose_channels
from .core import bone_mapping, control_rig, foot_contacts, rotation_channels
from .core.native_state import native
from .features import batch, batch_workers, bvh, cli, contacts, control_rigs, filters, ik, resampling, retargeting, \
    scene_timing
from .features.filters import filter  # noqa: A004  (motionkit.filter, as the API names it)
from .features.mirror import mirror
from .features.resampling import reduce_keys, resample
from .features.batch import retarget_files
from .features.retargeting import retarget
from . import ui

__all__ = ["animdata", "batch", "batch_workers", "bone_mapping", "cli", "bvh", "contacts", "control_rig", "control_rigs", "filter", "filters", "foot_contacts", "ik",
           "mirror", "native", "pose_channels", "reduce_keys", "resample", "resampling", "retarget", "retarget_files",
           "retargeting", "rotation_channels", "scene_timing"]

# The public modules answer at the package's top as well (`from motionkit.ik import Effector`, `import
# motionkit.bvh`), wherever the layers keep them, so that scripts do not depend on the add-on's layout.
for _module in (animdata, batch, batch_workers, bone_mapping, bvh, cli, contacts, control_rig, control_rigs, filters, foot_contacts, ik,
                pose_channels, resampling, retargeting, rotation_channels, scene_timing):
    sys.modules.setdefault(f"{__package__}.{_module.__name__.rsplit('.', 1)[1]}", _module)
del _module


def register():
    ui.register()
    # Installed as an extension the package is bl_ext.<repo>.motionkit; the
    # aliases keep `import motionkit` and `from motionkit import animdata`
    # working for headless scripts either way, without loading anything twice.
    if __package__ != "motionkit":
        for name in _aliases():
            sys.modules.setdefault("motionkit" + name[len(__package__):], sys.modules[name])
    status = sys.modules[__package__ + ".core.native_state"].status
    if not status.ok:
        # Enabling still succeeds so that the preferences and the sidebar can
        # show the reason; the console gets it in one line, not a traceback.
        print(f"MotionKit: {status.message}", file=sys.stderr)


def _aliases():
    prefix = __package__ + "."
    return [n for n in list(sys.modules) if n == __package__ or n.startswith(prefix)]


def unregister():
    if __package__ != "motionkit":
        for name in _aliases():
            alias = "motionkit" + name[len(__package__):]
            if sys.modules.get(alias) is sys.modules[name]:
                del sys.modules[alias]
    ui.unregister()
