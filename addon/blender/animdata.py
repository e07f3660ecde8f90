"""Every access MotionKit makes to actions and F-curves, for both of Blender's worlds.

Blender 3.x and 4.x before 4.4: an action holds its F-curves directly
(action.fcurves) and an ID animates through animation_data.action.
Blender 4.4 and 5.x: actions are layered and slotted. F-curves live in the
channel bag that a keyframe strip keeps for one slot, and an ID animates through
(animation_data.action, animation_data.action_slot). 5.0 removed action.fcurves.

Nothing outside this module touches action.fcurves, slots, layers, strips or
channel bags. Keys go in and out in bulk (keyframe_points.add + foreach_set,
foreach_get): no per-key Python.
"""
from __future__ import annotations

import ctypes
from typing import Iterable, NamedTuple, Sequence

import bpy
import numpy as np

from ..core import native_state

# Feature test rather than a version test: 4.4 has both APIs and the layered one
# is the one that stays.
LAYERED = "slots" in bpy.types.Action.bl_rna.properties

_INTERPOLATION = {item.identifier: item.value
                  for item in bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items}
_HANDLE_TYPE = {item.identifier: item.value
                for item in bpy.types.Keyframe.bl_rna.properties["handle_left_type"].enum_items}


class Channel(tuple):
    """(data_path, array_index, group_name): one F-curve to write."""
    __slots__ = ()

    def __new__(cls, data_path: str, index: int = 0, group: str = ""):
        return super().__new__(cls, (data_path, int(index), group))

    data_path = property(lambda self: self[0])
    index = property(lambda self: self[1])
    group = property(lambda self: self[2])

    def __str__(self) -> str:
        return f"{self[0]}[{self[1]}]"


# An action's custom property: the frames per second its keys were captured at, when that is known (a BVH
# import records it); speeds and smoothing in seconds need it when the scene plays the clip at another rate.
FRAME_RATE = "motionkit_frame_rate"


def frame_rate(action) -> float:
    """Frames per second of an action's keys: as captured (FRAME_RATE), else the scene's."""
    rate = action.get(FRAME_RATE) if action is not None else None
    if rate is not None and float(rate) > 0:
        return float(rate)
    render = bpy.context.scene.render
    return render.fps / render.fps_base


def record_frame_rate(action, rate: float) -> None:
    """Keep the frames per second of action's keys on it (FRAME_RATE), when known (positive)."""
    if rate > 0:
        action[FRAME_RATE] = rate


def new_action(name: str) -> bpy.types.Action:
    return bpy.data.actions.new(name)


def _slot_for(action: bpy.types.Action, id_data: bpy.types.ID, create: bool):
    """The action's slot for this ID: the one assigned, else one named after it."""
    anim = id_data.animation_data
    if anim is not None and anim.action == action and anim.action_slot is not None:
        return anim.action_slot
    for slot in action.slots:
        if slot.target_id_type == id_data.id_type and slot.name_display == id_data.name:
            return slot
    # An importer may name an action's one slot after no object at all ("Slot" from FBX): it is still the
    # object's. A slot named after another object is that object's.
    if len(action.slots) == 1:
        slot = action.slots[0]
        if slot.target_id_type in (id_data.id_type, 'UNSPECIFIED') and slot.name_display not in bpy.data.objects:
            return slot
    if not create:
        return None
    return action.slots.new(id_type=id_data.id_type, name=id_data.name)


def _channelbag(action: bpy.types.Action, slot, create: bool):
    if not action.layers:
        if not create:
            return None
        action.layers.new("Layer")
    layer = action.layers[0]
    if not layer.strips:
        if not create:
            return None
        layer.strips.new(type='KEYFRAME')
    return layer.strips[0].channelbag(slot, ensure=create)


def assign(id_data: bpy.types.ID, action: bpy.types.Action) -> None:
    """Make id_data play action (and, in the layered world, its slot for id_data)."""
    anim = id_data.animation_data or id_data.animation_data_create()
    if LAYERED:
        slot = _slot_for(action, id_data, create=True)
        anim.action = action
        anim.action_slot = slot
    else:
        anim.action = action


def install_action(id_data: bpy.types.ID, action: bpy.types.Action, write, *, owned: bool = True) -> bpy.types.Action:
    """Key a new action and make id_data play it: write(action) fills it, then the action id_data played
    keeps a fake user (it must outlive losing its last user) and the new one is assigned. When anything
    fails the action is removed again if it was made for this (owned), and id_data plays what it played."""
    previous = assigned_action(id_data)
    try:
        write(action)
        if previous is not None and previous.users == 1 and not previous.use_fake_user:
            previous.use_fake_user = True
        assign(id_data, action)
    except BaseException:
        if owned:
            bpy.data.actions.remove(action)
        raise
    return action


def assignment(id_data: bpy.types.ID) -> tuple:
    """What id_data plays now, for restore(): (its action or None, the slot's identifier or None)."""
    anim = id_data.animation_data
    if anim is None or anim.action is None:
        return None, None
    slot = anim.action_slot if LAYERED else None
    return anim.action, (slot.identifier if slot is not None else None)


def restore(id_data: bpy.types.ID, held: tuple) -> None:
    """id_data plays again what assignment() read (nothing, or an action and its slot)."""
    action, identifier = held
    anim = id_data.animation_data
    if action is None:
        if anim is not None:
            anim.action = None
        return
    anim = anim or id_data.animation_data_create()
    anim.action = action
    if LAYERED and identifier is not None:
        slot = next((s for s in action.slots if s.identifier == identifier), None)
        if slot is not None:
            anim.action_slot = slot


def assigned_action(id_data: bpy.types.ID) -> bpy.types.Action | None:
    anim = id_data.animation_data
    return anim.action if anim is not None else None


def fcurves(action: bpy.types.Action, id_data: bpy.types.ID) -> Sequence[bpy.types.FCurve]:
    """The F-curves of action that animate id_data (empty when there are none)."""
    if not LAYERED:
        return action.fcurves
    slot = _slot_for(action, id_data, create=False)
    if slot is None:
        return ()
    bag = _channelbag(action, slot, create=False)
    return bag.fcurves if bag is not None else ()


def find_fcurve(action: bpy.types.Action, id_data: bpy.types.ID, data_path: str,
                index: int = 0) -> bpy.types.FCurve | None:
    curves = fcurves(action, id_data)
    return curves.find(data_path, index=index) if curves else None


def _curve_collection(action: bpy.types.Action, id_data: bpy.types.ID):
    if not LAYERED:
        return action.fcurves
    slot = _slot_for(action, id_data, create=True)
    return _channelbag(action, slot, create=True).fcurves


def new_fcurves(action: bpy.types.Action, id_data: bpy.types.ID, channels: Iterable) -> list[bpy.types.FCurve]:
    """The action's F-curves for channels (Channel or (data_path, index[, group])) animating id_data, made
    where this Blender keeps them and emptied of keys if they were there."""
    curves = _curve_collection(action, id_data)
    return [_new_fcurve(curves, c if isinstance(c, Channel) else Channel(*c)) for c in channels]


def _new_fcurve(curves, channel: Channel) -> bpy.types.FCurve:
    existing = curves.find(channel.data_path, index=channel.index)
    if existing is not None:
        existing.keyframe_points.clear()
        return existing
    if LAYERED:
        return curves.new(channel.data_path, index=channel.index, group_name=channel.group)
    # Legacy actions take the group through action_group.
    return curves.new(channel.data_path, index=channel.index, action_group=channel.group)


def _first_non_finite(channels: Sequence[Channel], frames: np.ndarray, values: np.ndarray) -> str:
    bad_frames = np.flatnonzero(~np.isfinite(frames))
    if bad_frames.size:
        return f"frame time at key {bad_frames[0]} is {frames[bad_frames[0]]}"
    curve, key = np.argwhere(~np.isfinite(values))[0]
    return f"{channels[curve]} at frame {frames[key]:g} (key {key}) is {values[curve, key]}"


class Handles(NamedTuple):
    """Bezier handles for write_keys, each key's left and right handle.

    left_frames, right_frames: (n,) handle times, shared by all channels.
    left_values, right_values: (c, n). aligned: (c, n) bool, True where the two
    handles of a key are collinear (ALIGNED, so the key stays smooth when an
    animator drags it), else FREE.
    """
    left_frames: np.ndarray
    left_values: np.ndarray
    right_frames: np.ndarray
    right_values: np.ndarray
    aligned: np.ndarray


def write_keys(id_data: bpy.types.ID, action: bpy.types.Action, channels: Iterable,
               frames, values, interpolation: str = 'LINEAR',
               handles: Handles | None = None) -> list[bpy.types.FCurve]:
    """Write one key per frame on each channel, replacing keys already on those curves.

    channels: sequence of Channel or (data_path, index[, group]).
    frames: (n,) strictly increasing key times. values: (len(channels), n).
    handles: exact Bezier handles (FREE or ALIGNED) instead of Blender's
    automatic ones; Blender then draws and evaluates the curve they define.
    Everything is checked before anything is written: a shape mismatch, a
    non-finite number or frames that do not increase raise ValueError naming the
    channel and frame, and leave the action untouched.
    """
    _native = native_state.native()
    channels = [c if isinstance(c, Channel) else Channel(*c) for c in channels]
    frames = np.ascontiguousarray(frames, dtype=np.float64)
    values = np.ascontiguousarray(values, dtype=np.float64)
    if values.ndim == 1 and len(channels) == 1:
        values = values[np.newaxis, :]
    if frames.ndim != 1 or values.shape != (len(channels), frames.size):
        raise ValueError(f"write_keys: expected values of shape ({len(channels)}, {frames.size}) "
                         f"for {len(channels)} channels and {frames.size} frames, got {values.shape}")
    if interpolation not in _INTERPOLATION:
        raise ValueError(f"write_keys: unknown interpolation {interpolation!r}; "
                         f"expected one of {sorted(_INTERPOLATION)}")
    if len(set(channels)) != len(channels):
        raise ValueError("write_keys: a channel is listed twice")
    co = _pack(_native, id_data, channels, frames, values)
    if handles is not None:
        left = _pack(_native, id_data, channels, handles.left_frames, handles.left_values, "left handle of ")
        right = _pack(_native, id_data, channels, handles.right_frames, handles.right_values, "right handle of ")
        aligned = np.asarray(handles.aligned, dtype=bool)
        if aligned.shape != values.shape:
            raise ValueError(f"write_keys: handles.aligned has shape {aligned.shape}, expected {values.shape}")
        # C order: Blender 3.4 crashes on a strided buffer in foreach_set.
        types = np.where(aligned, _HANDLE_TYPE['ALIGNED'], _HANDLE_TYPE['FREE']).astype(np.uint8, order='C')

    interp = np.full(frames.size, _INTERPOLATION[interpolation], dtype=np.uint8)
    written = new_fcurves(action, id_data, channels)
    for row, fcurve in enumerate(written):
        points = fcurve.keyframe_points
        points.add(frames.size)
        keys = _write_co(points, co[row])
        if interpolation != 'BEZIER':  # add() makes Bezier keys already
            _set_enum(points, "interpolation", interp, _INTERPOLATION)
        if handles is not None:
            for prop, array in (("handle_left", left[row]), ("handle_right", right[row])):
                if keys is not None:
                    keys.view(np.float32)[:, _POINT_FLOATS[prop]] = array.reshape(-1, 2)
                else:
                    points.foreach_set(prop, array)
            _set_enum(points, "handle_left_type", types[row], _HANDLE_TYPE)
            _set_enum(points, "handle_right_type", types[row], _HANDLE_TYPE)
        fcurve.update()
    return written


def merge_keys(id_data: bpy.types.ID, action: bpy.types.Action, channels: Iterable, frames, values) -> None:
    """write_keys over frames' span only: each channel's keys from frames[0] to frames[-1] replaced by one key
    per frame, its keys before and after kept as they were (every byte: frame, value, handles,
    interpolation, easing); a channel without a curve gets one. Checked as write_keys checks."""
    channels = [c if isinstance(c, Channel) else Channel(*c) for c in channels]
    frames = np.ascontiguousarray(frames, dtype=np.float64)
    curves = _curve_collection(action, id_data)
    found = [curves.find(c.data_path, index=c.index) for c in channels]
    kept = [None if fc is None else _key_rows(fc.keyframe_points, frames[0], frames[-1]) for fc in found]
    written = write_keys(id_data, action, channels, frames, values)
    for fcurve, outside in zip(written, kept):
        if outside is not None and (len(outside[0]) or len(outside[1])):
            _splice(fcurve, *outside)


def _key_rows(points, first: float, last: float) -> tuple[np.ndarray, np.ndarray]:
    """The keys before first and after last as BezTriple rows (n, 72) bytes, copies."""
    count = len(points)
    keys = _key_view(points) if count >= 2 else None
    if keys is None:
        if count:
            keys = np.zeros((count, _BEZTRIPLE_SIZE), dtype=np.uint8)
            _fill_rows(keys, points)
        else:
            keys = np.zeros((0, _BEZTRIPLE_SIZE), dtype=np.uint8)
    at = keys.view(np.float32)[:, _POINT_FLOATS["co"]][:, 0].astype(np.float64)
    # Keys are float32 frames: within half a float32 step of the span's ends they are the span's.
    tolerance = 1e-6 * max(1.0, abs(first), abs(last))
    return keys[at < first - tolerance].copy(), keys[at > last + tolerance].copy()


def _fill_rows(rows: np.ndarray, points) -> None:
    """rows' co, handles, interpolation and handle types from RNA (where the keys' array is not at hand)."""
    floats = rows.view(np.float32)
    for prop in ("co", "handle_left", "handle_right"):
        flat = np.empty(2 * len(points), dtype=np.float32)
        points.foreach_get(prop, flat)
        floats[:, _POINT_FLOATS[prop]] = flat.reshape(-1, 2)
    for i, key in enumerate(points):  # one or no key: nothing to do in bulk
        rows[i, _KEY_BYTE["interpolation"]] = _INTERPOLATION[key.interpolation]
        rows[i, _KEY_BYTE["handle_left_type"]] = _HANDLE_TYPE[key.handle_left_type]
        rows[i, _KEY_BYTE["handle_right_type"]] = _HANDLE_TYPE[key.handle_right_type]


def _splice(fcurve: bpy.types.FCurve, before: np.ndarray, after: np.ndarray) -> None:
    """fcurve's keys (just written) with before's and after's rows around them, byte for byte."""
    points = fcurve.keyframe_points
    new = _key_view(points) if len(points) >= 2 else None
    if new is None:
        new = np.zeros((len(points), _BEZTRIPLE_SIZE), dtype=np.uint8)
        _fill_rows(new, points)
    rows = np.vstack([before, new.copy(), after])
    points.clear()
    points.add(len(rows))
    keys = _write_co(points, np.ascontiguousarray(rows.view(np.float32)[:, _POINT_FLOATS["co"]]).reshape(-1))
    if keys is None:
        raise RuntimeError("MotionKit: this Blender's keys are not laid out as expected; please report its "
                           "version")
    keys[:] = rows
    fcurve.update()


def copy_action(action: bpy.types.Action, name: str) -> bpy.types.Action:
    """A copy of action (every curve, slot and key as it is), named name."""
    copied = action.copy()
    copied.name = name
    copied.use_fake_user = False
    return copied


def remove_curves(action: bpy.types.Action, id_data: bpy.types.ID, prefixes: Iterable[str]) -> None:
    """Removes the action's curves of id_data whose data path starts with one of prefixes."""
    prefixes = tuple(prefixes)
    curves = fcurves(action, id_data)
    if not curves or not prefixes:
        return
    for fcurve in [fc for fc in curves if fc.data_path.startswith(prefixes)]:
        curves.remove(fcurve)


BLEND_TYPES = {"replace": 'REPLACE', "add": 'COMBINE'}


def push_track(id_data: bpy.types.ID, action: bpy.types.Action, start: float, blend: str,
               influence: float, name: str | None = None) -> bpy.types.NlaStrip:
    """action as a strip from frame start on a new NLA track above id_data's others, blended (BLEND_TYPES:
    "add" is Blender's Combine: rotations compose, locations add) by influence, and nothing outside its
    frames. Blender plays an assigned action above every track: id_data's own goes down onto a track of its
    own first (at its own frames, held), so that the new track lies above it. name: the tracks' name (each
    is named after its action otherwise), for remove_tracks."""
    anim = id_data.animation_data or id_data.animation_data_create()
    own = anim.action
    if own is not None:
        slot = anim.action_slot if LAYERED else None
        below = _new_track(anim, own, int(round(own.frame_range[0])), slot, name)
        below.blend_type = 'REPLACE'
        anim.action = None
    strip = _new_track(anim, action, int(round(start)), _slot_for(action, id_data, create=True) if LAYERED else None,
                       name)
    strip.blend_type = BLEND_TYPES[blend]
    strip.extrapolation = 'NOTHING'
    if influence < 1.0:
        # Blender reads a strip's influence only when it is animated: one constant key holds it.
        strip.use_animated_influence = True
        curve = strip.fcurves.find("influence")
        curve.keyframe_points.clear()
        curve.keyframe_points.insert(float(start), float(influence)).interpolation = 'CONSTANT'
    return strip


def remove_tracks(id_data: bpy.types.ID, name: str) -> None:
    """id_data's NLA tracks that push_track named name (Blender may have numbered them: "name.001")."""
    anim = id_data.animation_data
    if anim is not None:
        for track in [t for t in anim.nla_tracks if t.name.startswith(name)]:
            anim.nla_tracks.remove(track)


def _new_track(anim, action: bpy.types.Action, start: int, slot, name: str | None = None) -> bpy.types.NlaStrip:
    """A strip of action from start on a new track (named name, else after the action) above anim's others."""
    tracks = anim.nla_tracks
    track = tracks.new(prev=tracks[-1] if len(tracks) else None)
    track.name = name or action.name
    strip = track.strips.new(action.name, start, action)
    if slot is not None:
        strip.action_slot = slot
    return strip


class NonFinite(NamedTuple):
    """A key of a curve that is not a finite number: what ('key': its frame or value; 'handle': one of its
    handles), its index and its frame (NaN when the frame itself is not a number)."""
    fcurve: bpy.types.FCurve
    what: str
    index: int
    frame: float


def first_non_finite(fcurves: Iterable[bpy.types.FCurve]) -> NonFinite | None:
    """The first key of fcurves, in their order, whose frame or value is not a finite number, or failing that
    the first with such a handle (a key comes first: Blender may recompute a neighbour's handles from it);
    None when every key is finite. Work on such keys would spread NaN through every value it computes."""
    for fcurve in fcurves:
        points = fcurve.keyframe_points
        count = len(points)
        if not count:
            continue
        read = {}
        for prop in ("co", "handle_left", "handle_right"):
            read[prop] = np.empty(2 * count, dtype=np.float32)
            points.foreach_get(prop, read[prop])
        finite = {prop: np.isfinite(values.reshape(count, 2)).all(axis=1) for prop, values in read.items()}
        for what, bad in (("key", ~finite["co"]), ("handle", ~(finite["handle_left"] & finite["handle_right"]))):
            if bad.any():
                key = int(np.argmax(bad))
                return NonFinite(fcurve, what, key, float(read["co"][2 * key]))
    return None


def set_key_values(id_data: bpy.types.ID, action: bpy.types.Action, channels: Iterable, values,
                   frames=None) -> None:
    """New values for the keys already on the channels' curves, in their order: values (len(channels), n),
    n each curve's key count. Frames, interpolation and handle types stay, and each key's handles move with
    it, so a FREE or ALIGNED curve keeps its shape about the new value. A missing curve, a count that
    differs or a non-finite value raises ValueError before any curve changes. frames: the keys' frames,
    when the caller has read them (every channel's the same); strictly increasing, they spare Blender 4.x
    and later the sort in fcurve.update() where only Auto handles are to be set again."""
    channels = [c if isinstance(c, Channel) else Channel(*c) for c in channels]
    values = np.asarray(values, dtype=np.float64)
    if len(values) != len(channels):
        raise ValueError(f"set_key_values on {id_data.name}: {len(values)} rows of values for {len(channels)} channels")
    curves = fcurves(action, id_data)
    found = [curves.find(channel.data_path, index=channel.index) for channel in channels]
    for channel, fcurve, row in zip(channels, found, values):
        if fcurve is None or len(fcurve.keyframe_points) != row.size:
            raise ValueError(f"set_key_values on {id_data.name}: {channel} has "
                             f"{'no curve' if fcurve is None else len(fcurve.keyframe_points)} keys, "
                             f"not {row.size}")
        if not np.all(np.isfinite(row)):
            raise ValueError(f"set_key_values on {id_data.name}: {channel} would get a non-finite value")
    # Sorted keys, Auto handles: update() is its sort, with nothing to move, then handles_recalc() (bitwise
    # the same keys on 4.3 and 5.2); the sort is 25 of update()'s 330 ms on bench/filters.py's 455 curves.
    ordered = frames is not None and bool(np.all(np.diff(frames) > 0))
    for fcurve, row in zip(found, values):
        points = fcurve.keyframe_points
        keys = _co_view(points)
        if keys is not None:
            if _move_values(keys, row) and ordered and hasattr(points, "handles_recalc"):
                points.handles_recalc()
                continue
        else:
            moved = {prop: _read_co(points, None, prop).reshape(-1, 2) for prop in _POINT_FLOATS}
            shift = (row - moved["co"][:, 1]).astype(np.float32)
            for prop, co in moved.items():
                co[:, 1] = row if prop == "co" else co[:, 1] + shift
                points.foreach_set(prop, co.reshape(-1))
        fcurve.update()


def _move_values(keys: np.ndarray, row: np.ndarray) -> bool:
    """Every key's value to row (float64) in the keys' own array (_co_view), both handles shifted by as
    much, in place: the same float32 values as the RNA way in set_key_values (shift rounded to float32,
    added to each handle in float32; the value rounded from float64). In-place column updates, because a
    (count, 3) temporary of the three values costs twice as much (strided rows of three floats). Where
    every handle is one that fcurve.update() sets again from the values alone, the handles are left to
    it (the same keys after the update, bitwise): returns whether they were."""
    values = keys.view(np.float32)[:, _VALUE_FLOATS]  # (count, 3): left handle's, co's and right handle's
    if _auto_handles(keys):
        values[:, 1] = row  # fcurve.update() computes every handle again from the values alone
        return True
    shift = (row - values[:, 1]).astype(np.float32)
    values[:, 0] += shift
    values[:, 2] += shift
    values[:, 1] = row
    return False


# Handle types Blender's handle recalculation sets from the keys' frames and values alone, whatever the
# handles were (Auto and Auto Clamped); Free and Aligned handles keep where they were.
_RECOMPUTED_HANDLES = (_HANDLE_TYPE["AUTO"], _HANDLE_TYPE["AUTO_CLAMPED"])


def _auto_handles(keys: np.ndarray) -> bool:
    """Whether every key (_key_view rows) has the first key's two handle types, both _RECOMPUTED_HANDLES.
    Read as the 32-bit word of bytes 48-51 (interpolation, left and right handle types, a flag byte; little
    endian, as every platform Blender runs on): a byte column compared apart costs three times as much."""
    words = keys.view(np.uint32)[:, _KEY_BYTE["interpolation"] // 4] & np.uint32(0x00FFFF00)
    first = int(words[0])
    return (((first >> 8) & 0xFF) in _RECOMPUTED_HANDLES and (first >> 16) in _RECOMPUTED_HANDLES
            and bool((words == words[0]).all()))


# Interpolation and handle types are one byte in each key. Blender 4.x and
# later copy a uint8 buffer straight into the keys (an int32 buffer goes
# through RNA key by key, an order of magnitude slower: docs/benchmarks.md,
# "Writing F-curve keys"); Blender 3.x takes the uint8
# call and changes nothing, and also ignores int32 for the handle types (fixed
# by 4.x). So each property keeps the first way that is seen to work, checked
# on every curve: uint8, int32, then the keys' BezTriple bytes directly
# (_key_view; DNA's BezTriple: ipo, h1, h2 after vec[3][3], tilt, weight,
# radius; unchanged since 2.8).
_BEZTRIPLE_SIZE = 72
_KEY_BYTE = {"interpolation": 48, "handle_left_type": 49, "handle_right_type": 50}
# Blender 4.x and later copy uint8 buffers straight in; 3.x goes through RNA
# key by key for any buffer, so there the checked byte write, several times
# faster (docs/benchmarks.md), comes first.
_WAYS = ("uint8", "int32", "keys") if bpy.app.version >= (4, 0, 0) else ("keys", "uint8", "int32")
_enum_way: dict[str, str] = {}


def _set_enum(points, prop: str, codes: np.ndarray, values: dict) -> None:
    """One enum value per key (codes: their integer values), in bulk; the keys' co already written."""
    if not len(points):
        return
    names = {value: name for name, value in values.items()}
    if len(points) == 1:  # nothing to do in bulk, and no second key for the layout check
        setattr(points[0], prop, names[int(codes[0])])
        return
    # The check must see a change: make the first key differ from what comes.
    if values[getattr(points[0], prop)] == codes[0]:
        setattr(points[0], prop, next(name for name, value in values.items() if value != codes[0]))
    known = _enum_way.get(prop)
    for way in ((known,) if known else ()) + tuple(w for w in _WAYS if w != known):
        if way == "keys":
            keys = _key_view(points)
            if keys is None:
                continue
            keys[:, _KEY_BYTE[prop]] = codes
        else:
            points.foreach_set(prop, np.ascontiguousarray(codes, dtype=way))
        if values[getattr(points[0], prop)] == codes[0] and values[getattr(points[-1], prop)] == codes[-1]:
            _enum_way[prop] = way
            return
    raise RuntimeError(f"MotionKit: this Blender does not take key {prop} in bulk "
                       f"(wanted {names[int(codes[0])]}); please report its version")


# A key's frame and value are BezTriple.vec[1][0] and vec[1][1], float32 at
# byte 12, its handles vec[0] and vec[2]. Blender's foreach_get and foreach_set
# of "co" go through RNA key by key; the keys' own array is a memory copy
# (docs/benchmarks.md has both per key). It is used only where the layout is seen to hold: consecutive
# keys 72 bytes apart, and the first and last keys' bytes equal to what RNA
# reports for their co, interpolation and handle types (their frames differ,
# so the check cannot pass on zeros).
# KEY_ARRAY = False: every co and handle goes through RNA's foreach_get /
# foreach_set, the documented bulk path (slower; results are the same).
KEY_ARRAY = True
# vec[0], vec[1] and vec[2]'s x and y, as float32 columns of a key (18 floats).
_POINT_FLOATS = {"handle_left": slice(0, 2), "co": slice(3, 5), "handle_right": slice(6, 8)}
# Columns 1, 4 and 7: the value (y) of vec[0], vec[1] and vec[2], as in _POINT_FLOATS.
_VALUE_FLOATS = slice(1, 8, 3)
# Column 3: the key's frame (vec[1]'s x), its value the next column.
_FRAME_FLOAT = _POINT_FLOATS["co"].start


def _key_view(points) -> np.ndarray | None:
    """The keys' BezTriple array as (count, 72) bytes, or None where its layout is not seen to hold."""
    count = len(points)
    if count < 2:
        return None
    first, last = points[0], points[count - 1]
    base = first.as_pointer()
    if points[1].as_pointer() - base != _BEZTRIPLE_SIZE or last.as_pointer() - base != (count - 1) * _BEZTRIPLE_SIZE:
        return None
    keys = np.ctypeslib.as_array((ctypes.c_uint8 * (count * _BEZTRIPLE_SIZE)).from_address(base))
    keys = keys.reshape(count, _BEZTRIPLE_SIZE)
    for row, key in ((0, first), (count - 1, last)):
        if (keys[row].view(np.float32)[_POINT_FLOATS["co"]].tolist() != list(np.array(key.co, dtype=np.float32))
                or keys[row, _KEY_BYTE["interpolation"]] != _INTERPOLATION[key.interpolation]
                or keys[row, _KEY_BYTE["handle_left_type"]] != _HANDLE_TYPE[key.handle_left_type]
                or keys[row, _KEY_BYTE["handle_right_type"]] != _HANDLE_TYPE[key.handle_right_type]):
            return None
    return keys


def _co_view(points) -> np.ndarray | None:
    """_key_view for co and handles, unless KEY_ARRAY is off."""
    return _key_view(points) if KEY_ARRAY else None


def _read_co(points, keys: np.ndarray | None, prop: str = "co") -> np.ndarray:
    """Every key's (frame, value) of co, handle_left or handle_right, interleaved float32 (2 count,), from
    keys (_co_view(points)) or else through RNA."""
    if keys is not None:
        return np.ascontiguousarray(keys.view(np.float32)[:, _POINT_FLOATS[prop]]).reshape(-1)
    co = np.empty(2 * len(points), dtype=np.float32)
    points.foreach_get(prop, co)
    return co


def _write_co(points, co: np.ndarray) -> np.ndarray | None:
    """Set every key's (frame, value) from interleaved float32 co (2 count,), C-contiguous; returns the
    keys' array (_co_view) when that is how they were written, for more of the same."""
    count = len(points)
    if count >= 2:
        # The two ends through RNA first: the layout check then compares real, distinct frames.
        points[0].co = co[0:2]
        points[count - 1].co = co[-2:]
        keys = _co_view(points)
        if keys is not None:
            keys.view(np.float32)[:, _POINT_FLOATS["co"]] = co.reshape(count, 2)
            return keys
    points.foreach_set("co", co)
    return None


def _pack(native, id_data, channels, frames, values, what: str = "") -> np.ndarray:
    """Keys as Blender's interleaved float32 (frame, value) rows, NaN and infinity refused."""
    frames = np.ascontiguousarray(frames, dtype=np.float64)
    values = np.ascontiguousarray(values, dtype=np.float64)
    try:
        co = native.keyframe_co(frames, values)
    except native.MotionKitError as ex:
        if "not finite" in str(ex):
            raise ValueError(f"write_keys on {id_data.name}: {what}"
                             f"{_first_non_finite(channels, frames, values)}") from None
        raise ValueError(f"write_keys on {id_data.name}: {what}{ex}") from None
    return co


def holds_every_key(fcurve: bpy.types.FCurve) -> bool:
    """Whether every key of fcurve holds its value until the next (CONSTANT interpolation), as a 0/1 foot
    contact does."""
    points = fcurve.keyframe_points
    if not len(points) or points[0].interpolation != 'CONSTANT':
        return False
    codes = np.empty(len(points), dtype=np.int32)
    points.foreach_get("interpolation", codes)  # the enum's storage: equal codes, equal interpolation
    return bool(np.all(codes == codes[0]))


def read_keys(fcurve: bpy.types.FCurve) -> tuple[np.ndarray, np.ndarray]:
    """(frames, values) of every key, as float32 arrays exactly as Blender stores them."""
    points = fcurve.keyframe_points
    keys = _co_view(points)
    if keys is not None:
        # Each column copied on its own: numpy copies a strided (count, 2) block at half the speed.
        floats = keys.view(np.float32)
        return floats[:, _FRAME_FLOAT].copy(), floats[:, _FRAME_FLOAT + 1].copy()
    co = _read_co(points, None)
    return co[0::2].copy(), co[1::2].copy()


def sample(action: bpy.types.Action, id_data: bpy.types.ID, channels: Iterable,
           frames, static=None) -> tuple[np.ndarray, np.ndarray]:
    """Values of the action's curves for channels at frames: (values (c, n), found (c,)).

    Channels without a curve that plays (none, a muted one, or one with neither
    keys nor modifiers: Blender's evaluation leaves their property alone) come
    back with found False, holding their static value (static: (c,), usually
    the properties' own values) on every frame, or NaN when static is None. Constant, linear
    and Bezier keys are evaluated natively, as fcurve.evaluate would; curves
    with modifiers or easing keys go through fcurve.evaluate itself.
    """
    native = native_state.native()
    channels = [c if isinstance(c, Channel) else Channel(*c) for c in channels]
    frames = np.ascontiguousarray(frames, dtype=np.float64)
    values = np.full((len(channels), frames.size), np.nan)
    found = np.zeros(len(channels), dtype=bool)
    curves = fcurves(action, id_data) if action is not None else ()
    native_rows, keys = [], []
    for row, channel in enumerate(channels):
        fcurve = curves.find(channel.data_path, index=channel.index) if curves else None
        if fcurve is None or fcurve.mute:
            continue
        points = fcurve.keyframe_points
        count = len(points)
        modified = len(fcurve.modifiers) > 0
        if not count and not modified:  # Blender's animation system passes an empty curve over too
            continue
        found[row] = True
        view = _co_view(points)
        co = _read_co(points, view)
        if not modified and count == frames.size and np.array_equal(co[0::2], frames.astype(np.float32)):
            # A key on every frame asked for (baked or imported motion): a curve
            # passes through its keys whatever their interpolation.
            values[row] = co[1::2]
            continue
        if view is not None:
            interp = view[:, _KEY_BYTE["interpolation"]].astype(np.int32)
        else:
            interp = np.empty(count, dtype=np.int32)
            points.foreach_get("interpolation", interp)
        if modified or not count or np.any(interp > _INTERPOLATION['BEZIER']):
            values[row] = [fcurve.evaluate(f) for f in frames]  # modifiers or easing keys
            continue
        arrays = [co] + [_read_co(points, view, name) for name in ("handle_left", "handle_right")]
        native_rows.append(row)
        keys.append((arrays, interp, fcurve.extrapolation == 'LINEAR'))
    if keys:
        offsets = np.concatenate([[0], np.cumsum([len(k[1]) for k in keys])]).astype(np.int32)
        co, left, right = (np.concatenate([k[0][i] for k in keys]).astype(np.float64).reshape(-1, 2)
                           for i in range(3))
        interp = np.concatenate([k[1] for k in keys])
        linear = np.array([k[2] for k in keys], dtype=np.int32)
        values[native_rows] = native.evaluate_fcurves(co, left, right, interp, offsets, linear, frames)
    if static is not None:
        values[~found] = np.asarray(static, dtype=np.float64).reshape(-1)[~found, None]
    return values, found
