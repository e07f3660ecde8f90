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

from .rotation_channels import conjugate, rotate

# A bone whose Y axis lies farther than this from every child's head does not run along its limb.
_OFF_LIMB_DEG = 30.0


def _unit(v):
    return v / np.linalg.norm(v)


def aims(heads, tails, parents, rest) -> tuple[np.ndarray, np.ndarray] | None:
    """(bones, 3) where each bone points in its own rest frame, and (bones,) how far its aimed point lies
    from its head (the child's head; a bone left along Y or a leaf: its length), or None where every bone's
    Y axis runs along its limb. heads, tails (bones, 3) rest positions; parents (bones,) indices, -1 for roots, parents
    before children; rest (bones, 4) rest orientations (w x y z).

    A bone points at the head of the child that continues it (its parent's line carried on most
    straightly; for a root, the child with the most bones below). A bone whose Y axis lies more than 30
    degrees from every child's head is given that aim; on a rig where most bones are so, every bone is, and
    a leaf whose Y axis turns more than 45 degrees off its parent's line points on along that line.
    """
    heads, tails = np.asarray(heads, dtype=np.float64), np.asarray(tails, dtype=np.float64)
    count = len(heads)
    size = max(float(np.ptp(np.vstack([heads, tails]), axis=0).max()), 1e-12) if count else 1.0
    children = [[] for _ in range(count)]
    below = [0] * count
    for i in reversed(range(count)):
        if parents[i] >= 0:
            below[parents[i]] += 1 + below[i]
            if np.linalg.norm(heads[i] - heads[parents[i]]) > 1e-4 * size:
                children[parents[i]].append(i)
    off = [bool(kids) and max(float(_unit(tails[i] - heads[i]) @ _unit(heads[c] - heads[i])) for c in kids)
           < np.cos(np.radians(_OFF_LIMB_DEG)) for i, kids in enumerate(children)]
    if not any(off):
        return None
    every = sum(off) >= 0.5 * sum(bool(kids) for kids in children)
    out = np.tile([0.0, 1.0, 0.0], (count, 1))
    reach = np.linalg.norm(tails - heads, axis=1)
    for i in range(count):
        if not (off[i] or every):
            continue
        p = parents[i]
        incoming = _unit(heads[i] - heads[p]) if p >= 0 and np.linalg.norm(heads[i] - heads[p]) > 0 else None
        if children[i]:
            pick = max(children[i], key=lambda c: float(_unit(heads[c] - heads[i]) @ incoming)
                       if incoming is not None else below[c])
            direction = heads[pick] - heads[i]
            reach[i] = np.linalg.norm(direction)
        elif incoming is not None and float(_unit(tails[i] - heads[i]) @ incoming) < np.cos(np.radians(45.0)):
            direction = incoming  # a leaf whose tail turns far off its parent's line points nowhere known
        else:
            continue
        out[i] = rotate(conjugate(np.asarray(rest[i], dtype=np.float64)), _unit(direction))
    return out, reach
