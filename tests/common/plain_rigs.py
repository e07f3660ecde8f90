"""Rigs as plain data (core.rig_data.RigData) for the tests that run without Blender: the sample
characters' bones (blend_samples/characters.py) with their rest orientations made the way Blender makes an
edit bone's (the shortest turn of +Y onto the bone, then its roll about it), written with scipy."""
import numpy as np
from scipy.spatial.transform import Rotation

import characters
from core.rig_data import RigData


def bone_rest(head, tail, roll: float) -> np.ndarray:
    """An edit bone's rest orientation (w x y z): +Y turned the shortest way onto tail - head, then rolled."""
    axis = np.asarray(tail, dtype=np.float64) - np.asarray(head, dtype=np.float64)
    axis /= np.linalg.norm(axis)
    y = np.array([0.0, 1.0, 0.0])
    turn_axis = np.cross(y, axis)
    sin, cos = np.linalg.norm(turn_axis), float(y @ axis)
    turn = Rotation.from_rotvec(np.zeros(3) if sin < 1e-12 and cos > 0 else
                                (np.pi * np.array([0.0, 0.0, 1.0]) if sin < 1e-12 else
                                 turn_axis / sin * np.arctan2(sin, cos)))
    q = (turn * Rotation.from_rotvec([0.0, roll, 0.0])).as_quat()
    return np.roll(q, 1)


def from_spec(spec: characters.CharacterSpec, world: np.ndarray | None = None, floor=None) -> RigData:
    """The character as RigData, placed by world (4, 4; default identity)."""
    bones = list(spec.bones)
    index = {b.name: i for i, b in enumerate(bones)}
    heads = np.array([b.head for b in bones], dtype=np.float64)
    tails = np.array([b.tail for b in bones], dtype=np.float64)
    parents = [index[b.parent] if b.parent else -1 for b in bones]
    connected = [p >= 0 and np.allclose(heads[i], tails[p]) for i, p in enumerate(parents)]
    world = np.eye(4) if world is None else np.asarray(world, dtype=np.float64)
    scale = np.linalg.norm(world[:3, :3], axis=0)
    rotation = np.roll(Rotation.from_matrix(world[:3, :3] / scale).as_quat(), 1)
    return RigData(spec.name, tuple(index), tuple(parents), np.array([bone_rest(b.head, b.tail, b.roll)
                                                                     for b in bones]),
                   heads, tails, np.linalg.norm(tails - heads, axis=1), tuple(connected), world, rotation, scale,
                   floor)


def placed(rotation: Rotation, scale: float = 1.0, offset=(0.0, 0.0, 0.0)) -> np.ndarray:
    """A world matrix: turned, uniformly scaled, moved."""
    world = np.eye(4)
    world[:3, :3] = rotation.as_matrix() * scale
    world[:3, 3] = offset
    return world
