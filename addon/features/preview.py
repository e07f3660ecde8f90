"""The retarget seen before it is keyed: the target plays the retargeted clip from an action of its own,
remade whole on every change, and the actions the user has are never written. start() reads what the
target plays and how it stands (its pose channels and its object's transform, which an action that does
not key them leaves as the preview last put them), show() remakes the preview (the retarget's plan written
into a new action: a part of the body over a copy of the target's own), stop() puts all of it back and
removes the preview. A retarget into an NLA track is previewed as one: the target's own action on a track
under the preview's, blended as asked (tracks named PREVIEW_NAME, removed again whatever else changed)."""
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
    layered = plan_.options.into == "nla"
    action = retargeting.new_action_for(plan_, PREVIEW_NAME, None if layered else held.assignment[0])
    _clear_tracks(target, held)
    if layered:
        _push(target, action, plan_)
    else:
        animdata.assign(target, action)
    if shown is not None and shown != action:
        bpy.data.actions.remove(shown)
    return Shown(action, time.perf_counter() - started)


def _push(target, action, plan_) -> None:
    """The preview on an NLA track above the target's own action, as apply() puts an "nla" retarget, the
    tracks that adds named for the preview (_clear_tracks finds them by name, a file reopened too)."""
    o = plan_.options
    animdata.push_track(target, action, plan_.frames[0], o.blend, o.influence, name=PREVIEW_NAME)


def _clear_tracks(target, held: Held) -> None:
    """The preview's NLA tracks removed and what the target played assigned again."""
    animdata.remove_tracks(target, PREVIEW_NAME)
    animdata.restore(target, held.assignment)


def stop(target, held: Held, shown) -> None:
    """The target plays what it played before start() and stands as it stood, the preview's action and
    tracks removed: the scene as it was."""
    _clear_tracks(target, held)
    if shown is not None:
        bpy.data.actions.remove(shown)
    pose_channels.set_channel_values(target, held.pose)
    if held.matrix_basis is not None:
        target.matrix_basis = held.matrix_basis
