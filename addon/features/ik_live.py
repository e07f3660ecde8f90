"""Live IK: re-solve the current frame of every armature with Live on, whenever its targets
move or the frame changes (a depsgraph handler; its cost per re-solve is in docs/benchmarks.md,
"Full-body IK")."""
from __future__ import annotations

from dataclasses import dataclass, field

import bpy
import numpy as np

from . import ik


@dataclass
class LiveSettings:
    """What Live IK re-solves an armature with: ik.plan's effectors, method and options."""
    effectors: list = field(default_factory=list)  # ik.Effector
    method: str = "dls"
    options: dict = field(default_factory=dict)


# (armature object) -> its LiveSettings, or None while Live is off on it; the UI, which keeps the settings,
# gives it (register).
_settings_of = None
_last: dict[str, tuple] = {}
_busy = False


def _signature(obj, settings: LiveSettings) -> tuple:
    parts = [bpy.context.scene.frame_current, tuple(np.array(obj.matrix_world).ravel())]
    for effector in settings.effectors:
        target, bone = effector.target, None
        if isinstance(target, tuple):
            target, bone = target
        if target is not None and not effector.pin:
            parts.append(tuple(np.array(target.matrix_world).ravel()))
            if target.type == 'ARMATURE' and bone in target.pose.bones:
                parts.append(tuple(target.pose.bones[bone].head))
    return tuple(parts)


def solve_live(obj, settings: LiveSettings | None = None) -> bool:
    """Re-solve obj's current frame if its targets moved; True when it did. settings: by default what the UI
    keeps for obj."""
    global _busy
    settings = settings if settings is not None else _settings_of(obj)
    signature = _signature(obj, settings)
    if _last.get(obj.name) == signature or _busy:
        return False
    _busy = True
    try:
        plan = ik.plan(obj, settings.effectors, None, settings.method, **settings.options)
        ik.apply_pose(plan)
    except ValueError as ex:
        print(f"MotionKit live IK on '{obj.name}': {ex}")
    finally:
        _busy = False
    _last[obj.name] = signature
    return True


def _on_update(scene, depsgraph=None):
    for obj in scene.objects:
        if obj.type == 'ARMATURE':
            settings = _settings_of(obj)
            if settings is not None and settings.effectors:
                solve_live(obj, settings)


def sync() -> None:
    """The handler is installed while any armature has Live on."""
    wanted = _settings_of is not None and any(o.type == 'ARMATURE' and _settings_of(o) is not None
                                              for o in bpy.data.objects)
    for handlers in (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.frame_change_post):
        if wanted and _on_update not in handlers:
            handlers.append(_on_update)
        elif not wanted and _on_update in handlers:
            handlers.remove(_on_update)
    if not wanted:
        _last.clear()


@bpy.app.handlers.persistent
def _on_load(*_args):
    """After a file is opened (Blender clears non-persistent handlers then), or an undo or redo changed the
    Live toggles without their update callback: the re-solve runs exactly while some armature has Live on,
    so the toggle never shows on over a dead handler."""
    _last.clear()
    sync()


_STATE_CHANGES = ("load_post", "undo_post", "redo_post")


def register(settings_of) -> None:
    """settings_of(armature object): its LiveSettings, or None while Live is off on it."""
    global _settings_of
    _settings_of = settings_of
    for name in _STATE_CHANGES:
        handlers = getattr(bpy.app.handlers, name)
        if _on_load not in handlers:
            handlers.append(_on_load)
    try:
        sync()  # enabled on an open file that was saved with Live on
    except AttributeError:
        pass  # registered while Blender starts: bpy.data is not readable yet, and load_post follows


def unregister() -> None:
    for name in _STATE_CHANGES:
        handlers = getattr(bpy.app.handlers, name)
        if _on_load in handlers:
            handlers.remove(_on_load)
    for handlers in (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.frame_change_post):
        if _on_update in handlers:
            handlers.remove(_on_update)
    _last.clear()
