"""A procedural walk cycle for the sample characters (numpy only, no bpy).

The walk is authored as global rotations G_i(t) about armature axes (what an
animator would say: "thigh swings 25 degrees forward"), applied on top of each
bone's rest orientation: Q_i = G_i B_i. Blender stores a pose bone's rotation
relative to its rest frame and its parent, so the bone-local rotation is

    M_i = B_i^-1 G_p(i)^-1 G_i B_i

which holds for any bone roll: the same walk plays on every sample character
however its bones are rolled. Quaternions are (w, x, y, z).
"""
from __future__ import annotations

import math

import numpy as np

CYCLE_SECONDS = 1.0  # one left and one right step
SPEED = 1.35  # metres per second, forward (-Y)
ARMS_DOWN_DEG = 72.0  # walking arm hang below horizontal


def axis_angle(axis, angles) -> np.ndarray:
    angles = np.asarray(angles, dtype=np.float64)
    half = 0.5 * angles
    q = np.zeros(angles.shape + (4,))
    q[..., 0] = np.cos(half)
    q[..., 1:] = np.sin(half)[..., None] * np.asarray(axis, dtype=np.float64)
    return q


def mul(a, b) -> np.ndarray:
    aw, ax, ay, az = np.moveaxis(np.asarray(a), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b), -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def conj(q) -> np.ndarray:
    return np.asarray(q) * np.array([1.0, -1.0, -1.0, -1.0])


def rotate(q, v) -> np.ndarray:
    """Rotates vectors v (..., 3) by unit quaternions q (..., 4)."""
    qv = np.concatenate([np.zeros(np.shape(v)[:-1] + (1,)), v], axis=-1)
    return mul(mul(q, qv), conj(q))[..., 1:]


X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def global_rotations(spec, times: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """G_i for every canonical bone of spec at times (seconds), and the hips' offset (n, 3)."""
    phase = 2.0 * math.pi * times / CYCLE_SECONDS
    deg = math.radians
    n = times.shape[0]
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    G: dict[str, np.ndarray] = {}

    G["hips"] = mul(axis_angle(Z, deg(6) * np.sin(phase)), axis_angle(Y, deg(3) * np.cos(phase)))
    spine_keys = [k for k in spec.canonical if k.startswith("spine.")]
    for i, key in enumerate(spine_keys, 1):
        # The chest counter-rotates the pelvis, a little more with every bone.
        G[key] = axis_angle(Z, deg(6) * np.sin(phase) * (1.0 - 2.0 * i / len(spine_keys)))
    for key in spec.canonical:
        if key.startswith("neck.") or key in ("head", "root"):
            G[key] = identity

    down_rest = spec.proportions.arm_down_deg
    for side, sign, offset in (("L", 1.0, 0.0), ("R", -1.0, math.pi)):
        p = phase + offset
        hip = -deg(24) * np.sin(p)  # negative about X swings the leg forward (-Y)
        knee = deg(6) + deg(50) * ((1.0 + np.cos(p + 0.9)) / 2.0) ** 1.5  # flexes in swing
        ankle = deg(12) * np.sin(p - 0.4)
        G[f"thigh.{side}"] = axis_angle(X, hip)
        G[f"shin.{side}"] = axis_angle(X, hip + knee)
        G[f"foot.{side}"] = axis_angle(X, 0.5 * ankle)  # the sole stays near level
        G[f"toe.{side}"] = axis_angle(X, np.clip(ankle, 0.0, None))
        G[f"shoulder.{side}"] = identity
        lower = axis_angle(Y, sign * deg(ARMS_DOWN_DEG - down_rest))
        swing = deg(18) * np.sin(p)  # arms swing against the legs
        elbow = deg(12) + deg(10) * (1.0 - np.cos(p)) / 2.0
        G[f"upper_arm.{side}"] = mul(axis_angle(X, swing), lower)
        G[f"forearm.{side}"] = mul(axis_angle(X, swing - elbow), lower)
        G[f"hand.{side}"] = G[f"forearm.{side}"]

    offset = np.stack([0.02 * np.sin(phase),
                       -SPEED * times,
                       0.025 * np.cos(2.0 * phase) - 0.025], axis=-1)
    return G, offset


def local_rotations(spec, rest: dict[str, np.ndarray], G: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """M_i = B_i^-1 G_p^-1 G_i B_i for every bone, keyed by canonical name.

    rest: canonical -> B_i, the bone's rest orientation in armature space (4,).
    """
    out = {}
    for bone in spec.bones:
        key = bone.canonical
        parent_key = next((b.canonical for b in spec.bones if b.name == bone.parent), None)
        delta = G[key] if parent_key is None else mul(conj(G[parent_key]), G[key])
        B = rest[key]
        q = mul(mul(conj(B), delta), B)
        # Keep w >= 0 so that consecutive keys never flip hemisphere.
        q *= np.where(q[..., :1] < 0.0, -1.0, 1.0)
        out[key] = q
    return out


def hips_location(rest_hips: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """The root's pose location: the armature-space offset in the hips' rest frame."""
    return rotate(np.broadcast_to(conj(rest_hips), offset.shape[:-1] + (4,)), offset)
