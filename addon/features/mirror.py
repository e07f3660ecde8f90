"""Mirror an armature's action left <-> right across its plane of symmetry: motionkit.mirror.

Bones pair by their side markers (core/side_names.py). The action's pose channels are read in bulk on
its key frames, the whole clip is posed and mirrored in one native call (the world-space motion
reflected, then re-expressed in each bone's own rest: native/include/motionkit/mirror.hpp), and a new
action is written in each bone's own rotation mode, continuous Euler angles included. Everything is
computed and checked before anything in the file changes, so an error leaves it as it was.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..blender import animdata, pose_channels
from ..core import native_state, side_names
from .resampling import KeyWrite, check_finite, check_keys_finite

PLANES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
# A bone without a side marker is a centre bone, mirrored onto itself, when its rest head lies this close to
# the plane (a fraction of the rig's size); further off (a prop) it keeps its local transform.
CENTRE_FRACTION = 1e-3
# A bone whose mirrored location channel stays this close to zero (a fraction of the rig's size) on every
# frame, and whose source had no location keys, gets none: float32 rests are symmetric only to ~1e-7.
LOCATION_FRACTION = 1e-5


@dataclass
class MirrorReport:
    """What motionkit.mirror did."""
    action: str  # the new action's name
    pairs: list = field(default_factory=list)  # (left, right) bone names mirrored onto each other, each pair once
    centre: list = field(default_factory=list)  # bones mirrored onto themselves
    kept_local: list = field(default_factory=list)  # bones without a partner that keep their local transform
    frames: int = 0  # keys per curve


@dataclass
class _Roles:
    """Per target bone (parents first), which source bone drives it and how (the native job's lists)."""
    partners: list  # the source bone mirrored onto it, or -1
    kept: list  # without a partner: the source bone whose pose channels it keeps, or -1 for its rest
    report: MirrorReport


def mirror(obj, *, plane="X", plane_offset: float = 0.0, target=None, action_name: str | None = None,
           pairs=None, frame_range=None, progress=None) -> MirrorReport:
    """Mirror obj's action left <-> right into a new action, on obj or on target.

    plane: 'X', 'Y' or 'Z', the armature-space plane where that coordinate is plane_offset (default the
    armature's X = 0), or a (normal, point) pair in armature space. target: another armature whose bones
    have the same names (default obj itself); it plays the new action. pairs: (a, b) bone names that pair
    whatever their names say. frame_range: (first, last) frames mirrored (default every key). Keys land on
    the source's key frames. Returns a MirrorReport; a ValueError leaves everything as it was.
    """
    source = _armature(obj, "armature")
    target = source if target is None else _armature(target, "target")
    action = animdata.assigned_action(source)
    if action is None:
        raise ValueError(f"'{source.name}' has no action to mirror")
    check_keys_finite(source, [fc for fc in animdata.fcurves(action, source) if fc.data_path.startswith("pose.bones")],
                      "mirror")
    normal, point = _plane(plane, plane_offset)
    rig, bones = pose_channels.native_rig(source.data)
    target_rig, target_bones = (rig, bones) if target is source else pose_channels.native_rig(target.data)
    roles = _roles(source, bones, [b.name for b in target_bones], normal, point, pairs)
    frames = _key_frames(source, action, bones, frame_range)
    if progress is not None:
        progress(0, 2)
    basis = pose_channels.rotations(source, action, bones, frames)
    moved, _ = pose_channels.locations(source, action, bones, frames)
    with native_state.blender_frames(frames):
        rotations, locations = native_state.native().mirror(
            rig, target_rig, basis, np.ascontiguousarray(moved), roles.partners, roles.kept, normal=normal,
            point=point)
    if progress is not None:
        progress(1, 2)
    writes = _writes(source, action, bones, target, target_bones, roles, frames, rotations, locations)
    check_finite(target, writes)
    new = animdata.install_action(target, animdata.new_action(action_name or f"{action.name} Mirrored"),
                                  lambda written: _write(target, written, writes, action))
    roles.report.action = new.name  # Blender numbers a name already taken
    roles.report.frames = int(frames.size)
    return roles.report


def _armature(obj, role: str):
    if not isinstance(obj, bpy.types.Object) or obj.type != 'ARMATURE':
        raise ValueError(f"the {role} '{getattr(obj, 'name', obj)}' is not an armature object")
    if not len(obj.data.bones):
        raise ValueError(f"the {role} '{obj.name}' has no bones")
    if obj.library is not None:
        raise ValueError(f"'{obj.name}' is linked from '{obj.library.filepath}' and cannot be keyed here; make a "
                         f"library override first")
    return obj


def _plane(plane, offset) -> tuple[np.ndarray, np.ndarray]:
    """(unit normal, point) of the mirror plane in armature space."""
    if isinstance(plane, str):
        if plane not in PLANES:
            raise ValueError(f"unknown plane {plane!r}; expected one of {list(PLANES)} or (normal, point)")
        normal = np.array(PLANES[plane])
        return normal, float(offset) * normal
    try:
        normal, point = (np.asarray(v, dtype=np.float64).reshape(3) for v in plane)
    except (TypeError, ValueError):
        normal = point = np.full(3, np.nan)
    length = np.linalg.norm(normal)
    if not (np.isfinite(length) and length > 1e-12 and np.all(np.isfinite(point))):
        raise ValueError("the plane needs a finite, non-zero normal and a finite point, three numbers each")
    return normal / length, point


def _roles(source, bones, target_names, normal, point, pairs) -> _Roles:
    """Which source bone each target bone mirrors or keeps: side bones their partners; centre bones (no
    marker, head on the plane, or paired with themselves) themselves; other unmarked bones keep their own
    local transform; target bones the source lacks stay at rest."""
    names = [b.name for b in bones]
    index = {name: i for i, name in enumerate(names)}
    partner_of = side_names.partners(names, pairs)
    near = CENTRE_FRACTION * pose_channels.rig_size(source.data)
    off_plane = {b.name for b in bones if abs(float(np.dot(np.array(b.head_local) - point, normal))) > near}
    forced = {a for a, b in pairs or () if a == b}
    report, partners, kept = MirrorReport(""), [], []
    for name in target_names:
        partner = partner_of.get(name)
        local = partner == name and name in off_plane and name not in forced
        partners.append(index[partner] if partner is not None and not local else -1)
        kept.append(index[name] if local else -1)
        if local:
            report.kept_local.append(name)
        elif partner == name:
            report.centre.append(name)
        elif partner is not None and (partner, name) not in report.pairs:
            report.pairs.append((name, partner))
    return _Roles(partners, kept, report)


def _key_frames(obj, action, bones, frame_range) -> np.ndarray:
    """The frames where the bones' curves have keys (within frame_range, whose ends count too)."""
    paths = {pose_channels.bone_path(b.name) for b in bones}
    curves = [fc for fc in animdata.fcurves(action, obj) if fc.data_path.rsplit(".", 1)[0] in paths]
    keys = [animdata.read_keys(fc)[0] for fc in curves]
    frames = np.unique(np.concatenate(keys).astype(np.float64)) if keys else np.empty(0)
    if frames.size and frame_range is not None:
        first, last = float(frame_range[0]), float(frame_range[1])
        if last < first:
            raise ValueError(f"frame range {first:g}..{last:g} is empty")
        ends = [f for f in (first, last) if frames[0] <= f <= frames[-1]]
        frames = np.unique(np.concatenate([frames[(frames >= first) & (frames <= last)], ends]))
    if not frames.size:
        raise ValueError(f"'{action.name}' has no bone keys to mirror" + (" in that frame range" if frame_range
                                                                        else ""))
    return frames


def _keyed(obj, action, bones) -> dict[str, set]:
    """{bone name: the transform properties its curves key ('location', 'rotation', 'scale')}."""
    owners = {pose_channels.bone_path(b.name): b.name for b in bones}
    keyed = {}
    for fcurve in animdata.fcurves(action, obj):
        owner, _, prop = fcurve.data_path.rpartition(".")
        kind = next((k for k in ("location", "rotation", "scale") if prop.startswith(k)), None)
        if owner in owners and kind is not None:
            keyed.setdefault(owners[owner], set()).add(kind)
    return keyed


def _writes(source, action, bones, target, target_bones, roles: _Roles, frames, rotations, locations) -> list:
    """The new action's keys: rotations of the bones the mirror drives (keyed in the source, or turned off
    their rest), locations where the source keyed them or the mirror moves a bone off its rest head, and
    each bone's partner's scale. A connected bone takes no location: Blender ignores it."""
    keyed = _keyed(source, action, bones)
    drivers = [p if p >= 0 else k for p, k in zip(roles.partners, roles.kept)]
    near = LOCATION_FRACTION * pose_channels.rig_size(target.data)
    turned, moved, scaled = [], [], []
    for b, (bone, driver) in enumerate(zip(target_bones, drivers)):
        if driver < 0:
            continue
        own = keyed.get(bones[driver].name, set())
        q = rotations[:, 4 * b:4 * b + 4]
        if "rotation" in own or np.any(np.abs(q[:, 0]) < 1.0 - 1e-12):
            turned.append(b)
        if not bone.use_connect and ("location" in own or np.any(np.abs(locations[:, 3 * b:3 * b + 3]) > near)):
            moved.append(b)
        if "scale" in own:
            scaled.append((bone.name, bones[driver].name))
    writes = []
    interpolation = _interpolation(source, action)
    if turned:
        columns = (4 * np.array(turned)[:, None] + np.arange(4)).ravel()
        channels, values = pose_channels.rotation_keys(target, [target_bones[b].name for b in turned],
                                                       rotations[:, columns])
        writes.append(KeyWrite(channels, frames, values, interpolation, None))
    if moved:
        channels = [(f"{pose_channels.bone_path(target_bones[b].name)}.location", k, target_bones[b].name)
                    for b in moved for k in range(3)]
        values = np.vstack([locations[:, 3 * b:3 * b + 3].T for b in moved])
        writes.append(KeyWrite(channels, frames, values, interpolation, None))
    if scaled:
        writes.append(_scale_write(source, action, target, scaled, frames, interpolation))
    return writes


def _scale_write(source, action, target, scaled, frames, interpolation) -> KeyWrite:
    """Each (bone, partner) pair's bone keyed with the partner's own scale channels."""
    read = [(f"{pose_channels.bone_path(partner)}.scale", k) for _, partner in scaled for k in range(3)]
    static = np.array([source.pose.bones[partner].scale for _, partner in scaled], dtype=np.float64).reshape(-1)
    values, _ = animdata.sample(action, source, read, frames, static)
    channels = [(f"{pose_channels.bone_path(bone)}.scale", k, bone) for bone, _ in scaled for k in range(3)]
    return KeyWrite(channels, frames, values, interpolation, None)


def _interpolation(obj, action) -> str:
    """The interpolation most of the bones' curves start with (Bezier for anything else)."""
    counts = Counter(fc.keyframe_points[0].interpolation for fc in animdata.fcurves(action, obj)
                     if len(fc.keyframe_points) and fc.data_path.startswith("pose.bones["))
    common = counts.most_common(1)[0][0] if counts else 'BEZIER'
    return common if common in ('CONSTANT', 'LINEAR', 'BEZIER') else 'BEZIER'


def _write(target, action, writes, source_action) -> None:
    for write in writes:
        animdata.write_keys(target, action, write.channels, write.frames, write.values, write.interpolation)
    animdata.record_frame_rate(action, animdata.frame_rate(source_action))
