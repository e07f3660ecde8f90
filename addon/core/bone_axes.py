"""Where each bone points, for rigs whose bones' Y axes do not run along their limbs (numpy, no bpy).

Blender draws a bone from head to tail along its Y axis, and MotionKit takes
that axis as where the bone points. Blender's FBX importer without automatic
bone orientation leaves every bone's axes as the file's joint frames, so a
Mixamo clip's bones all point one way whatever their joints do; with it, each
bone takes the joint frame's axis nearest its child (a spine 7 degrees off
its next joint); a glTF import's thumb may point 40 degrees off. Two rigs are
only compared alike if a bone's direction means the same on both: the
direction to the head of the child that continues it, wherever its Y axis
does not already run there.
"""
from __future__ import annotations

import numpy as np

from . import bone_mapping
from .rotation_channels import conjugate, rotate_each

# A bone whose Y axis lies farther than this from its continuing child's head does not run along its limb.
_OFF_LIMB_DEG = 0.1
# On a rig where most bones are off, a leaf turned farther than this from its parent's line is too.
_OFF_LEAF_DEG = 45.0


def _units(v):
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def _edges(heads, parents):
    """Each parent-child pair whose heads lie apart: (child, parent, offset, distance) arrays."""
    count = len(heads)
    size = max(float(np.ptp(heads, axis=0).max()), 1e-12) if count else 1.0
    child = np.flatnonzero(parents >= 0)
    parent = parents[child]
    offset = heads[child] - heads[parent]
    distance = np.linalg.norm(offset, axis=1)
    apart = distance > 1e-4 * size  # a child whose head sits on its parent's says nothing of its direction
    return child[apart], parent[apart], offset[apart], distance[apart]


def continuing_children(heads, parents) -> np.ndarray:
    """(bones,) the child that continues each bone, -1 for none: its parent's line carried on most
    straightly, or for a root the child with the most bones below (equal: the first). Children whose heads
    sit on their parent's are never chosen. heads (bones, 3), parents (bones,), parents before children."""
    heads = np.asarray(heads, dtype=np.float64)
    parents = np.asarray(parents, dtype=np.int64)
    count = len(heads)
    out = np.full(count, -1, dtype=np.int64)
    child, parent, offset, distance = _edges(heads, parents)
    if not len(child):
        return out
    below = np.zeros(count, dtype=np.int64)
    for i in range(count - 1, -1, -1):  # parents come before children
        if parents[i] >= 0:
            below[parents[i]] += 1 + below[i]
    incoming = _units(heads - heads[np.maximum(parents, 0)])
    valid = (parents >= 0) & (np.linalg.norm(heads - heads[np.maximum(parents, 0)], axis=1) > 0)
    score = np.where(valid[parent], np.einsum("ij,ij->i", offset / distance[:, None], incoming[parent]),
                     below[child].astype(np.float64))
    order = np.lexsort((-child, score, parent))
    last = np.r_[parent[order][1:] != parent[order][:-1], True]
    out[parent[order[last]]] = child[order[last]]
    return out


def without_direction(heads, parents) -> np.ndarray:
    """(bones,) bool: the bones that have children but none standing off their own head (a Mixamo `*_split`
    joint or a twist bone at its parent's head makes that parent such a bone). Such a bone points nowhere
    of its own: the importer gives it an axis of its choosing (Blender's BVH import, a millimetre along Z),
    so that no angle between it and another rig's bone says the two stand in different poses. A leaf keeps
    its direction (its tail is its end: a head top, a toe). heads (bones, 3), parents (bones,), parents
    before children."""
    heads = np.asarray(heads, dtype=np.float64)
    parents = np.asarray(parents, dtype=np.int64)
    has_children = np.zeros(len(heads), dtype=bool)
    has_children[parents[parents >= 0]] = True
    return has_children & (continuing_children(heads, parents) < 0)


def aims(heads, tails, parents, rest, continuing=None) -> tuple[np.ndarray, np.ndarray] | None:
    """(bones, 3) where each bone points in its own rest frame, and (bones,) how far its aimed point lies
    from its head (the child's head; a bone left along Y or a leaf: its length), or None where every bone's
    Y axis runs along its limb. heads, tails (bones, 3) rest positions; parents (bones,) indices, -1 for roots,
    parents before children; rest (bones, 4) rest orientations (w x y z); continuing (bones,) the child each
    bone points at (-1: none), by default continuing_children's (a retarget passes one rig's choice through
    the bone map to the other, so that a hand points at the same finger on both).

    A bone whose Y axis lies more than 0.1 degree from its continuing child's head is aimed there; on a rig
    where most bones are so, a leaf whose Y axis turns more than 45 degrees off its parent's line points on
    along that line.
    """
    heads, tails = np.asarray(heads, dtype=np.float64), np.asarray(tails, dtype=np.float64)
    parents = np.asarray(parents, dtype=np.int64)
    count = len(heads)
    if not count:
        return None
    continuing = continuing_children(heads, parents) if continuing is None else np.asarray(continuing)
    reach = np.linalg.norm(tails - heads, axis=1)
    axes = _units(tails - heads)
    has_children = continuing >= 0
    directions = np.full((count, 3), np.nan)
    offset = heads[continuing[has_children]] - heads[has_children]
    reach_of = reach.copy()
    reach_of[has_children] = np.linalg.norm(offset, axis=1)
    directions[has_children] = _units(offset)
    off = has_children & (np.einsum("ij,ij->i", axes, np.nan_to_num(directions))
                          < np.cos(np.radians(_OFF_LIMB_DEG)))
    incoming = _units(heads - heads[np.maximum(parents, 0)])
    valid = (parents >= 0) & (np.linalg.norm(heads - heads[np.maximum(parents, 0)], axis=1) > 0)
    leaves = (off.sum() >= 0.5 * has_children.sum()) & ~has_children & valid & (
        np.einsum("ij,ij->i", axes, incoming) < np.cos(np.radians(_OFF_LEAF_DEG)))
    directions[leaves] = incoming[leaves]
    aimed = off | leaves
    if not aimed.any():
        return None
    out = np.tile([0.0, 1.0, 0.0], (count, 1))
    out[aimed] = rotate_each(conjugate(np.asarray(rest, dtype=np.float64)[aimed]), directions[aimed])
    return out, np.where(off, reach_of, reach)


# An unmapped joint between two mapped ones that stands this far off the line between them is a helper
# (a Mixamo clavicle's `*_split` joint stands 55 degrees off it), not a segment of the limb (a two-bone neck's
# middle joint lies within a few degrees of the line from the neck to the head).
_OFF_CHAIN_DEG = 20.0


def helpers_between(rig, mapped) -> list[int]:
    """The unmapped bones between two mapped ones that are helpers, not segments of a limb: named so
    (core.bone_mapping: Mixamo's `*_split` joints, twist bones) or standing more than _OFF_CHAIN_DEG off the
    line from the mapped bone above to the one below. mapped: per bone, whether it is mapped."""
    heads = np.asarray(rig.heads, dtype=np.float64)
    found = set()
    for child, up, between in _mapped_spans(rig, mapped):
        found.update(j for j in between if bone_mapping.name_info(rig.names[j]).helper
                     or _off_line(heads[up], heads[j], heads[child]))
    return sorted(found)


def _mapped_spans(rig, mapped):
    """(mapped bone, its nearest mapped ancestor, the unmapped bones between, lowest first) for every mapped
    bone that has a mapped ancestor."""
    for child in range(len(rig.parents)):
        if not mapped[child]:
            continue
        between, up = [], int(rig.parents[child])
        while up >= 0 and not mapped[up]:
            between.append(up)
            up = int(rig.parents[up])
        if up >= 0:
            yield child, up, between


def _mapped_below(rig, mapped) -> dict:
    """Per bone, its mapped descendants reached through unmapped helper joints only (helpers_between: a
    clavicle's arm past a `*_split` joint), a direct child first."""
    below: dict = {}
    helpers = set(helpers_between(rig, mapped))
    for child, up, between in _mapped_spans(rig, mapped):
        if not helpers.issuperset(between):
            continue
        below.setdefault(up, []).append((len(between), child))
    return {bone: [c for _, c in sorted(found)] for bone, found in below.items()}


def _off_line(start, joint, end) -> bool:
    to_end, to_joint = end - start, joint - start
    norms = np.linalg.norm(to_end) * np.linalg.norm(to_joint)
    return norms > 0 and float(to_end @ to_joint) < np.cos(np.radians(_OFF_CHAIN_DEG)) * norms


def _prefer_mapped_children(source, target_below, source_next, bone_map) -> None:
    """A mapped source bone whose continuing child is no mapped bone, but which has a mapped descendant (the
    target bone of which hangs under its own target bone, past unmapped bones only), continues into that
    descendant instead: a thigh carrying secondary joints (pant legs, skin helpers) that carry the hip's line
    on more straightly than the knee points at its knee, as the other rig's does. target_below: the target's
    _mapped_below. source_next changed in place."""
    target_of = {int(a): t for t, a in enumerate(bone_map) if a >= 0}
    below = _mapped_below(source, [a in target_of for a in range(len(source.parents))])
    for t, a in enumerate(bone_map):
        if a < 0 or int(source_next[a]) in target_of:
            continue
        for child in below.get(int(a), []):
            if target_of[child] in target_below.get(t, []):
                source_next[a] = child
                break


def paired_aims(source, target, bone_map) -> tuple[np.ndarray | None, np.ndarray | None]:
    """aims of two rigs' rest poses (core.rig_data.RigData; None where every bone runs along its Y axis), a
    bone's direction meaning the same on both: a target bone points at the child mapped to the source's
    continuing child (a hand at the same finger, whatever each rest pose's wrist does), and where one of a
    pair has nothing to point at (a hand without fingers) both keep their own axes. bone_map: per target
    bone its source bone, -1 for none."""
    source_next = source.continuing_children()
    target_next = target.continuing_children()
    target_below = _mapped_below(target, [a >= 0 for a in bone_map])
    _prefer_mapped_children(source, target_below, source_next, bone_map)
    for t, a in enumerate(bone_map):
        if a >= 0 and (source_next[a] < 0 or target_next[t] < 0):
            source_next[a] = target_next[t] = -1
    # A target bone points at the mapped descendant (past unmapped bones: a clavicle past a `*_split`
    # joint to its arm) that is the source's continuing child's.
    for parent, children in target_below.items():
        for child in children:
            if bone_map[parent] >= 0 and source_next[bone_map[parent]] == bone_map[child]:
                target_next[parent] = child
                break
    found = (source.aims(source_next), target.aims(target_next))
    return tuple(None if found_aims is None else found_aims[0] for found_aims in found)
