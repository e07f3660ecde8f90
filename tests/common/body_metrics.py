"""How a retargeted clip sits in its character's body, measured on Blender's evaluated meshes and written
apart from MotionKit's body code (no core.body): the share of forearm and hand vertices inside the closed
body (the trunk, head and thighs: the generalised winding number of its triangles, tests/common/bodies.py),
how deep the deepest goes (Blender's BVHTree.find_nearest), and how far each hand is from the body (0
inside). Parts come from the files' own vertex labels (vertex_part), not from a bone map."""
from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np
from mathutils import Vector
from mathutils.bvhtree import BVHTree

import bodies
import body_scene
import san_protocol as sp

BODY = ("Hips", "Spine", "Spine1", "Spine2", "Neck", "Head", "LeftUpLeg", "RightUpLeg")
ARMS = ("LeftForeArm", "LeftHand", "RightForeArm", "RightHand")
HANDS = ("LeftHand", "RightHand")
DEEP = 0.01     # a frame with any arm vertex deeper than this inside (m) counts as one that goes in
CONTACT = 0.02  # the source's hand this near its own body (m) touches it (the protocol's 2 cm)


@dataclass
class Skinned:
    """A character's evaluated mesh and what its vertices are: obj, part (V,) joint names, body triangles
    (T, 3), arm vertices (A,) and, per hand, its vertices."""
    obj: bpy.types.Object
    part: np.ndarray
    body_triangles: np.ndarray
    arms: np.ndarray
    hands: tuple

    @classmethod
    def of(cls, armature, shared: str, character: str) -> "Skinned":
        obj = body_scene.skin(armature, shared, character)
        data = np.load(bodies.mesh_path(shared, character))
        part = np.array([str(n) for n in data["joint_names"]])[data["vertex_part"]]
        on_body = np.isin(part, BODY)
        triangles = np.asarray(data["rest_faces"], dtype=np.int64)
        return cls(obj, part, triangles[on_body[triangles].all(axis=1)], np.flatnonzero(np.isin(part, ARMS)),
                   tuple(np.flatnonzero(part == h) for h in HANDS))


@dataclass
class Frames:
    """Per measured frame: inside (frames,) the share of arm vertices inside the body, deepest (frames,)
    the deepest one's depth (m, 0 for none), hand (frames, 2) each hand's distance to the body (m)."""
    inside: np.ndarray
    deepest: np.ndarray
    hand: np.ndarray


def measure(skinned: Skinned, frames) -> Frames:
    inside, deepest, hand = [], [], []
    for frame in frames:
        world = body_scene.evaluated_vertices(skinned.obj, int(frame))
        one = _frame(skinned, world)
        inside.append(one[0])
        deepest.append(one[1])
        hand.append(one[2])
    return Frames(np.array(inside), np.array(deepest), np.array(hand))


def _frame(skinned: Skinned, world) -> tuple:
    tree = BVHTree.FromPolygons([Vector(v) for v in world], skinned.body_triangles.tolist())
    arms = world[skinned.arms]
    # Only an arm vertex within the body's box can be inside it.
    body_points = world[np.unique(skinned.body_triangles)]
    low, high = body_points.min(axis=0), body_points.max(axis=0)
    near = np.all((arms >= low) & (arms <= high), axis=1)
    inside = np.zeros(len(arms), dtype=bool)
    if near.any():
        inside[near] = bodies.winding_numbers(arms[near], world, skinned.body_triangles) > 0.5
    depth = max((tree.find_nearest(Vector(p))[3] for p in arms[inside]), default=0.0)
    where = {int(v): k for k, v in enumerate(skinned.arms)}
    hands = []
    for vertices in skinned.hands:
        rows = [where[int(v)] for v in vertices]
        if inside[rows].any():
            hands.append(0.0)
        else:
            hands.append(min(tree.find_nearest(Vector(p))[3] for p in arms[rows]))
    return float(inside.mean()), float(depth), hands


def contact_frames(source: Frames) -> np.ndarray:
    """(frames, 2) where the source's hand touches its own body (within CONTACT, or inside)."""
    return source.hand <= CONTACT


def summary(measured: Frames, height: float, contacts: np.ndarray) -> dict:
    """The protocol's row for one clip: mean share inside (%), frames with any deeper than DEEP (%), and on
    the source's contact frames the hand's distance to the body (mean, worst; % of height), None without."""
    on = measured.hand[contacts]
    return {"inside": 100.0 * float(measured.inside.mean()),
            "deep_frames": 100.0 * float(np.mean(measured.deepest > DEEP)),
            "contact_mean": 100.0 * float(on.mean()) / height if on.size else None,
            "contact_worst": 100.0 * float(on.max()) / height if on.size else None,
            "contact_count": int(on.size)}


def plain_copy(source: sp.Bvh, target: sp.Bvh) -> sp.Bvh:
    """The target's hierarchy playing the source's local rotations joint by joint (by name less any prefix;
    a joint the source lacks at its rest), its root's path scaled by the hips' heights: the plain rotation
    copy as a file Blender's importer can read."""
    base = lambda n: n.split(":")[-1]  # noqa: E731
    source_of = {base(n): j for j, n in enumerate(source.names)}
    values = np.zeros((len(source.values), target.values.shape[1]))
    for j, name in enumerate(target.names):
        s = source_of.get(base(name))
        for k, channel in enumerate(target.channels[j]):
            if s is None or not channel.endswith("rotation"):
                continue
            if channel not in source.channels[s]:
                raise ValueError(f"{name}: channel {channel} has no match in the source")
            values[:, target.first[j] + k] = source.values[:, source.first[s] + source.channels[s].index(channel)]
    ratio = sp.hip_height(target.parents, target.offsets) / sp.hip_height(source.parents, source.offsets)
    root = sp.root_positions(source) * ratio
    for k, channel in enumerate(target.channels[0]):
        if channel.endswith("position"):
            values[:, target.first[0] + k] = root[:, "XYZ".index(channel[0])]
    return sp.Bvh(target.names, target.parents, target.offsets, target.channels, values, source.frame_time)
