"""Forward kinematics of a Blender-style rig written with scipy's Rotation, for tests that judge the
native code's poses: nothing here shares code with the native rig (its PoseBone recurrence), so a fault
there cannot agree with itself.

With Rest_b a bone's rest orientation and H_b its rest head (armature space), its posed orientation and
head are
    G_b    = G_p Rest_p^-1 Rest_b basis_b
    head_b = head_p + G_p Rest_p^-1 (H_b - H_p)
(a root: G_b = Rest_b basis_b, head_b = H_b + Rest_b location), and its tail head_b + G_b (0, length, 0).
Quaternions are w x y z, as the native module takes them."""
import numpy as np
from scipy.spatial.transform import Rotation


def rotation(wxyz) -> Rotation:
    """A scipy Rotation from quaternions (..., 4) w x y z (scipy's own order is x y z w)."""
    q = np.asarray(wxyz, dtype=np.float64)
    return Rotation.from_quat(np.concatenate([q[..., 1:], q[..., :1]], axis=-1))


def pose(parents, rest, heads, lengths, rotations, root_location=None):
    """Every frame's posed orientations (a list of Rotation, one per bone, over frames), heads and tails
    (frames, bones, 3). rotations: (frames, 4 x bones) basis quaternions w x y z; root_location: (frames, 3)
    or (1, 3), the root bones' location channel (zero if None)."""
    rotations = np.asarray(rotations, dtype=np.float64)
    frames, bones = len(rotations), len(parents)
    rest_of = [rotation(r) for r in np.asarray(rest, dtype=np.float64)]
    heads = np.asarray(heads, dtype=np.float64)
    location = np.zeros((frames, 3)) if root_location is None else np.broadcast_to(
        np.asarray(root_location, dtype=np.float64), (frames, 3))
    global_, head_out = [], np.empty((frames, bones, 3))
    for b, p in enumerate(parents):
        basis = rotation(rotations[:, 4 * b:4 * b + 4])
        if p < 0:
            frame = rotation(np.tile(np.asarray(rest, dtype=np.float64)[b], (frames, 1)))
            head_out[:, b] = heads[b] + frame.apply(location)
        else:
            frame = global_[p] * (rest_of[p].inv() * rest_of[b])
            head_out[:, b] = head_out[:, p] + global_[p].apply(rest_of[p].inv().apply(heads[b] - heads[p]))
        global_.append(frame * basis)
    y = np.array([0.0, 1.0, 0.0])
    tails = np.stack([head_out[:, b] + g.apply(lengths[b] * y) for b, g in enumerate(global_)], axis=1)
    return global_, head_out, tails
