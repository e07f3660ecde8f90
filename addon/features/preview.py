"""The retarget seen before it is keyed: the target plays the retargeted clip from an action of its own,
remade whole on every change, and the actions the user has are never written. start() reads what the
target plays and how it stands (its pose channels and its object's transform, which an action that does
not key them leaves as the preview last put them), show() remakes the preview (the retarget's plan written
into a new action: a part of the body over a copy of the target's own), stop() puts all of it back and
removes the preview. An NLA track's blend is not previewed: the written bones show at full influence."""
from __future__ import annotations

import time
from dataclasses import dataclass

import bpy

from . import retargeting
from ..blender import animdata, pose_channels

PREVIEW_NAME = "MotionKit Preview"


@dataclass
class Shown:
    """A preview made: its action, and how long the retarget and writing it took (seconds)."""
    action: bpy.types.Action
    seconds: float


@dataclass
class Held:
    """What the target played and how it stood before the preview (start()), for stop()."""
    assignment: tuple      # animdata.assignment: (action or None, slot identifier or None)
    pose: dict             # pose_channels.channel_values: every pose bone's channels
    matrix_basis: object   # the object's own transform (a mathutils Matrix copy)


def start(target) -> Held:
    """What the target plays now and how it stands, to put back when the preview stops."""
    return Held(animdata.assignment(target), pose_channels.channel_values(target), target.matrix_basis.copy())


def show(source, target, bone_map, frame_range, options, held: Held, shown=None) -> Shown:
    """The target playing the retarget of source (retargeting.plan's arguments) from a new preview action;
    shown: the preview it replaces (removed once the new one plays). held: start()'s. A ValueError leaves
    the last preview playing."""
    started = time.perf_counter()
    if source is None or getattr(source, "type", None) != 'ARMATURE':
        raise ValueError("the preview retargets from a source armature in the scene (import a file first)")
    plan_ = retargeting.plan(source, target, bone_map, frame_range, options)
    action = retargeting.new_action_for(plan_, PREVIEW_NAME, held.assignment[0])
    animdata.assign(target, action)
    if shown is not None and shown != action:
        bpy.data.actions.remove(shown)
    return Shown(action, time.perf_counter() - started)


def stop(target, held: Held, shown) -> None:
    """The target plays what it played before start() and stands as it stood, the preview's action removed:
    the scene as it was."""
    animdata.restore(target, held.assignment)
    if shown is not None:
        bpy.data.actions.remove(shown)
    pose_channels.set_channel_values(target, held.pose)
    if held.matrix_basis is not None:
        target.matrix_basis = held.matrix_basis
