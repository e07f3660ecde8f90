"""A game rig's floor root and the body's proportions, in numpy (no bpy).

Game rigs carry a bone on the floor above the hips (Unreal's ``root``, a
dataset's ``joint_Root``). Retargeting places the hips in armature space
whatever that bone does, so its motion is a choice (FLOOR_ROOTS): keep it
still, copy the source's floor root, or extract root motion for game engines
(it follows the hips' ground projection and facing, smoothed). Whatever it
does, the hips are re-expressed under it so that the world pose is unchanged.

Proportions: each leg's length measured along it (thigh + shin + the ankle's
height above the sole), which a rest pose with spread legs does not change,
unlike the hips' height above the lowest point; the legs' heights scale by
their ratio (the root's path by the standing heights, core.floor_fit).

Quaternions are w x y z; positions are armature space with Z up.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import native_state
from .rotation_channels import about, conjugate, multiply, rotate_each as rotate, sign_continuous, twist_angles

FLOOR_ROOTS = (
    ("auto", "Auto", "Copy the source's floor root if it has one, else keep the target's still"),
    ("still", "Still", "The floor root stays where the match pose has it; the hips carry all the motion"),
    ("copy", "Copy", "The floor root moves as the source's floor root does (translation scaled)"),
    ("extract", "Extract",
     "The floor root follows the hips' ground projection and facing, smoothed, for game engines; "
     "the hips keep the rest, so the world pose is the same"),
)
_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
# A foot whose bones run on within this angle of the shin's line is a zero pose's, not a standing foot.
_DEGENERATE_FOOT_DEG = 30.0


def about_z(angles) -> np.ndarray:
    return about(2, angles)


def heading(q) -> np.ndarray:
    """The turn about Z of rotations q (n, 4) (the twist of a swing-twist split), continuous over rows."""
    return np.unwrap(twist_angles(q, [0.0, 0.0, 1.0]))


def smooth(x, sigma_frames: float) -> np.ndarray:
    """Gaussian smoothing along the first axis; a straight line stays exactly as it is, ends included."""
    x = np.asarray(x, dtype=np.float64)
    if sigma_frames <= 0 or len(x) < 2:
        return x.copy()
    radius = int(np.ceil(3.0 * sigma_frames))
    kernel = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma_frames) ** 2)
    kernel /= kernel.sum()
    # Point-reflected ends keep a steady walk steady up to the last frame (held ends would lag behind it).
    index = np.clip(np.arange(1, radius + 1), 0, len(x) - 1)
    padded = np.concatenate([2.0 * x[:1] - x[index][::-1], x, 2.0 * x[-1:] - x[len(x) - 1 - index]])
    flat = padded.reshape(len(padded), -1)
    out = np.stack([np.convolve(flat[:, k], kernel, mode="valid") for k in range(flat.shape[1])], axis=1)
    return out.reshape(x.shape)


# ---------------------------------------------------------------------------
# Proportions

@dataclass(frozen=True)
class Leg:
    """One leg's bones as indices into a rig's bones (foot may be -1)."""
    thigh: int
    shin: int
    foot: int
    below_ankle: tuple[int, ...]  # the foot's bone and everything under it


def leg_length(leg: Leg, heads: np.ndarray, tails: np.ndarray, ankle_lowest: float | None = None,
               up=None) -> float:
    """thigh + shin + the ankle's height above the sole, in a pose given by its bones' heads and tails.

    The ankle's height is measured along the shin (the farthest foot point
    beyond the ankle in the shin's direction), so turning the whole leg at the
    hip, as an A-pose with spread legs does, changes nothing; or, given up and
    where it is more, along up (how high the ankle stands above the foot's
    lowest point): a character standing on bent knees, its shins slanted and
    its feet flat, has its ankles that high when its legs straighten. A zero pose's
    foot runs on along the shin and has no sole to measure: then
    ankle_lowest, the ankle's lowest height above the floor over a clip, is
    used when given, else a tenth of thigh + shin (a person's proportion).
    """
    hip, knee = heads[leg.thigh], heads[leg.shin]
    ankle = heads[leg.foot] if leg.foot >= 0 else tails[leg.shin]
    upper, lower = float(np.linalg.norm(knee - hip)), float(np.linalg.norm(ankle - knee))
    if not lower > 0:
        return upper
    down = (ankle - knee) / lower
    points = np.vstack([heads[list(leg.below_ankle)], tails[list(leg.below_ankle)]]) if leg.below_ankle else ankle[None]
    offsets = points - ankle
    along = offsets @ down
    reach = np.linalg.norm(offsets, axis=1)
    spread = reach > 1e-9 * max(upper + lower, 1e-12)
    cos_limit = np.cos(np.radians(_DEGENERATE_FOOT_DEG))
    degenerate = bool(spread.any()) and bool(np.all(along[spread] >= cos_limit * reach[spread]))
    if degenerate:
        ankle_height = ankle_lowest if ankle_lowest is not None else 0.1 * (upper + lower)
    else:
        ankle_height = max(0.0, float(along.max()))
        if up is not None:
            ankle_height = max(ankle_height, float(-(offsets @ np.asarray(up, dtype=np.float64)).min()))
    return upper + lower + ankle_height


# ---------------------------------------------------------------------------
# The floor root's motion

@dataclass
class FloorRootRest:
    """What re-expressing the floor root and the hips needs of the target's rest pose (armature space)."""
    root: int           # the floor root's index
    root_parent: int    # its parent (-1 for the top bone)
    hips: int
    hips_parent: int
    rest_rotations: np.ndarray  # (bones, 4)
    rest_heads: np.ndarray      # (bones, 3)


def _local(rest: FloorRootRest, bone: int, parent: int, parent_rotations, parent_heads, rotations, heads):
    return local_channels(rest.rest_rotations, rest.rest_heads, bone, parent, parent_rotations, parent_heads,
                          rotations, heads)


def local_channels(rest_rotations, rest_heads, bone: int, parent: int, parent_rotations, parent_heads, rotations,
                   heads):
    """Pose channels (basis rotation, location) that put `bone` at rotations/heads (n, 4)/(n, 3) under its
    parent posed at parent_rotations/parent_heads, as Blender composes them:
    pose = parent_pose @ parent_rest^-1 @ rest @ basis. rest_rotations, rest_heads: every bone's rest."""
    q_rest, h_rest = rest_rotations[bone], rest_heads[bone]
    if parent < 0:
        frame, anchor = np.broadcast_to(q_rest, rotations.shape), np.broadcast_to(h_rest, heads.shape)
    else:
        p_rest = conjugate(rest_rotations[parent])
        relative = multiply(p_rest, q_rest)
        offset = rotate(p_rest, h_rest - rest_heads[parent])
        frame = multiply(parent_rotations, relative)
        anchor = parent_heads + rotate(parent_rotations, offset)
    inverse = conjugate(frame)
    return multiply(inverse, rotations), rotate(inverse, heads - anchor)


def extract_track(hips_rotations, hips_heads, hips_match_rotation, hips_match_head, root_match_rotation,
                  root_match_head, sigma_frames: float, height: float | None = None,
                  up=None) -> tuple[np.ndarray, np.ndarray]:
    """The floor root's armature-space rotations (n, 4) and heads (n, 3) for root motion:
    its match pose moved along the hips' ground track and turned with the hips' heading, both smoothed.
    up: the world's up in armature space (default Z; an FBX import's is Y); height: the heads' height along
    it (the floor's), else the match pose's."""
    up = np.array([0.0, 0.0, 1.0]) if up is None else np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    turn = multiply(hips_rotations, conjugate(hips_match_rotation))
    yaw = smooth(np.unwrap(twist_angles(turn, up)), sigma_frames)
    moved = smooth(hips_heads - hips_match_head, sigma_frames)
    moved -= np.outer(moved @ up, up)  # on the floor: the hips keep their height and sway
    heads = root_match_head + moved
    if height is not None:
        heads += np.outer(height - heads @ up, up)
    about_up = np.column_stack([np.cos(0.5 * yaw), np.sin(0.5 * yaw)[:, None] * up])
    return sign_continuous(multiply(about_up, root_match_rotation), _IDENTITY), heads


def copy_track(source_rotations, source_heads, source_match_rotation, source_match_head, space,
               root_match_rotation, root_match_head, scale: float, horizontal: float, vertical: bool):
    """The floor root moved as the source's floor root moved from its match pose, carried into target
    space by `space` (4,) and scaled; across the floor times horizontal besides (0 keeps the match pose's),
    vertical False keeps the match pose's height."""
    turn = multiply(multiply(space, multiply(source_rotations, conjugate(source_match_rotation))), conjugate(space))
    moved = scale * rotate(space, source_heads - source_match_head)
    moved[:, :2] *= horizontal
    if not vertical:
        moved[:, 2] = 0.0
    return sign_continuous(multiply(turn, root_match_rotation), _IDENTITY), root_match_head + moved


def carry(rest: FloorRootRest, root_rotations, root_heads, root_parent_pose, hips_parent_pose, hips_rotations,
          hips_heads):
    """The floor root's channels that put it at root_rotations/root_heads, and the hips' channels that keep
    the hips where they were (hips_rotations/hips_heads, armature space).

    root_parent_pose: (rotations, heads) of the floor root's parent (None for a top bone).
    hips_parent_pose: a callable (root basis, root location) -> (rotations, heads) of the hips' parent with
    the floor root so posed (the parent is the floor root itself, or a bone between them).
    Returns (root basis, root location, hips basis, hips location), each (n, 4) or (n, 3).
    """
    parent_rotations, parent_heads = root_parent_pose if root_parent_pose is not None else (None, None)
    root_basis, root_location = _local(rest, rest.root, rest.root_parent, parent_rotations, parent_heads,
                                       root_rotations, root_heads)
    root_basis = sign_continuous(root_basis, _IDENTITY)
    parent_rotations, parent_heads = hips_parent_pose(root_basis, root_location)
    hips_basis, hips_location = _local(rest, rest.hips, rest.hips_parent, parent_rotations, parent_heads,
                                       hips_rotations, hips_heads)
    return root_basis, root_location, sign_continuous(hips_basis, _IDENTITY), hips_location


def body_roots(rig, body, mapped) -> tuple[int | None, int | None]:
    """(hips, floor root) of a rig (core.rig_data.RigData) by index: the hips found by the bone map among the
    mapped bones (else the highest mapped bone other than a floor root), and the top bone above them, if any."""
    hips = rig.index(body.hips) if body.hips in rig and rig.index(body.hips) in mapped else None
    if hips is None:
        floor = rig.index(body.root) if body.root in rig else None
        candidates = [b for b in mapped if b != floor]
        if not candidates:
            return None, None
        hips = min(candidates, key=lambda b: (rig.depths[b], b))
    top = rig.top(hips)
    return hips, (top if top != hips else None)


@dataclass
class FloorRootMotion:
    """What the floor root is to do: mode "copy" or "extract"; source_motion, for "copy": the source's floor
    root (orientations (n, 4), heads (n, 3), match orientation, match head); space: source to target armature
    space; scale: the motion's; root: the retarget's root motion (ROOT_MOTIONS); sigma_frames: the extracted
    track's smoothing."""
    mode: str
    source_motion: tuple | None
    space: np.ndarray
    scale: float
    root: str
    sigma_frames: float
    height: float | None = None  # "extract": the root's height (the floor's), else its match pose's
    up: np.ndarray | None = None  # "extract": the world's up in armature space (default Z)
    scale_horizontal: float = 1.0  # "copy": the travel across the floor, times this on top of scale


def move_floor_root(rig, match, rotations, locations, floor: int, hips: int, how: FloorRootMotion) -> None:
    """Gives the target's floor root its motion (copy or extract) and re-expresses the hips under it so that
    every bone keeps its armature-space pose. rig: the target's RigData; match: its match pose
    (core.rig_data.Pose). Writes rotations and locations (frames, 4B / 3B pose channels) in place."""
    native = native_state.native()
    posed_rotations, posed_heads = native.armature_pose(rig.native, rotations, locations)
    block = lambda a, b, n: a[:, n * b:n * b + n]  # noqa: E731
    if how.mode == "extract":
        track = extract_track(block(posed_rotations, hips, 4), block(posed_heads, hips, 3), match.rotations[hips],
                              match.heads[hips], match.rotations[floor], match.heads[floor], how.sigma_frames,
                              how.height, how.up)
    else:
        track = copy_track(*how.source_motion, how.space, match.rotations[floor], match.heads[floor], how.scale,
                           horizontal=how.scale_horizontal if how.root in ("scaled", "offset") else 0.0,
                           vertical=how.root != "none")
    rest = FloorRootRest(floor, rig.parents[floor], hips, rig.parents[hips], rig.rest, rig.heads)
    root_parent = rig.parents[floor]
    parent_pose = None if root_parent < 0 else (block(posed_rotations, root_parent, 4),
                                                block(posed_heads, root_parent, 3))

    def hips_parent_pose(root_basis, root_location):
        if rest.hips_parent == floor:  # the usual game rig: the hips hang from the floor root itself
            return track
        trial_rotations, trial_locations = rotations.copy(), locations.copy()
        trial_rotations[:, 4 * floor:4 * floor + 4] = root_basis
        trial_locations[:, 3 * floor:3 * floor + 3] = root_location
        r, h = native.armature_pose(rig.native, trial_rotations, trial_locations)
        return block(r, rest.hips_parent, 4), block(h, rest.hips_parent, 3)

    root_basis, root_location, hips_basis, hips_location = carry(
        rest, *track, parent_pose, hips_parent_pose, block(posed_rotations, hips, 4), block(posed_heads, hips, 3))
    rotations[:, 4 * floor:4 * floor + 4] = root_basis
    locations[:, 3 * floor:3 * floor + 3] = root_location
    rotations[:, 4 * hips:4 * hips + 4] = hips_basis
    locations[:, 3 * hips:3 * hips + 3] = hips_location


def onto_object(rig, match, rotations, locations, hips: int, sigma_frames: float,
                up=None) -> tuple[np.ndarray, np.ndarray]:
    """The object's ground track for root motion on the object: (rotations (n, 4), translations (n, 3)) in
    armature space, the hips' ground path and heading from their match pose, smoothed (extract_track about
    the armature's origin; up: the world's up in armature space). The hips are re-expressed under their
    parent, as it stands (in place in rotations, locations), so that the armature-space pose moved by the
    track is the pose before: the world pose is the same once the object takes the track."""
    native = native_state.native()
    posed_rotations, posed_heads = native.armature_pose(rig.native, rotations, locations)
    block = lambda a, b, n: a[:, n * b:n * b + n]  # noqa: E731
    hips_rotations, hips_heads = block(posed_rotations, hips, 4), block(posed_heads, hips, 3)
    turn, moved = extract_track(hips_rotations, hips_heads, match.rotations[hips], match.heads[hips], _IDENTITY,
                                np.zeros(3), sigma_frames, up=up)
    back = conjugate(turn)
    parent = rig.parents[hips]
    rest = FloorRootRest(hips, parent, hips, parent, rig.unit_rest, rig.heads)
    parent_pose = (None, None) if parent < 0 else (block(posed_rotations, parent, 4), block(posed_heads, parent, 3))
    basis, location = _local(rest, hips, parent, *parent_pose, multiply(back, hips_rotations),
                             rotate(back, hips_heads - moved))
    rotations[:, 4 * hips:4 * hips + 4] = sign_continuous(basis, _IDENTITY)
    locations[:, 3 * hips:3 * hips + 3] = location
    return turn, moved
