"""Squad as Shoemake published it (K. Shoemake, "Animating rotation with quaternion curves", SIGGRAPH
1985, and the 1987 course notes "Quaternion calculus and fast animation"), computed here in float64 with
numpy, independent of MotionKit's native code. Quaternions are (w, x, y, z) rows; keys equally spaced.

    squad(q_i, q_{i+1}, s_i, s_{i+1}, h) = slerp(slerp(q_i, q_{i+1}, h), slerp(s_i, s_{i+1}, h), 2h(1 - h))
    s_i = q_i exp(-(log(q_i^-1 q_{i+1}) + log(q_i^-1 q_{i-1})) / 4)

with slerp(p, q, h) = p (p^-1 q)^h = p exp(h log(p^-1 q)). At the first and last keys, which have one
neighbour, s = q (the curve starts and ends along the chord to its neighbour, as the notes take it).

Signs: q and -q are the same rotation, and the paper asks for the nearer of the two. The keys are put in
one hemisphere (q_{i+1} . q_i >= 0), and each slerp of the formula takes its second end's sign so that
p . q >= 0, the short arc between the two rotations. That choice shows only where two inner quadrangle
points s_i, s_{i+1} are more than a half turn apart as rotations (keys turning about 2 rad a step):
taken literally there, the inner slerp goes the long way round and the curve swings out by ~1.7 rad.
"""
import numpy as np


def multiply(a, b):
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def conjugate(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def log(q):
    """The pure quaternion (x, y, z) v with exp(v) = q, for a unit q: the half angle along the axis."""
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = np.arctan2(s, q[..., :1])
    return np.where(s > 0, v * angle / np.where(s > 0, s, 1.0), 0.0)


def exp(v):
    a = np.linalg.norm(v, axis=-1, keepdims=True)
    sinc = np.where(a > 0, np.sin(a) / np.where(a > 0, a, 1.0), 1.0)
    return np.concatenate([np.cos(a), v * sinc], axis=-1)


def slerp(p, q, h):
    """p to q (the sign of q nearer p: the short arc), at fraction h."""
    q = np.where(np.sum(p * q, axis=-1, keepdims=True) < 0, -q, q)
    return multiply(p, exp(h[..., None] * log(multiply(conjugate(p), q))))


def hemisphere(q):
    """Unit keys, each flipped where needed so that it lies within 90 degrees (4D) of the one before."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    out = q.copy()
    for i in range(1, len(out)):
        if out[i] @ out[i - 1] < 0:
            out[i] = -out[i]
    return out


def controls(q):
    """The inner quadrangle points s_i of keys q (n, 4), already in one hemisphere."""
    s = q.copy()
    inverse = conjugate(q[1:-1])
    s[1:-1] = multiply(q[1:-1], exp(-(log(multiply(inverse, q[2:])) + log(multiply(inverse, q[:-2]))) / 4))
    return s


def squad(times, keys, at):
    """The squad curve through keys (n, 4) at equally spaced times (n,), evaluated at times at (m,)."""
    step = np.diff(times)
    assert np.allclose(step, step[0]), "Shoemake's squad is written for equally spaced keys"
    q = hemisphere(np.asarray(keys, dtype=np.float64))
    s = controls(q)
    i = np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(times) - 2)
    h = (at - times[i]) / step[0]
    return slerp(slerp(q[i], q[i + 1], h), slerp(s[i], s[i + 1], h), 2 * h * (1 - h))
