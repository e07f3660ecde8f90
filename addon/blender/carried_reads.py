"""The channels a retarget carries beside the bones' rotations and the root's path (RetargetOptions.channels,
core/channel_carry), read from Blender once with the rest of the retarget's inputs (blender/retarget_reads):
each mapped bone's scale, the animated custom properties of the mapped bones and of the object, and the
shape-key values of the source's meshes, sampled on the clip's frames, each onto the target's place of the
same (or channel_map's) name. A channel the target has no place for is left out, and said why
(channel_carry.LeftOut).
"""
from __future__ import annotations

import bpy
import numpy as np

from . import animdata, pose_channels
from ..core import channel_carry
from ..core.channel_carry import Carried, LeftOut


def read(source, target, action, frames, pairs, written, options) -> Carried:
    """The source's channels on frames that the target takes, and those it has no place for. pairs: the
    plan's (source bone, target bone); written: the target bones the plan writes (names; None: all)."""
    carried = Carried(values=np.empty((0, len(frames))))
    chosen = set(options.channels)
    targets_of = {}
    for a, b in pairs:
        if written is None or b in written:
            targets_of.setdefault(a, []).append(b)
    unmapped = {a for a, _ in pairs} - set(targets_of)  # mapped, but onto bones not written (parts): silent
    rows = []
    curves = list(animdata.fcurves(action, source))
    if "scale" in chosen:
        rows += _scales(source, target, action, curves, frames, targets_of, options.into, carried)
    if "properties" in chosen:
        rows += _properties(source, target, action, curves, frames, (targets_of, unmapped), options.channel_map,
                            carried)
    if rows:
        carried.values = np.vstack(rows)
    if "shape_keys" in chosen:
        _shape_keys(source, target, frames, options.channel_map, carried)
    return carried


# A scale this close to 1 on every frame is a unit scale rounded to float32 (Blender's FBX importer keys
# 1 - 6e-8 on Mixamo's bones): four units of float32's last place.
UNIT_SCALE = 4 * 2.0 ** -23


def _scales(source, target, action, curves, frames, targets_of, into, carried) -> list:
    """Each mapped bone's scale where the source keys it. A unit scale on every frame (UNIT_SCALE) carries
    nothing the target's rest pose lacks: it is written only where the keys go into or over the target's own
    action (into "current" or "nla") and that animates the bone's scale (which would otherwise show)."""
    paths = {fc.data_path for fc in curves}
    bones = [b for b in targets_of if f"{pose_channels.bone_path(b)}.scale" in paths]
    if not bones:
        return []
    channels = [(f"{pose_channels.bone_path(b)}.scale", i) for b in bones for i in range(3)]
    static = [v for b in bones for v in source.pose.bones[b].scale]
    values, _ = animdata.sample(action, source, channels, frames, static)
    own = animdata.assigned_action(target) if into in ("current", "nla") else None
    rows = []
    for k, bone in enumerate(bones):
        scale = values[3 * k:3 * k + 3]
        for tgt in targets_of[bone]:
            path = f"{pose_channels.bone_path(tgt)}.scale"
            animated = own is not None and any(animdata.find_fcurve(own, target, path, i) is not None
                                               for i in range(3))
            if animated or np.any(np.abs(scale - 1.0) > UNIT_SCALE):
                carried.channels += [animdata.Channel(path, i, tgt) for i in range(3)]
                rows.append(scale)
    return rows


def _properties(source, target, action, curves, frames, bones, channel_map, carried) -> list:
    """The animated custom properties of the source's mapped bones and of its object, onto the target's of
    the same (or channel_map's) name. bones: ({source bone: its written target bones}, the source bones
    mapped onto bones not written)."""
    targets_of, unwritten = bones
    sampled, places = [], []
    reported = set()
    for fc in curves:
        found = channel_carry.bone_property(fc.data_path)
        prop = found[1] if found else channel_carry.object_property(fc.data_path)
        if prop is None or channel_carry.is_own(prop) or (found and found[0] in unwritten):
            continue
        name = f'{found[0]}["{prop}"]' if found else f'["{prop}"]'
        wanted = channel_carry.target_name(prop, channel_map)
        if found and found[0] not in targets_of:
            reasons = [f"the bone '{found[0]}' is not mapped"]
            holders = []
        else:
            holders = [(target.pose.bones[t], f"the target's bone '{t}'", t) for t in targets_of[found[0]]] \
                if found else [(target, f"the target '{target.name}'", "")]
            reasons = [_lacks(holder, wanted, fc.array_index, what) for holder, what, _ in holders]
        for (holder, _, group), reason in zip(holders, reasons):
            if reason is None:
                path = channel_carry.bone_property_path(group, wanted) if found else \
                    channel_carry.object_property_path(wanted)
                places.append(animdata.Channel(path, fc.array_index, group))
                sampled.append((fc.data_path, fc.array_index))
        for reason in reasons:
            if reason is not None and (name, reason) not in reported:
                reported.add((name, reason))
                carried.left_out.append(LeftOut("property", name, reason))
    if not sampled:
        return []
    values, _ = animdata.sample(action, source, sampled, frames)
    carried.channels += places
    return [values]


def _lacks(holder, name: str, index: int, what: str) -> str | None:
    """Why holder (a pose bone or an object) cannot take the value of a property's index, or None."""
    value = holder.get(name)
    if value is None:
        return f"{what} has no property '{name}'"
    if isinstance(value, str) or hasattr(value, "keys"):
        return f"{what}'s property '{name}' is not a number"
    length = len(value) if hasattr(value, "__len__") else 1
    if index >= length:
        return f"{what}'s property '{name}' has {length} value{'s' if length != 1 else ''}, not {index + 1}"
    return None


def deformed_meshes(armature) -> list:
    """The meshes with shape keys that the armature carries: parented to it or deformed by an Armature
    modifier of it, by name."""
    meshes = [o for o in bpy.data.objects if o.type == 'MESH' and o.data.shape_keys is not None and (
        o.parent == armature or any(m.type == 'ARMATURE' and m.object == armature for m in o.modifiers))]
    return sorted(meshes, key=lambda o: o.name)


def _shape_keys(source, target, frames, channel_map, carried) -> None:
    """Each shape key the source's meshes animate, onto every target mesh with a shape key of the same (or
    channel_map's) name; a name animated on two source meshes is taken from the first by name."""
    first = {}  # name: (source Key, its action, data path)
    for mesh in deformed_meshes(source):
        key = mesh.data.shape_keys
        action = animdata.assigned_action(key)
        for fc in (animdata.fcurves(action, key) if action is not None else ()):
            name = channel_carry.shape_key(fc.data_path)
            if name is not None and name not in first:
                first[name] = (key, action, fc.data_path)
    if not first:
        return
    keys = list(dict.fromkeys(m.data.shape_keys for m in deformed_meshes(target)))
    sampled = {}  # source Key: (action, paths)
    for name, (key, action, path) in first.items():
        sampled.setdefault(key, (action, []))[1].append(path)
    values = {}
    for key, (action, paths) in sampled.items():
        found, _ = animdata.sample(action, key, [(p, 0) for p in paths], frames)
        values.update(zip(paths, found))
    into = {}  # target Key: (channels, rows)
    for name, (_, _, path) in first.items():
        wanted = channel_carry.target_name(name, channel_map)
        holders = [k for k in keys if wanted in k.key_blocks]
        if not holders:
            carried.left_out.append(LeftOut("shape_key", name, (
                f"no mesh of the target '{target.name}' has a shape key '{wanted}'" if keys else
                f"the target '{target.name}' has no mesh with shape keys")))
        for key in holders:
            channels, rows = into.setdefault(key, ([], []))
            channels.append(animdata.Channel(channel_carry.shape_key_path(wanted), 0, ""))
            rows.append(values[path])
    carried.shapes = [(key, channels, np.vstack(rows)) for key, (channels, rows) in into.items()]
