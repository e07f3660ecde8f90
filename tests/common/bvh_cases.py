"""Synthetic BVH files that cover every channel layout and rotation order (no bpy).

Each case is (name, text). Motion is smooth random-ish (seeded sines) so that
frame-to-frame continuity can be checked too.
"""
from __future__ import annotations

import itertools

import numpy as np

ORDERS = ["".join(p) for p in itertools.permutations("XYZ")]


def _channels(names):
    return f"CHANNELS {len(names)} {' '.join(names)}" if names else "CHANNELS 0"


def build(joints, frames=24, frame_time=1 / 30, seed=0, newline="\n", amplitude=70.0):
    """joints: list of (name, parent_index or -1, offset, channels, end_offset or None)."""
    lines = ["HIERARCHY"]
    children = {i: [] for i in range(len(joints))}
    for i, j in enumerate(joints):
        if j[1] >= 0:
            children[j[1]].append(i)

    def emit(i, depth):
        name, parent, offset, channels, end = joints[i]
        pad = "\t" * depth
        lines.append(f"{pad}{'ROOT' if parent < 0 else 'JOINT'} {name}")
        lines.append(pad + "{")
        lines.append(f"{pad}\tOFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}")
        lines.append(f"{pad}\t{_channels(channels)}")
        for child in children[i]:
            emit(child, depth + 1)
        if end is not None:
            lines.extend([f"{pad}\tEnd Site", f"{pad}\t{{",
                          f"{pad}\t\tOFFSET {end[0]:.6f} {end[1]:.6f} {end[2]:.6f}", f"{pad}\t}}"])
        lines.append(pad + "}")

    for i, j in enumerate(joints):
        if j[1] < 0:
            emit(i, 0)
    columns = [c for j in joints for c in j[3]]
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0, 2 * np.pi, len(columns))
    speed = rng.uniform(0.5, 2.0, len(columns))
    t = np.arange(frames)[:, None] * frame_time * 2 * np.pi
    scale = np.array([amplitude if c.endswith("rotation") else 0.3 for c in columns])
    values = scale * np.sin(speed * t + phase)
    lines += ["MOTION", f"Frames: {frames}", f"Frame Time: {frame_time:.6f}"]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in values]
    return newline.join(lines) + newline


def _rot(order):
    return [f"{a}rotation" for a in order]


POS = ["Xposition", "Yposition", "Zposition"]


def cases():
    out = []
    # Every rotation order on a chain (root included), root translating.
    for order in ORDERS:
        out.append((f"chain_{order}", build([
            ("Hips", -1, (0, 1, 0), POS + _rot(order), None),
            ("Spine", 0, (0, 0.2, 0), _rot(order), None),
            ("Arm", 1, (0.3, 0.1, 0.05), _rot(order), None),
            ("Hand", 2, (0.25, 0, 0), _rot(order), (0.1, 0, 0)),
            ("Leg", 0, (-0.1, -0.1, 0), _rot(order), (0, -0.4, 0.02)),
        ], seed=len(out))))
    # Position channels on a non-root joint, channels interleaved and reordered.
    out.append(("positions_on_child", build([
        ("Root", -1, (0, 0, 0), ["Zrotation", "Xposition", "Yrotation", "Yposition", "Xrotation", "Zposition"], None),
        ("Slide", 0, (0, 0.5, 0), ["Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"], None),
        ("Tip", 1, (0.2, 0.3, 0), _rot("YZX"), (0, 0.2, 0)),
    ], seed=11)))
    # Joints with no channels and with fewer than three rotations.
    out.append(("sparse_channels", build([
        ("Root", -1, (0, 1, 0), POS + _rot("ZXY"), None),
        ("Fixed", 0, (0, 0.3, 0), [], None),
        ("Hinge", 1, (0.3, 0, 0), ["Zrotation"], None),
        ("Two", 2, (0.3, 0, 0), ["Yrotation", "Xrotation"], (0.1, 0, 0)),
    ], seed=12)))
    # Several roots in one file.
    out.append(("two_roots", build([
        ("A", -1, (0, 1, 0), POS + _rot("XYZ"), None),
        ("A1", 0, (0, 0.5, 0), _rot("XYZ"), (0, 0.2, 0)),
        ("B", -1, (1, 1, 0), POS + _rot("ZYX"), None),
        ("B1", 2, (0.4, 0, 0), _rot("ZYX"), (0.2, 0, 0)),
    ], seed=13)))
    # Line endings and whitespace real files have.
    base = out[0][1]
    out.append(("crlf", base.replace("\n", "\r\n")))
    out.append(("cr_only", base.replace("\n", "\r")))
    out.append(("tabs_blank_trailing", base.replace("\n", "  \t\n\n").replace(" ", "\t ")))
    out.append(("no_final_newline", base.rstrip("\n")))
    return out


def comparable_with_blender(name):
    """Cases Blender's own importer reads with our semantics (full rotation triples)."""
    return name.startswith("chain_") or name in ("two_roots", "crlf", "tabs_blank_trailing",
                                                 "no_final_newline")
