"""Characters the tests make from Mixamo's own (san_protocol.Bvh, numpy only, no MotionKit code): a helper
joint moved along or off its limb's line, or taken out, and a clip cut to a run of frames, written back as BVH
files for Blender's importer. Each keeps the clip a true answer for the character it makes: a joint that the
clip never turns (Mixamo's `*_split` joints) is moved with its child's offset made up, so that every other
joint stays where the clip puts it, or taken out with its offset handed to its children."""
from __future__ import annotations

import numpy as np

import san_protocol as sp

# A joint the clip leaves unturned turns by less than this on every frame (degrees: Mixamo writes its
# `*_split` joints' zeros as values under 1e-5).
UNTURNED_DEG = 1e-3


def children(bvh: sp.Bvh, joint: int) -> list[int]:
    """The joints that hang from joint (indices)."""
    return [j for j, p in enumerate(bvh.parents) if p == joint]


def _unturned(bvh: sp.Bvh, joint: int) -> None:
    rotations = [k for k, c in enumerate(bvh.channels[joint]) if c.endswith("rotation")]
    turned = np.abs(bvh.values[:, [bvh.first[joint] + k for k in rotations]]).max(initial=0.0)
    if turned > UNTURNED_DEG:
        raise ValueError(f"{bvh.names[joint]} turns by up to {turned:.3g} degrees: moving it changes the clip")


def with_joint_moved(bvh: sp.Bvh, name: str, offset) -> sp.Bvh:
    """bvh with the unturned joint `name` at `offset` from its parent (its one child's offset made up, so that
    the child stays where it stood on every frame)."""
    joint = bvh.index(name)
    _unturned(bvh, joint)
    (child,) = children(bvh, joint)
    offsets = bvh.offsets.copy()
    offsets[child] += offsets[joint] - np.asarray(offset, dtype=np.float64)
    offsets[joint] = offset
    return sp.Bvh(bvh.names, bvh.parents, offsets, bvh.channels, bvh.values, bvh.frame_time)


def without_joint(bvh: sp.Bvh, name: str) -> sp.Bvh:
    """bvh with the unturned joint `name` taken out, its children hung from its parent."""
    joint = bvh.index(name)
    _unturned(bvh, joint)
    keep = [j for j in range(len(bvh.names)) if j != joint]
    new_index = {old: new for new, old in enumerate(keep)}
    offsets = bvh.offsets.copy()
    parents = []
    for j in keep:
        parent = bvh.parents[j]
        if parent == joint:
            offsets[j] += offsets[joint]
            parent = bvh.parents[joint]
        parents.append(new_index.get(parent, -1))
    columns = [c for j in keep for c in range(bvh.first[j], bvh.first[j] + len(bvh.channels[j]))]
    return sp.Bvh([bvh.names[j] for j in keep], parents, offsets[keep], [bvh.channels[j] for j in keep],
                  bvh.values[:, columns], bvh.frame_time)


def frames(bvh: sp.Bvh, start: int, count: int) -> sp.Bvh:
    """count of bvh's frames from start (0-based)."""
    return sp.Bvh(bvh.names, bvh.parents, bvh.offsets, bvh.channels, bvh.values[start:start + count],
                  bvh.frame_time)


def write_bvh(bvh: sp.Bvh, path: str) -> None:
    """bvh as a BVH file (joints in bvh's order, which lists parents first; a leaf ends in a zero end site)."""
    lines = ["HIERARCHY"]

    def joint(j: int, depth: int) -> None:
        pad = "\t" * depth
        lines.append(f"{pad}{'ROOT' if bvh.parents[j] < 0 else 'JOINT'} {bvh.names[j]}")
        lines.append(pad + "{")
        lines.append(f"{pad}\tOFFSET " + " ".join(f"{v:.6f}" for v in bvh.offsets[j]))
        lines.append(f"{pad}\tCHANNELS {len(bvh.channels[j])} " + " ".join(bvh.channels[j]))
        below = children(bvh, j)
        for child in below:
            joint(child, depth + 1)
        if not below:
            lines.extend([f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET 0.000000 0.000000 0.000000",
                          f"{pad}\t}}"])
        lines.append(pad + "}")

    for root in (j for j, p in enumerate(bvh.parents) if p < 0):
        joint(root, 0)
    lines += ["MOTION", f"Frames: {len(bvh.values)}", f"Frame Time: {bvh.frame_time:.6f}"]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in bvh.values]
    with open(path, "w") as handle:
        handle.write("\n".join(lines) + "\n")
