"""Forward kinematics of a BVH clip in plain numpy (Blender's Python has no scipy): the reference the BVH
tests hold imports and pose conversions to. Quaternions are w x y z.

    Q_i = Q_p(i) R_i,   p_i = p_p(i) + Q_p(i) t_i

R_i composes the joint's rotation channels in file order; t_i is its OFFSET with any position channels
replacing components. End sites are joints like any other."""
import numpy as np


def multiply(a, b):
    """Quaternion products a b, (..., 4) each."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def rotate(q, v):
    """Vectors v (..., 3) turned by unit quaternions q (..., 4)."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def local_motion(skeleton, values, j):
    """Joint j's R_j (frames, 4) and t_j (frames, 3) from its channels."""
    frames = values.shape[0]
    rotation = np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1))
    translation = np.tile(np.asarray(skeleton.offsets[j], dtype=np.float64), (frames, 1))
    for k, channel in enumerate(skeleton.channels[j]):
        column = values[:, skeleton.first_channels[j] + k]
        axis = "XYZ".index(channel[0])
        if channel.endswith("position"):
            translation[:, axis] = column
            continue
        half = np.radians(column) / 2.0
        turn = np.zeros((frames, 4))
        turn[:, 0], turn[:, 1 + axis] = np.cos(half), np.sin(half)
        rotation = multiply(rotation, turn)
    return rotation, translation


def forward_kinematics(skeleton, values):
    """World positions (frames, joints, 3) and orientations (frames, joints, 4) of every joint."""
    values = np.asarray(values, dtype=np.float64)
    frames, joints = values.shape[0], len(skeleton)
    positions, orientations = np.zeros((frames, joints, 3)), np.zeros((frames, joints, 4))
    for j, parent in enumerate(skeleton.parents):
        rotation, translation = local_motion(skeleton, values, j)
        if parent < 0:
            orientations[:, j], positions[:, j] = rotation, translation
        else:
            orientations[:, j] = multiply(orientations[:, parent], rotation)
            positions[:, j] = positions[:, parent] + rotate(orientations[:, parent], translation)
    return positions, orientations
