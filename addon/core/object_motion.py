"""An armature object's own motion, in numpy (no bpy).

Some FBX, glTF and capture exports move the armature object (or its parent) and leave the root bone in
place. A retarget reads motion in armature space, so the object's motion relative to a reference placement
is composed into the top bones' channels: the rig then walks in armature space as one whose root bone
carries the motion would, and its world pose is the same. The other way round, a ground track (the hips'
path and heading) becomes the target object's keys (root_motion_onto="object").

Matrices are (4, 4) or (n, 4, 4) as Blender's; quaternions w x y z; an object's basis is
translation @ rotation @ scale, as Blender composes matrix_basis.
"""
from __future__ import annotations

import numpy as np

from .rotation_channels import conjugate, multiply, rotate_each

# A relative scale further than this from 1 (float32 matrices: a few 1e-7) is a real change of size, which no
# bone's rotation and location can carry.
_SCALE_TOLERANCE = 1e-5

GROUP = "Object Transforms"  # the group Blender keys an object's transform in


def rotation_matrices(q) -> np.ndarray:
    """(n, 3, 3) rotation matrices of quaternions (n, 4) (normalised here)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def quaternions(m) -> np.ndarray:
    """(n, 4) unit quaternions, w >= 0, of rotation matrices (n, 3, 3) (Shepperd's method: each row from the
    largest of 4w², 4x², 4y², 4z², so that none loses precision)."""
    m = np.asarray(m, dtype=np.float64)
    trace = np.trace(m, axis1=-2, axis2=-1)
    diagonal = np.stack([trace, *(2.0 * m[..., k, k] - trace for k in range(3))], -1)
    pick = np.argmax(diagonal, axis=-1)
    big = 1.0 + np.take_along_axis(diagonal, pick[..., None], -1)[..., 0]
    wx, wy, wz = m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]
    xy, xz, yz = m[..., 0, 1] + m[..., 1, 0], m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1]
    # Each row is 4 * (the picked component) times the quaternion: normalising gives it.
    cases = [(big, wx, wy, wz), (wx, big, xy, xz), (wy, xy, big, yz), (wz, xz, yz, big)]
    q = np.empty(m.shape[:-2] + (4,))
    for k, case in enumerate(cases):
        where = pick == k
        q[where] = np.stack([c[where] for c in case], -1)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return q * np.where(q[..., :1] < 0.0, -1.0, 1.0)


def basis_matrices(locations, rotations, scales) -> np.ndarray:
    """(n, 4, 4) matrix_basis of an object: locations (n, 3), rotations (n, 4) quaternions, scales (n, 3)."""
    locations = np.asarray(locations, dtype=np.float64)
    out = np.zeros(locations.shape[:-1] + (4, 4))
    out[..., :3, :3] = rotation_matrices(rotations) * np.asarray(scales, dtype=np.float64)[..., None, :]
    out[..., :3, 3] = locations
    out[..., 3, 3] = 1.0
    return out


def relative_motion(worlds, reference, what: str, frames) -> tuple[np.ndarray, np.ndarray]:
    """The motion (rotations (n, 4), translations (n, 3)) that takes the object from its reference placement
    (4, 4) to worlds (n, 4, 4), in its own (armature) space: reference^-1 @ worlds. A change of size is a
    ValueError naming what moves and the frame (frames[row]): bones carry rotation and location only."""
    relative = np.linalg.solve(np.asarray(reference, dtype=np.float64), np.asarray(worlds, dtype=np.float64))
    turn = relative[:, :3, :3]
    sizes = np.linalg.norm(turn, axis=1)  # column lengths: the relative scale per axis
    bad = np.flatnonzero(np.abs(sizes - 1.0).max(axis=1) > _SCALE_TOLERANCE)
    if bad.size:
        row = bad[0]
        raise ValueError(f"{what} changes its scale over the clip (x{tuple(round(float(s), 6) for s in sizes[row])} "
                         f"of its first frame's at frame {frames[row]:g}): only its location and rotation can be "
                         f"carried into the bones; bake or remove its scale keys")
    return quaternions(turn / sizes[:, None, :]), relative[:, :3, 3].copy()


def compose_tops(rest, heads, parents, basis, locations, rotations, translations) -> tuple[np.ndarray, np.ndarray]:
    """The top bones' pose channels with the motion (rotations (n, 4), translations (n, 3), armature space)
    composed in front of their pose, so that every bone's armature-space pose p becomes motion @ p.

    rest (B, 4) unit rest orientations, heads (B, 3) rest heads, parents (B,) (-1 for a top bone); basis
    (n, 4B) basis quaternions and locations (n, 3B) location channels. A top bone's pose is
    [rest @ basis, head + rest * location]; returns new copies of basis and locations."""
    basis, locations = np.array(basis, dtype=np.float64), np.array(locations, dtype=np.float64)
    for b in [i for i, p in enumerate(parents) if p < 0]:
        r = np.broadcast_to(np.asarray(rest[b], dtype=np.float64), rotations.shape)
        inverse = conjugate(r)
        basis[:, 4 * b:4 * b + 4] = multiply(multiply(inverse, rotations), multiply(r, basis[:, 4 * b:4 * b + 4]))
        head = heads[b] + rotate_each(r, locations[:, 3 * b:3 * b + 3])
        moved = rotate_each(rotations, head) + translations
        locations[:, 3 * b:3 * b + 3] = rotate_each(inverse, moved - heads[b])
    return basis, locations


def object_keys(location, rotation, placement, track_rotations, track_translations):
    """The object's location and rotation channels (n, 3), (n, 4 quaternions) that move it by a track in its
    own space (rotations (n, 4), translations (n, 3)): matrix_basis' = matrix_basis @ track.

    location (3,) and rotation (4,) are its channels as they stand; placement: (the rotation (4,) and
    uniform scale of its matrix_basis, delta transforms included), which carry the track's translation
    into the parent's space. A delta rotation stays in front of the keyed one, as Blender composes them."""
    turn, scale = placement
    n = len(track_rotations)
    shift = scale * rotate_each(np.broadcast_to(np.asarray(turn, dtype=np.float64), (n, 4)), track_translations)
    keyed = multiply(np.broadcast_to(np.asarray(rotation, dtype=np.float64), (n, 4)), track_rotations)
    return np.asarray(location, dtype=np.float64) + shift, keyed
