"""The measure of retargeting against Mixamo's own retargets (the SAN protocol of Aberman et al. 2020,
*Skeleton-Aware Networks for Deep Motion Retargeting*), independent of MotionKit: numpy only (Blender's
Python has no scipy), so that tests and benches in Blender and on the host hold MotionKit to it.

- A tiny BVH reader and forward kinematics (rotation matrices, channels composed in file order:
  R_j = R_c1 R_c2 R_c3; world W_j = W_p R_j, p_j = p_p + W_p t_j, t_j the OFFSET with any position
  channels replacing it).
- The 22 main body joints (BODY_JOINTS) and, for a skeleton with names of its own, a fixed
  correspondence (GIRL2_JOINTS): that dict is the measurement's definition for that character.
- The character's height as SAN's code computes it (`BVH_file.get_height` in
  `retargeting/datasets/bvh_parser.py` of DeepMotionEditing/deep-motion-editing): the lengths of the rest
  offsets summed from the left toe (LeftToeBase) up to the root and from the head (Head) up to the root.
  Mixamo's BVH files with a `Pelvis` under `Hips` are re-rooted at the pelvis there, which leaves the same
  sum: the rest-offset path length between the left toe and the head through the tree (height()).
- The measures (errors()): the mean distance between the retarget's joints and the target's own clip's,
  frame by frame, in % of the target's height, over the 22 joints ("all"); the same with each frame's
  joints taken relative to its hips ("pose": the pose alone; the hips' own term is zero and counted, so
  the mean is over the same 22 joints); and SAN's figure, the mean over joints, frames and the three
  coordinates of the squared difference over the height squared, x1000 ("san_mse").
- The baseline (plain_copy()): each joint's local BVH rotation copied by name onto the target's offsets,
  the target's joints without a namesake at their rest rotation, the root's translation multiplied by the
  ratio of the hip heights (rest hips above the lowest rest joint).
"""
from __future__ import annotations

import numpy as np

SIDES = ("Left", "Right")
BODY_JOINTS = (("Hips", "Spine", "Spine1", "Spine2", "Neck", "Head")
               + tuple(side + part for side in SIDES for part in ("Shoulder", "Arm", "ForeArm", "Hand"))
               + tuple(side + part for side in SIDES for part in ("UpLeg", "Leg", "Foot", "ToeBase")))
TOE, HEAD, HIPS = "LeftToeBase", "Head", "Hips"

# girl2 (Mixamo's auto-rig with a 142-bone skeleton of its own): its body joints by the Mixamo names they
# stand for. It has two spine bones where Mixamo has three: its Chest carries the arms and neck as Spine2
# does, and Mixamo's Spine1 has no counterpart (so 21 joints are measured on it).
GIRL2_JOINTS = {
    "Hips": "Hips", "Spine": "Spine", "Spine2": "Chest", "Neck": "Neck", "Head": "Head",
    **{f"{s}{part}": f"{s} {theirs}" for s in SIDES for part, theirs in (
        ("Shoulder", "shoulder"), ("Arm", "arm"), ("ForeArm", "elbow"), ("Hand", "wrist"),
        ("UpLeg", "leg"), ("Leg", "knee"), ("Foot", "ankle"), ("ToeBase", "toe"))},
}


class Bvh:
    """A BVH file's hierarchy (names, parents, offsets (J, 3), channels per joint, each joint's first
    column) and motion (values (frames, columns), frame_time). End sites are left out."""

    def __init__(self, names, parents, offsets, channels, values, frame_time):
        self.names, self.parents, self.channels = list(names), list(parents), list(channels)
        self.offsets = np.asarray(offsets, dtype=np.float64)
        self.first = np.cumsum([0] + [len(c) for c in self.channels[:-1]]).tolist()
        self.values, self.frame_time = np.asarray(values, dtype=np.float64), float(frame_time)

    def index(self, name: str) -> int:
        return self.names.index(name)


def read_bvh(path: str) -> Bvh:
    with open(path) as handle:
        tokens = handle.read().split()
    names, parents, offsets, channels, stack, end_site = [], [], [], [], [], False
    i = 0
    while tokens[i] != "MOTION":
        word = tokens[i]
        if word in ("ROOT", "JOINT"):
            names.append(tokens[i + 1])
            parents.append(stack[-1] if stack else -1)
            channels.append([])
            offsets.append(None)
            i += 2
        elif word == "End":
            end_site = True
            i += 2
        elif word == "{":
            stack.append(-2 if end_site else len(names) - 1)
            end_site = False
            i += 1
        elif word == "}":
            stack.pop()
            i += 1
        elif word == "OFFSET":
            if stack[-1] != -2:
                offsets[-1] = [float(v) for v in tokens[i + 1:i + 4]]
            i += 4
        elif word == "CHANNELS":
            count = int(tokens[i + 1])
            channels[-1] = tokens[i + 2:i + 2 + count]
            i += 2 + count
        else:
            i += 1
    frames, frame_time = int(tokens[i + 2]), float(tokens[i + 5])
    columns = sum(len(c) for c in channels)
    values = np.array(tokens[i + 6:i + 6 + frames * columns], dtype=np.float64).reshape(frames, columns)
    return Bvh(names, parents, offsets, channels, values, frame_time)


def axis_rotations(axis: str, degrees) -> np.ndarray:
    """(n, 3, 3) right-handed rotations about x, y or z by the angles (degrees)."""
    a = np.radians(np.asarray(degrees, dtype=np.float64))
    c, s = np.cos(a), np.sin(a)
    out = np.zeros(a.shape + (3, 3))
    i, j = {"X": (1, 2), "Y": (2, 0), "Z": (0, 1)}[axis]
    k = 3 - i - j
    out[..., k, k] = 1.0
    out[..., i, i], out[..., i, j], out[..., j, i], out[..., j, j] = c, -s, s, c
    return out


def local_rotations(bvh: Bvh) -> np.ndarray:
    """(frames, joints, 3, 3): each joint's rotation channels composed in file order."""
    frames = bvh.values.shape[0]
    out = np.tile(np.eye(3), (frames, len(bvh.names), 1, 1))
    for j, chans in enumerate(bvh.channels):
        for k, channel in enumerate(chans):
            if channel.endswith("rotation"):
                out[:, j] = out[:, j] @ axis_rotations(channel[0], bvh.values[:, bvh.first[j] + k])
    return out


def root_positions(bvh: Bvh) -> np.ndarray:
    """(frames, 3): the root's offset with its position channels in place."""
    out = np.tile(bvh.offsets[0], (bvh.values.shape[0], 1))
    for k, channel in enumerate(bvh.channels[0]):
        if channel.endswith("position"):
            out[:, "XYZ".index(channel[0])] = bvh.values[:, bvh.first[0] + k]
    return out


def forward_kinematics(parents, offsets, rotations, root) -> np.ndarray:
    """World positions (frames, joints, 3) from local rotations (frames, joints, 3, 3), the rest offsets
    and the root's path (frames, 3); parents come before their children."""
    frames, joints = rotations.shape[:2]
    world = np.empty_like(rotations)
    positions = np.empty((frames, joints, 3))
    for j, parent in enumerate(parents):
        if parent < 0:
            world[:, j], positions[:, j] = rotations[:, j], root
        else:
            world[:, j] = world[:, parent] @ rotations[:, j]
            positions[:, j] = positions[:, parent] + world[:, parent] @ offsets[j]
    return positions


def clip_positions(bvh: Bvh) -> np.ndarray:
    """The clip's joints in the file's space and units, (frames, joints, 3)."""
    return forward_kinematics(bvh.parents, bvh.offsets, local_rotations(bvh), root_positions(bvh))


def rest_positions(parents, offsets) -> np.ndarray:
    out = np.zeros((len(parents), 3))
    for j, parent in enumerate(parents):
        out[j] = offsets[j] if parent < 0 else out[parent] + offsets[j]
    return out


def height(names, parents, offsets, toe: str = TOE, head: str = HEAD) -> float:
    """SAN's height: the rest offsets' lengths summed along the tree from the toe and from the head up to
    the joint where the two paths meet (the root on Mixamo's skeletons)."""
    def chain(j):
        out = []
        while j >= 0:
            out.append(j)
            j = parents[j]
        return out
    up_toe, up_head = chain(names.index(toe)), chain(names.index(head))
    meet = next(j for j in up_toe if j in up_head)
    path = up_toe[:up_toe.index(meet)] + up_head[:up_head.index(meet)]
    return float(sum(np.linalg.norm(offsets[j]) for j in path))


def hip_height(parents, offsets, hips: int = 0, up: int = 1) -> float:
    """The rest hips' height above the lowest rest joint, along the up axis."""
    rest = rest_positions(parents, offsets)
    return float(rest[hips, up] - rest[:, up].min())


def body_indices(names, joints=BODY_JOINTS, correspondence=None) -> list[int]:
    """Indices into names of the body joints (through correspondence, Mixamo name -> own name, when
    given; joints without a counterpart are left out)."""
    if correspondence is None:
        return [names.index(j) for j in joints]
    return [names.index(correspondence[j]) for j in joints if j in correspondence]


def errors(predicted, reference, size: float, hips: int = 0) -> dict[str, float]:
    """The protocol's measures of predicted against reference joints (frames, joints, 3), the joints
    already chosen (hips: the hips' column among them), size the target's height in the same units."""
    predicted, reference = np.asarray(predicted, np.float64), np.asarray(reference, np.float64)
    if predicted.shape != reference.shape:
        raise ValueError(f"joints {predicted.shape} against reference {reference.shape}")
    diff = predicted - reference
    pose = diff - diff[:, hips:hips + 1]
    return {"all": 100.0 * float(np.linalg.norm(diff, axis=-1).mean()) / size,
            "pose": 100.0 * float(np.linalg.norm(pose, axis=-1).mean()) / size,
            "san_mse": 1000.0 * float(np.mean(diff ** 2)) / size ** 2}


def joint_pose_errors(predicted, reference, size: float, hips: int = 0) -> np.ndarray:
    """Per joint (joints,): the pose-alone distance (relative to the hips), mean over frames, in % of size."""
    diff = np.asarray(predicted, np.float64) - np.asarray(reference, np.float64)
    return 100.0 * np.linalg.norm(diff - diff[:, hips:hips + 1], axis=-1).mean(axis=0) / size


def plain_copy(source: Bvh, target: Bvh) -> np.ndarray:
    """The baseline: target's joints (frames, joints, 3) with each joint's local rotation taken from the
    source's joint of the same name (rest rotation where none), the root's path times the hip heights'
    ratio."""
    rotations = local_rotations(source)
    frames = rotations.shape[0]
    out = np.tile(np.eye(3), (frames, len(target.names), 1, 1))
    for j, name in enumerate(target.names):
        if name in source.names:
            out[:, j] = rotations[:, source.index(name)]
    ratio = hip_height(target.parents, target.offsets) / hip_height(source.parents, source.offsets)
    return forward_kinematics(target.parents, target.offsets, out, root_positions(source) * ratio)
