"""Where a mapped bone points, measured the way the retarget promises to match it, by Blender's evaluation.

A bone points at the child that continues it. Where the source bone's tail sits on the head of a child
that is mapped to a child of the target bone, the pair is measured head to head towards those two
children (a BVH import's hips whose tail runs to a thigh against a rig's hips whose tail runs up the
spine); otherwise by the bones' Y axes (leaves, and bones whose tails end on no mapped child).
"""
import bpy
import numpy as np

# The retarget's chain modes that point every chain where the source's points (core/reference_pose.CHAINS,
# spelled out here): what the exactness tests hold the retarget to; by default a target keeps its posture.
MATCH_EVERY_CHAIN = {chain: "MATCH" for chain in ("trunk", "arm.L", "arm.R", "leg.L", "leg.R", "fingers.L",
                                                  "fingers.R")}


def pointing_ends(source, target, pairs, parents=None):
    """[(source child, target child) or None] for each (source bone, target bone) pair. parents: target
    bone -> parent where a control rig's map parents its deform bones otherwise than the armature does."""
    to_target = dict(pairs)
    below = {}
    for bone in target.data.bones:
        parent = (parents or {}).get(bone.name, bone.parent.name if bone.parent else None)
        below.setdefault(parent, set()).add(bone.name)
    ends = []
    for a, t in pairs:
        bone = source.data.bones[a]
        at_tail = [c for c in bone.children if (c.head_local - bone.tail_local).length < 1e-4 * bone.length]
        end = next(((c.name, to_target[c.name]) for c in at_tail if to_target.get(c.name) in below.get(t, ())), None)
        ends.append(end)
    return ends


def pointing_directions(obj, names, ends, frames):
    """World directions (frames, bones, 3): from each named bone's head to its end's head, or its Y axis."""
    out = np.empty((len(frames), len(names), 3))
    for i, frame in enumerate(frames):
        bpy.context.scene.frame_set(int(frame))
        world = obj.matrix_world
        for j, (name, end) in enumerate(zip(names, ends)):
            bone = obj.pose.bones[name]
            if end is None:
                v = world.to_3x3() @ bone.matrix.to_3x3().col[1]
            else:
                v = world @ obj.pose.bones[end].head - world @ bone.head
            out[i, j] = tuple(v.normalized())
    return out


def pointing_pairs(source, target, pairs, frames, parents=None):
    """(source, target) world directions (frames, pairs, 3) of each mapped pair, measured alike."""
    ends = pointing_ends(source, target, pairs, parents)
    return (pointing_directions(source, [a for a, _ in pairs], [e and e[0] for e in ends], frames),
            pointing_directions(target, [t for _, t in pairs], [e and e[1] for e in ends], frames))
