"""The retarget seen before it is keyed: the target plays the retargeted clip from an action of its own,
remade whole on every change, and the actions the user has are never written. start() reads what the
target plays, show() remakes the preview (the retarget's plan written into a new action: a part of the
body over a copy of the target's own), stop() puts back what the target played and removes the preview.
An NLA track's blend is not previewed: the written bones show at full influence."""
from __future__ import annotations

import time
from dataclasses import dataclass

import bpy

from . import retargeting
from ..blender import animdata

PREVIEW_NAME = "MotionKit Preview"


@dataclass
class Shown:
    """A preview made: its action, and how long the retarget and writing it took (seconds)."""
    action: bpy.types.Action
    seconds: float


def start(target) -> tuple:
    """What the target plays now (animdata.assignment), to put back when the preview stops."""
    return animdata.assignment(target)


def show(source, target, bone_map, frame_range, options, held: tuple, shown=None) -> Shown:
    """The target playing the retarget of source (retargeting.plan's arguments) from a new preview action;
    shown: the preview it replaces (removed once the new one plays). held: start()'s. A ValueError leaves
    the last preview playing."""
    started = time.perf_counter()
    if source is None or getattr(source, "type", None) != 'ARMATURE':
        raise ValueError("the preview retargets from a source armature in the scene (import a file first)")
    plan_ = retargeting.plan(source, target, bone_map, frame_range, options)
    action = retargeting.new_action_for(plan_, PREVIEW_NAME, held[0])
    animdata.assign(target, action)
    if shown is not None and shown != action:
        bpy.data.actions.remove(shown)
    return Shown(action, time.perf_counter() - started)


def stop(target, held: tuple, shown) -> None:
    """The target plays what it played before start(), the preview's action removed: the scene as it was."""
    animdata.restore(target, held)
    if shown is not None:
        bpy.data.actions.remove(shown)
