"""Where each bone points, for rigs whose bones' Y axes do not run along their limbs (numpy, no bpy).

Blender draws a bone from head to tail along its Y axis, and MotionKit takes
that axis as where the bone points. Blender's FBX importer without automatic
bone orientation leaves every bone's axes as the file's joint frames, so a
Mixamo clip's bones all point one way whatever their joints do, and a glTF
import's thumb may point 40 degrees off its next joint. For such bones the
aim is the direction to the head of the child that continues the bone.
"""
from __future__ import annotations

import numpy as np

from .rotation_channels import conjugate, rotate_each

# A bone whose Y axis lies farther than this from every child's head does not run along its limb.
_OFF_LIMB_DEG = 30.0


def _units(v):
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def aims(heads, tails, parents, rest) -> tuple[np.ndarray, np.ndarray] | None:
    """(bones, 3) where each bone points in its own rest frame, and (bones,) how far its aimed point lies
    from its head (the child's head; a bone left along Y or a leaf: its length), or None where every bone's
    Y axis runs along its limb. heads, tails (bones, 3) rest positions; parents (bones,) indices, -1 for roots,
    parents before children; rest (bones, 4) rest orientations (w x y z).

    A bone points at the head of the child that continues it (its parent's line carried on most
    straightly; for a root, the child with the most bones below). A bone whose Y axis lies more than 30
    degrees from every child's head is given that aim; on a rig where most bones are so, every bone is, and
    a leaf whose Y axis turns more than 45 degrees off its parent's line points on along that line.
    """
    heads, tails = np.asarray(heads, dtype=np.float64), np.asarray(tails, dtype=np.float64)
    parents = np.asarray(parents, dtype=np.int64)
    count = len(heads)
    if not count:
        return None
    size = max(float(np.ptp(np.vstack([heads, tails]), axis=0).max()), 1e-12)
    reach = np.linalg.norm(tails - heads, axis=1)
    axes = _units(tails - heads)
    child = np.flatnonzero(parents >= 0)
    parent = parents[child]
    offset = heads[child] - heads[parent]
    distance = np.linalg.norm(offset, axis=1)
    apart = distance > 1e-4 * size  # a child whose head sits on its parent's says nothing of its direction
    child, parent, offset, distance = child[apart], parent[apart], offset[apart], distance[apart]
    along = np.einsum("ij,ij->i", axes[parent], offset / distance[:, None])
    best = np.full(count, -np.inf)
    np.maximum.at(best, parent, along)
    has_children = np.isfinite(best)
    off = has_children & (best < np.cos(np.radians(_OFF_LIMB_DEG)))
    if not off.any():
        return None
    every = off.sum() >= 0.5 * has_children.sum()
    chosen = np.ones(count, dtype=bool) if every else off
    below = np.zeros(count, dtype=np.int64)
    for i in range(count - 1, -1, -1):  # parents come before children
        if parents[i] >= 0:
            below[parents[i]] += 1 + below[i]
    incoming = _units(heads - heads[np.maximum(parents, 0)])
    valid = (parents >= 0) & (np.linalg.norm(heads - heads[np.maximum(parents, 0)], axis=1) > 0)
    # The continuing child: straightest on from the parent's own line, or for a root the biggest subtree.
    score = np.where(valid[parent], np.einsum("ij,ij->i", offset / distance[:, None], incoming[parent]),
                     below[child].astype(np.float64))
    order = np.lexsort((-child, score, parent))  # equal scores: the first child wins
    last = np.r_[parent[order][1:] != parent[order][:-1], True]
    picked = order[last]  # one edge per parent with children: its best child
    directions = np.full((count, 3), np.nan)
    directions[parent[picked]] = offset[picked]
    reach_of = reach.copy()
    reach_of[parent[picked]] = distance[picked]
    leaves = chosen & ~has_children & valid & (np.einsum("ij,ij->i", axes, incoming) < np.cos(np.radians(45.0)))
    directions[leaves] = incoming[leaves]
    aimed = chosen & np.isfinite(directions).all(axis=1)
    out = np.tile([0.0, 1.0, 0.0], (count, 1))
    out[aimed] = rotate_each(conjugate(np.asarray(rest, dtype=np.float64)[aimed]), _units(directions[aimed]))
    reach = np.where(aimed & has_children, reach_of, reach)
    return out, reach
