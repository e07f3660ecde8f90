"""The retarget seen before it is keyed: the target plays the retargeted clip from an action of its own,
remade whole on every change, and the actions the user has are never written. start() reads what the
target plays and how it stands (its pose channels and its object's transform, which an action that does
not key them leaves as the preview last put them), show() remakes the preview (the retarget's plan written
into a new action: a part of the body over a copy of the target's own), stop() puts all of it back and
removes the preview. A retarget into an NLA track is previewed as one: the target's own action on a track
under the preview's, blended as asked (tracks named PREVIEW_NAME, removed again whatever else changed). The
carried shape keys play the same way, from a preview action on each target mesh's Key (tagged, holding the
Key's own action so that a file saved mid-preview loses none)."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import bpy

from . import retargeting
from ..blender import animdata, carried_reads, pose_channels

PREVIEW_NAME = "MotionKit Preview"
# ID properties of a Key's preview action: its tag, and the action the Key played before (a user of it).
TAG, HELD = "motionkit_preview", "motionkit_preview_held"


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
    # {Key name: animdata.assignment, or None where the Key had no animation data}: what each target mesh's
    # Key played.
    keys: dict = field(default_factory=dict)


def start(target) -> Held:
    """What the target plays now and how it stands, to put back when the preview stops."""
    return Held(animdata.assignment(target), pose_channels.channel_values(target), target.matrix_basis.copy(),
                {key.name: animdata.assignment(key) if key.animation_data else None for key in _target_keys(target)})


def _target_keys(target) -> list:
    return list(dict.fromkeys(m.data.shape_keys for m in carried_reads.deformed_meshes(target)))


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
    _show_shapes(plan_, held)
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


def _show_shapes(plan_, held: Held) -> None:
    """Each target Key whose shapes the plan carries plays them from a new preview action (for a part of the
    body a copy of its own, as Apply makes it); the others play what they played. The last previews removed."""
    carried = {key.name: (channels, values) for key, channels, values in
               (plan_.carried.shapes if plan_.carried is not None else ())}
    for key in _target_keys(plan_.target):
        last = animdata.assigned_action(key)
        own = held.keys.get(key.name) or (None, None)
        if key.name in carried:
            channels, values = carried[key.name]
            name = f"{PREVIEW_NAME} ({key.user.name})"
            action = animdata.copy_action(own[0], name) if plan_.partial and own[0] is not None else \
                animdata.new_action(name)
            action[TAG] = True
            if own[0] is not None:
                action[HELD] = own[0]
            animdata.write_keys(key, action, channels, plan_.frames, values)
            animdata.assign(key, action)
        elif key.name in held.keys:
            animdata.restore(key, own)
        if last is not None and last.get(TAG):
            bpy.data.actions.remove(last)


def stop(target, held: Held, shown) -> None:
    """The target plays what it played before start() and stands as it stood, the preview's action and
    tracks removed: the scene as it was."""
    _clear_tracks(target, held)
    if shown is not None:
        bpy.data.actions.remove(shown)
    for key in bpy.data.shape_keys:
        action = animdata.assigned_action(key)
        if action is not None and action.get(TAG):
            own = held.keys.get(key.name, (action.get(HELD), None))
            animdata.restore(key, own or (None, None))
            bpy.data.actions.remove(action)
            anim = key.animation_data
            if own is None and not anim.drivers and not anim.nla_tracks:  # it had none: none is made
                key.animation_data_clear()
    pose_channels.set_channel_values(target, held.pose)
    if held.matrix_basis is not None:
        target.matrix_basis = held.matrix_basis
