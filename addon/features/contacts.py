"""Planted feet in Blender: foot contacts stored on the action, and footskate cleanup with full-body IK.

Foot points, always in this order: POINTS = [L ankle, L ball, R ankle, R ball].
The ankle is the shin's tail, the ball the foot bone's tail (Blender's IK tip,
where ik_solve's effectors sit).

The cleanup (Kovar, Schreiner, Gleicher 2002): per contact one plant position,
IK targets blended from the plain pose's points to the plants
(foot_contacts.plant_targets, a native job), and the whole clip solved in
one native call (native/include/motionkit/ik.hpp) on a small rig made of the
hips and the two legs: the hips' translation, thighs, shins and feet are the
only unknowns, so every other bone keeps its rotation exactly. Knees are hinges
limited to the plain clip's own range of twist and side swing and to
flexion no less than the plain clip's least, so that they never bend
backwards or hyper-extend further than the input did; where a plant cannot
be reached the solver gives the closest pose within those limits.

Contacts live where an animator sees and edits them: one F-curve per foot
point on the armature's action, a custom property of the foot's pose bone
(pose.bones["foot.L"]["motionkit_contact_heel"], ["motionkit_contact_ball"]),
0/1 with constant interpolation. Everything goes through motionkit.animdata.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..blender import animdata, pose_channels
from ..core import bone_mapping, native_state, rotation_channels
from ..core.rig_data import RigData
from ..core.rotation_channels import conjugate as _conj, multiply as _mul, rotate_each as _rotate
from ..core.foot_contacts import ContactSettings, all_intervals, detect as detect_contacts, plant_targets, plantable

SIDES = ("L", "R")
POINTS = ("L ankle", "L ball", "R ankle", "R ball")
PROPERTIES = ("motionkit_contact_heel", "motionkit_contact_ball")  # per foot: ankle, ball
_RIGID = ((0, 1), (2, 3))  # each foot's two points, a bone's length apart
_SOLVE_OPTIONS = {}  # overrides of the solver's IkOptions fields (experiments)
_KNEE_SLACK = 0.0  # radians of twist and side swing beyond the clip's own range


@dataclass
class Foot:
    """One leg's bones, by name. toe may be None (the ball is the foot bone's tail either way)."""
    side: str
    thigh: str
    shin: str
    foot: str
    toe: str | None = None


@dataclass
class Report:
    frames: np.ndarray                      # Blender frames
    contacts: np.ndarray                    # (frames, 4) bool, POINTS order
    intervals: list = field(default_factory=list)  # per point, [(first frame, last frame)] in Blender frames
    held: np.ndarray | None = None          # (frames, 4) bool: the contacts held still (no slides, no pivots)
    source: str = "detected"                # "detected", "given" or "curves"
    errors: np.ndarray | None = None        # (frames, 4) distance of each point from its IK target, armature units
    max_error: np.ndarray | None = None     # (4,) the worst of errors per point
    iterations: int = 0                     # total IK iterations over the clip
    seconds: float = 0.0                    # the cleanup (targets, solve, conversion), not the file I/O
    solve_seconds: float = 0.0              # the native call alone
    knee_axes: dict = field(default_factory=dict)  # side -> "flexion" (from the clip) or "foot" (fallback)
    bones: list = field(default_factory=list)      # bones whose channels the cleanup changed


def _about_y(angle):
    return rotation_channels.about(1, angle)


# ---------------------------------------------------------------------------
# Legs

def find_feet(obj) -> list[Foot]:
    """The two legs of an armature from MotionKit's bone map (labels thigh.L, shin.L, foot.L, toe.L, ...)."""
    return feet_of(bone_mapping.classify(pose_channels.armature_mapping_rig(obj, upright=True)), obj.name)


def feet_of(body, name: str) -> list[Foot]:
    """The two legs of a bone_mapping.Body; a ValueError names the foot and what is missing."""
    feet = []
    for side in SIDES:
        names = {part: body.limbs.get(f"{part}.{side}") for part in ("thigh", "shin", "foot", "toe")}
        missing = [part for part in ("thigh", "shin", "foot") if not names[part]]
        if missing:
            raise ValueError(f"foot {side}: '{name}' has no {', '.join(missing)} bone that MotionKit "
                             f"recognises (found {', '.join(f'{k}={v}' for k, v in names.items() if v) or 'none'})")
        feet.append(Foot(side, names["thigh"], names["shin"], names["foot"], names["toe"]))
    return feet


def _as_feet(feet) -> list[Foot]:
    out = []
    for side, foot in zip(SIDES, feet):
        if isinstance(foot, Foot):
            out.append(foot)
        else:
            thigh, shin, foot_bone, *toe = foot
            out.append(Foot(side, thigh, shin, foot_bone, toe[0] if toe else None))
    if len(out) != 2:
        raise ValueError(f"feet: expected two legs (L, R), got {len(out)}")
    return out


def _leg_indices(rig: RigData, feet: list[Foot]) -> list[tuple[int, int, int]]:
    out = []
    for foot in feet:
        chain = []
        for part in ("thigh", "shin", "foot"):
            name = getattr(foot, part)
            if name not in rig:
                raise ValueError(f"foot {foot.side}: {part} bone '{name}' is not in the armature")
            chain.append(rig.index(name))
        for child, parent in ((foot.shin, foot.thigh), (foot.foot, foot.shin)):
            above = rig.parents[rig.index(child)]
            if above < 0 or rig.names[above] != parent:
                raise ValueError(f"foot {foot.side}: bone '{child}' is not a child of '{parent}'")
        out.append(tuple(chain))
    return out


def _hips(rig: RigData, legs) -> int:
    """The thighs' nearest common ancestor: the bone whose translation carries the body."""
    paths = [rig.ancestors(thigh) for thigh, _, _ in legs]
    common = [i for i in paths[0] if i in paths[1]]
    if not common:
        raise ValueError(f"the thighs '{rig.names[legs[0][0]]}' and '{rig.names[legs[1][0]]}' share no "
                         "parent: no hips to move")
    return common[0]


# ---------------------------------------------------------------------------
# Contacts on the action

def contact_channels(feet) -> list[tuple[str, int, str]]:
    """The contact F-curves' channels, in POINTS order."""
    out = []
    for foot in _as_feet(feet):
        path = pose_channels.bone_path(foot.foot)
        out += [(f'{path}["{prop}"]', 0, foot.foot) for prop in PROPERTIES]
    return out


def read_contacts(obj, action, feet, frames) -> np.ndarray | None:
    """The stored contacts (frames, 4) bool on the given Blender frames, or None when the action has no
    contact curve. A missing curve (of four) reads as no contact."""
    if action is None:
        return None
    frames = np.asarray(frames, dtype=np.float64)
    out = np.zeros((frames.size, len(POINTS)), dtype=bool)
    found = False
    for p, (path, index, _) in enumerate(contact_channels(feet)):
        fcurve = animdata.find_fcurve(action, obj, path, index)
        if fcurve is None or not len(fcurve.keyframe_points):
            continue
        found = True
        times, values = animdata.read_keys(fcurve)
        order = np.argsort(times, kind="stable")
        times, values = times[order].astype(np.float64), values[order]
        # Constant interpolation: each frame takes the last key at or before it (the first key before).
        at = np.clip(np.searchsorted(times, frames + 1e-4, side="right") - 1, 0, None)
        out[:, p] = values[at] > 0.5
    return out if found else None


def _contact_keys(frames, contacts):
    """Keys only where a contact curve changes (and on the first frame): (frames, values (4, n))."""
    change = np.ones(frames.size, dtype=bool)
    change[1:] = np.any(contacts[1:] != contacts[:-1], axis=1)
    return frames[change], contacts[change].T.astype(np.float64)


def write_contacts(obj, action, feet, frames, contacts) -> list:
    """Store contacts (frames, 4) as 0/1 constant F-curves on the foot bones' custom properties."""
    frames = np.asarray(frames, dtype=np.float64)
    contacts = np.asarray(contacts, dtype=bool)
    if contacts.shape != (frames.size, len(POINTS)):
        raise ValueError(f"contacts must have shape ({frames.size}, {len(POINTS)}), not {contacts.shape}")
    feet = _as_feet(feet)
    for foot in feet:
        if foot.foot not in obj.pose.bones:
            raise ValueError(f"foot {foot.side}: bone '{foot.foot}' is not in '{obj.name}'")
    key_frames, values = _contact_keys(frames, contacts)
    created = []
    try:
        for foot in feet:
            pose_bone = obj.pose.bones[foot.foot]
            for prop in PROPERTIES:
                # The property must exist for the Graph Editor to show (and Blender to evaluate) the curve.
                if prop not in pose_bone.keys():
                    pose_bone[prop] = 0.0
                    created.append((pose_bone, prop))
                    what = "heel (ankle)" if prop == PROPERTIES[0] else "ball"
                    pose_bone.id_properties_ui(prop).update(
                        min=0.0, max=1.0, soft_min=0.0, soft_max=1.0,
                        description=f"MotionKit: 1 where the {what} of foot {foot.side} is planted")
        return animdata.write_keys(obj, action, contact_channels(feet), key_frames, values,
                                   interpolation='CONSTANT')
    except BaseException:
        for pose_bone, prop in created:
            del pose_bone[prop]
        raise


# ---------------------------------------------------------------------------
# The cleanup

def _knee_roll(angles, shin_world, foot_dir_world) -> tuple[float, str]:
    """The roll r about the shin's Y axis that turns its flexion axis onto +X (so that flexion is +x
    in the IK's limits), from the plain clip's knee swings (angles: the ik_swing_twist of the shin's basis);
    from the foot's direction when the clip hardly bends the knee."""
    swing = angles[:, [0, 2]]
    if np.max(np.linalg.norm(swing, axis=1)) > 0.3:
        _, vectors = np.linalg.eigh(swing.T @ swing)
        axis = vectors[:, -1]
        if np.mean(swing @ axis) < 0:
            axis = -axis
        how = "flexion"
    else:
        # Flexion swings the shin's tail backwards, away from where the foot points: about forward x Y.
        forward = _rotate(_conj(shin_world), foot_dir_world)  # in the shin's own frame
        axis3 = np.cross(forward, [0.0, 1.0, 0.0]).mean(axis=0)
        axis = axis3[[0, 2]]
        how = "foot"
    if np.linalg.norm(axis) < 1e-9:
        return 0.0, "none"
    return float(np.arctan2(-axis[1], axis[0])), how


def _rolled(angles, roll):
    """ik_swing_twist of about_y(-roll) q about_y(roll) from that of q: the twist about Y is unchanged and
    the swing vector (x, 0, z) turns by -roll about Y."""
    c, s = np.cos(roll), np.sin(roll)
    x, z = angles[:, 0], angles[:, 2]
    return np.stack([c * x - s * z, angles[:, 1], s * x + c * z], axis=1)


class _Posed:
    """Armature-space orientations and heads of some bones over a clip, by bone index: views into the
    (F, 4n) and (F, 3n) arrays of a native pose, no copies; basis: those bones' pose-basis rotations
    (F, 4n) in the same columns."""

    def __init__(self, orientations, heads, columns, basis):
        self._orientations, self._heads, self.columns, self.basis = orientations, heads, columns, basis

    def orient(self, b):
        c = self.columns[b]
        return self._orientations[:, 4 * c:4 * c + 4]

    def head(self, b):
        c = self.columns[b]
        return self._heads[:, 3 * c:3 * c + 3]


@dataclass
class _LegRig:
    """What posing the legs takes from Blender, read once (numpy and native objects only, so that the
    posing itself may run on a worker thread): the legs (thigh, shin, foot indices), the bones that place
    them (the legs and every bone above them) with their native rig, every bone's length and the object's
    matrix_world. rig None: the caller poses the whole armature itself."""
    legs: list
    sub: list
    rig: object
    lengths: np.ndarray
    world: np.ndarray
    aims: np.ndarray | None = None  # (B, 3) where each bone points in its own frame (None: along its Y)

    @classmethod
    def read(cls, rig: RigData, legs, feet, whole: bool = False) -> "_LegRig":
        # Only the legs and the bones above them place the feet: posed alone (the rest is never read).
        sub = sorted(set(b for chain in legs for b in chain).union(*(rig.ancestors(chain[0]) for chain in legs)))
        lengths, aims = rig.lengths, None
        # A rig whose bones do not run along their Y axes (an FBX import): each leg bone's point is the next
        # joint, not its tail (core.bone_axes); a foot's is its ball.
        found = rig.aims(_continuing(rig, legs, feet))
        if found is not None:
            aims, lengths = found
        return cls(legs, sub, None if whole else rig.native_rig(sub), lengths, rig.world, aims)

    def aim_rotations(self, bones) -> np.ndarray:
        """(len(bones), 4) per bone the rotation that turns its Y axis onto where it points."""
        if self.aims is None:
            return np.tile([1.0, 0.0, 0.0, 0.0], (len(bones), 1))
        return np.array([rotation_channels.between([0.0, 1.0, 0.0], self.aims[b]) for b in bones])


def _continuing(rig: RigData, legs, feet) -> np.ndarray:
    """Each bone's continuing child (core.bone_axes), but a foot's is its toe wherever the toe hangs from it:
    the foot's second point is the ball, the toe's head, as the retarget and the floor take it. By shape alone
    a heel bone beside the toe can continue the shin more straightly (Blender's metarig: heel.02's head on
    the floor behind the ankle), and a point there leaves the ball free to roll about the ankle-heel line."""
    continuing = rig.continuing_children()
    for foot, (_, _, f) in zip(feet, legs):
        toe = rig.index(foot.toe) if foot.toe and foot.toe in rig else None
        # A toe whose head sits on the foot's says nothing of where the foot points.
        if toe is not None and rig.parents[toe] == f and \
                np.linalg.norm(rig.heads[toe] - rig.heads[f]) > 1e-4 * rig.lengths[f]:
            continuing[f] = toe
    return continuing


def _pose_points(leg_rig: _LegRig, rotations, locations, posed=None):
    """The pose in armature space (a _Posed of the hips and legs at least), the foot points in armature
    and world space (F, 4, 3) and the leg length (thigh + shin, world units). posed: the whole armature's
    pose (orientations (F, 4B), heads (F, 3B)) when the caller has it already. Reads no Blender data."""
    if posed is None:
        sub = leg_rig.sub
        rot_columns = (4 * np.array(sub)[:, None] + np.arange(4)).ravel()
        loc_columns = (3 * np.array(sub)[:, None] + np.arange(3)).ravel()
        sub_basis = np.ascontiguousarray(rotations[:, rot_columns])
        pose = _Posed(*native_state.native().armature_pose(
            leg_rig.rig, sub_basis, np.ascontiguousarray(locations[:, loc_columns])),
            {b: i for i, b in enumerate(sub)}, sub_basis)
    else:
        pose = _Posed(posed[0], posed[1], range(len(leg_rig.lengths)), rotations)
    lengths, world, legs = leg_rig.lengths, leg_rig.world, leg_rig.legs
    aims = leg_rig.aims
    points = np.stack([pose.head(b) + lengths[b] * (rotation_channels.y_axes(pose.orient(b)) if aims is None else
                                                    _rotate(pose.orient(b), aims[b]))
                       for _, shin, foot in legs for b in (shin, foot)], axis=1)
    world_points = points @ world[:3, :3].T + world[:3, 3]
    scale = float(np.cbrt(abs(np.linalg.det(world[:3, :3]))))
    leg_length = scale * float(np.mean([lengths[t] + lengths[s] for t, s, _ in legs]))
    return pose, points, world_points, leg_length


def foot_points(rig: RigData, rotations, locations, feet, posed=None) -> tuple[np.ndarray, float]:
    """World positions (F, 4, 3) of the foot points (POINTS order) of a pose sequence of a rig
    (core.rig_data: pose_channels.read_rig), and the leg length (thigh + shin, world units): what detection
    sees. posed: its armature pose, if already at hand."""
    feet = _as_feet(feet)
    legs = _leg_indices(rig, feet)
    leg_rig = _LegRig.read(rig, legs, feet, whole=posed is not None)
    _, _, world_points, leg_length = _pose_points(leg_rig, rotations, locations, posed)
    return world_points, leg_length


@dataclass
class Stances:
    """A motion's feet as a retarget reads them on its source: its contacts (F, 4) bool, POINTS order, and
    those a cleanup holds still (no slides, pivots or turns), the same shape."""
    contacts: np.ndarray
    holds: np.ndarray


def find_contacts(rig: RigData, rotations, locations, feet, settings: ContactSettings | None = None,
                  fps: float | None = None, posed=None, floor: float = 0.0, holds: bool = False):
    """Contacts (F, 4) bool (POINTS order) of a pose sequence (for example the retarget's source, whose
    contacts the target then keeps); fps default the scene's; posed: its armature pose, if at hand; floor:
    the floor's world Z. holds: also which of them a cleanup holds still, read on this motion
    (foot_contacts.plantable): a Stances."""
    if fps is None:
        fps = animdata.frame_rate(None)  # the scene's
    points, leg_length = foot_points(rig, rotations, locations, feet, posed)
    found = detect_contacts(points, fps, leg_length, floor, settings)
    return Stances(found, plantable(points, found, leg_length, settings, _RIGID)) if holds else found


def _blender_frame(frames, f) -> str:
    return f"{frames[f]:g}"


def cleanup(rig: RigData, frames, rotations, locations, feet, contacts=None,
            settings: ContactSettings | None = None, *, hips: str | None = None, fps: float | None = None,
            in_place: bool = False, threads: int = 0):
    """Footskate cleanup of a pose sequence; returns (rotations, locations, Report). Changes nothing in
    the file. The arguments are staged_cleanup's."""
    prepare, finish = staged_cleanup(rig, frames, rotations, locations, feet, contacts, settings,
                                     hips=hips, fps=fps, in_place=in_place, threads=threads)
    return finish(prepare()())


def staged_cleanup(rig: RigData, frames, rotations, locations, feet, contacts=None,
                   settings: ContactSettings | None = None, *, hips: str | None = None, fps: float | None = None,
                   in_place: bool = False, threads: int = 0, follow_heights=None,
                   hips_move: bool = True, holds=None):
    """cleanup in stages, so that its native solve and what follows can run beside other work: everything
    that reads Blender data (and the checks of the arguments) happens here, and the result is
    (prepare, finish). prepare() computes the targets and limits (numpy) and returns solve; solve() calls
    native code only (the GIL released); finish(solve()) gives cleanup's (rotations, locations, Report).
    None of them touches Blender data: solve and finish may run on a worker thread while this one writes
    keys (prepare too, but it holds the GIL most of its time). A ValueError from any stage names the foot,
    bone and frame. threads: the solve's (0: every core; the same numbers whatever the count).
    """
    steps = _cleanup_steps(rig, frames, rotations, locations, feet, contacts, settings, hips=hips,
                           fps=fps, in_place=in_place, threads=threads, follow_heights=follow_heights,
                           hips_move=hips_move, holds=holds)
    next(steps)  # Blender's data read, the arguments checked

    def prepare():
        return next(steps)

    def finish(solved):
        try:
            steps.send(solved)
        except StopIteration as done:
            return done.value
        raise RuntimeError("foot cleanup: one solve was expected")

    return prepare, finish


def _keep_feet_rigid(targets, points, rise) -> None:
    """Moves one point of each foot across the floor (its height kept) so that its target lies as far from
    the other's as the foot's two points lie apart: heights that follow the pose must not ask a rigid foot
    for more than it can give. The point that rises more above its plant moves (a heel coming off the
    ground turns about the ball, a toe about the heel). targets, points: (F, 4, 3) world, POINTS order;
    rise (F, 4): how far each target was raised above its plant; targets changed in place."""
    for a, b in _RIGID:
        moving = np.where(rise[:, a] > rise[:, b], a, b)
        still = a + b - moving
        frames = np.arange(len(targets))
        length = np.linalg.norm(points[:, b] - points[:, a], axis=1)
        pivot, free = targets[frames, still], targets[frames, moving]
        across = free[:, :2] - pivot[:, :2]
        norm = np.linalg.norm(across, axis=1)
        reach = np.sqrt(np.maximum(length ** 2 - (free[:, 2] - pivot[:, 2]) ** 2, 0.0))
        ok = norm > 1e-9 * np.maximum(length, 1e-12)
        free[ok, :2] = pivot[ok, :2] + across[ok] * (reach[ok] / norm[ok])[:, None]
        targets[frames, moving] = free


def _cleanup_steps(rig: RigData, frames, rotations, locations, feet, contacts=None,
                   settings: ContactSettings | None = None, *, hips: str | None = None, fps: float | None = None,
                   in_place: bool = False, threads: int = 0, follow_heights=None,
                   hips_move: bool = True, holds=None):
    """The cleanup as a generator: yields its solve, is sent the solve's result, returns cleanup's result.

    rig: the armature at rest (core.rig_data.RigData, pose_channels.read_rig; its world matrix places the
    floor, Z up). frames: (F,) Blender frames. rotations (F, 4B) pose-basis quaternions w x y z, locations
    (F, 3B) pose location channels, both in the rig's bone order.
    feet: per side L, R a Foot or (thigh, shin, foot, toe or None) bone names.
    contacts: (F, 4) bool in POINTS order, or None to detect them on this pose sequence.
    hips: the bone whose location channel carries the body (default: the thighs' common parent).
    fps: for detection and blend lengths (default the scene's).
    follow_heights: (F, 2) per leg, world Z; None holds each plant at its own height. Given, a planted
    point holds only across the floor (where sliding shows) and on every frame its height follows the
    pose's own raised by its leg's follow_heights (the retarget's floor: heels and toes lift where the
    source's do, no foot sinks below the floor). Only the thighs', shins' and feet's rotations and the
    hips' location change (hips_move=False: the hips stay). in_place: write them into
    rotations and locations themselves (float64, C-contiguous) and return those, rather than copies.
    Raises ValueError naming the foot, bone and Blender frame.
    """
    started = time.perf_counter()
    settings = settings or ContactSettings()
    settings.validate()
    feet = _as_feet(feet)
    frames = np.asarray(frames, dtype=np.float64)
    rotations = np.ascontiguousarray(rotations, dtype=np.float64)
    locations = np.ascontiguousarray(locations, dtype=np.float64)
    _check_clip(rig, frames, rotations, locations, contacts)
    contacts = None if contacts is None else np.asarray(contacts, dtype=bool)
    if fps is None:
        fps = animdata.frame_rate(None)  # the scene's
    # Everything the cleanup takes from Blender, read here: after the first stage it reads no Blender data.
    legs = _leg_indices(rig, feet)
    part = _SolvePart.read(rig, legs, feet, _hip_index(rig, feet, legs, hips))
    own = time.perf_counter() - started  # report.seconds: the cleanup's own time, its stages summed
    yield
    started = time.perf_counter()

    _check_finite_pose(part, feet, frames, rotations, locations)
    pose, points, targets, contacts, source, holds = _plant_targets(part.leg_rig, frames, rotations, locations,
                                                                    contacts, settings, fps, follow_heights, holds)
    report = Report(frames, contacts, source=source, held=holds)
    report.bones = [part.bone_names[part.hip]] + [part.bone_names[b] for b in part.changed]
    solve_input = _LegSolve.prepare(part, feet, pose, points, report)
    solve = _solve_call(part, solve_input, targets, frames, report, hips_move=hips_move, threads=threads,
                        name=rig.name)
    own += time.perf_counter() - started
    solved = yield solve
    started = time.perf_counter()

    out_rot, out_loc = _solved_channels(part, solve_input, pose, solved, frames, rotations, locations, in_place,
                                        rig.name)
    report.errors = solved.errors
    report.max_error = solved.errors.max(axis=0) if frames.size else np.zeros(len(POINTS))
    report.iterations = int(solved.iterations.sum())
    report.intervals = [[(frames[s], frames[e - 1]) for s, e in runs] for runs in all_intervals(contacts)]
    report.seconds = own + time.perf_counter() - started
    return out_rot, out_loc, report


def _check_clip(rig: RigData, frames, rotations, locations, contacts) -> None:
    count, nb = frames.size, len(rig)
    if rotations.shape != (count, 4 * nb) or locations.shape != (count, 3 * nb):
        raise ValueError(f"rotations and locations must be ({count}, {4 * nb}) and ({count}, {3 * nb}), "
                         f"not {rotations.shape} and {locations.shape}")
    if contacts is not None and np.shape(contacts) != (count, len(POINTS)):
        raise ValueError(f"contacts must have shape ({count}, {len(POINTS)}), not {np.shape(contacts)}")


def _hip_index(rig: RigData, feet, legs, hips) -> int:
    """The bone whose location channel carries the body: hips (a name), else the thighs' common parent."""
    hip = _hips(rig, legs) if hips is None else (rig.index(hips) if hips in rig else None)
    if hip is None:
        raise ValueError(f"hips bone '{hips}' is not in the armature")
    for foot, chain in zip(feet, legs):
        if hip not in rig.ancestors(chain[0]):
            raise ValueError(f"foot {foot.side}: hips bone '{rig.names[hip]}' is not above the thigh "
                             f"'{rig.names[chain[0]]}'")
    if rig.connected[hip]:
        raise ValueError(f"hips bone '{rig.names[hip]}' is connected to its parent: its location cannot move")
    return hip


@dataclass
class _SolvePart:
    """The solve's rig, read from Blender: the hips (parentless: its armature pose becomes its basis and
    location), the bones from the hips to each thigh (held), and the legs; by bone index."""
    leg_rig: _LegRig
    hip: int
    between: set         # the bones from the hips down to the thighs, held
    part: list           # the solved bones, parents first, the hips first
    local: dict          # bone index -> its index in part
    parents: list        # parent indices within part
    rest_q: np.ndarray   # (part, 4) unit rest orientations
    rest_heads: np.ndarray
    size: float          # the whole rig's (RigData.size)
    bone_names: list     # every bone's name
    changed: list        # the legs' bones, whose rotations the cleanup changes
    effectors: list      # native.IkEffector per foot point, POINTS order

    @classmethod
    def read(cls, rig: RigData, legs, feet, hip) -> "_SolvePart":
        leg_rig = _LegRig.read(rig, legs, feet)
        parent = rig.parents
        between = set()
        for thigh, _, _ in legs:
            b = parent[thigh]
            while b >= 0 and b != hip:
                between.add(b)
                b = parent[b]
        part = [hip] + sorted(between) + [b for chain in legs for b in chain]
        part.sort(key=lambda i: (i != hip, i))  # bones is depth-first: parents stay before children
        local = {b: k for k, b in enumerate(part)}
        rest_q = rig.rest[part]  # a copy
        rest_q /= np.linalg.norm(rest_q, axis=1, keepdims=True)
        bone_names = list(rig.names)
        effectors = [native_state.native().IkEffector(local[b], name=f"foot {side} {what} ('{bone_names[b]}' tail)")
                     for side, (_, shin, foot_bone) in zip(SIDES, legs)
                     for what, b in (("ankle", shin), ("ball", foot_bone))]
        return cls(leg_rig, hip, between, part, local, [local[parent[b]] if b != hip else -1 for b in part],
                   rest_q, rig.heads[part], rig.size,
                   bone_names, [b for chain in legs for b in chain], effectors)


def _check_finite_pose(part: _SolvePart, feet, frames, rotations, locations) -> None:
    """One check over every bone that places the feet; the culprit is looked for only when it fails."""
    if np.isfinite(rotations).all() and np.isfinite(locations).all():
        return
    for foot, chain in zip(feet, part.leg_rig.legs):
        for b in chain + (part.hip,):
            bad = ~np.isfinite(rotations[:, 4 * b:4 * b + 4]).all(axis=1) | \
                ~np.isfinite(locations[:, 3 * b:3 * b + 3]).all(axis=1)
            if bad.any():
                raise ValueError(f"foot {foot.side}: bone '{part.bone_names[b]}' has a non-finite pose at frame "
                                 f"{_blender_frame(frames, np.flatnonzero(bad)[0])}")


def _plant_targets(leg_rig: _LegRig, frames, rotations, locations, contacts, settings, fps, follow_heights,
                   holds=None):
    """(pose, foot points (F, 4, 3) armature space, IK targets (F, 4, 3) armature space, contacts, their
    source, the contacts held): the plain pose's foot points held at their plants where contacts (detected
    when None) say, but for slides and pivots (holds: those held, as a retarget read them on its source;
    None: foot_contacts.plantable on this pose)."""
    pose, points, world_points, leg_length = _pose_points(leg_rig, rotations, locations)
    source = "given"
    if contacts is None:
        contacts = detect_contacts(world_points, fps, leg_length, 0.0, settings)
        source = "detected"
    if holds is None:
        holds = plantable(world_points, contacts, leg_length, settings, _RIGID)  # no slides, no pivots
    with native_state.blender_frames(frames):
        targets_world, _ = plant_targets(native_state.native(), world_points, holds, settings.blend_frames(fps),
                                         _RIGID)
    if follow_heights is not None:
        lift = np.asarray(follow_heights, dtype=np.float64)[:, [0, 0, 1, 1]]  # per point, POINTS order
        held = targets_world[..., 2].copy()
        targets_world[..., 2] = world_points[..., 2] + lift
        _keep_feet_rigid(targets_world, world_points, targets_world[..., 2] - held)
    inverse = np.linalg.inv(leg_rig.world)
    return pose, points, targets_world @ inverse[:3, :3].T + inverse[:3, 3], contacts, source, holds


@dataclass
class _LegSolve:
    """The solve's input pose and rig, its leg bones turned to run along where they point (aim: rest A,
    basis A^-1 basis A, undone after the solve; the hips keep their own frame) and each shin rolled so that
    its knee bends about X, limited to the plain clip's own range (ik_swing_twist coordinates)."""
    rig: object
    rest_q: np.ndarray     # (part, 4) the solve's rest orientations
    basis: np.ndarray      # (F, part, 4) the solve's input basis rotations
    aim: np.ndarray        # (part, 4)
    hip_orient: np.ndarray  # (F, 4) the hips' armature-space orientation
    hip_loc: np.ndarray    # (F, 3) the hips' location in the solve's rest frame
    rolls: dict            # shin bone -> its roll
    limit_min: np.ndarray
    limit_max: np.ndarray

    @classmethod
    def prepare(cls, part: _SolvePart, feet, pose, points, report) -> "_LegSolve":
        count = len(points)
        basis = pose.basis.reshape(count, -1, 4)[:, [pose.columns[b] for b in part.part]]  # a copy
        aim = part.leg_rig.aim_rotations(part.part)
        aim[0] = [1.0, 0.0, 0.0, 0.0]
        rest_q = _mul(part.rest_q, aim)
        basis = _mul(_mul(_conj(aim)[None], basis), aim[None])
        # Hips: basis = rest^-1 * posed orientation, location so that rest head + rest * location = head.
        hip_orient = pose.orient(part.hip) / np.linalg.norm(pose.orient(part.hip), axis=1, keepdims=True)
        basis[:, 0] = _mul(_conj(rest_q[0]), hip_orient)
        hip_loc = _rotate(_conj(np.broadcast_to(rest_q[0], (count, 4))), pose.head(part.hip) - part.rest_heads[0])
        rolls, knee_angles = {}, {}  # knee_angles: the rolled shin's ik_swing_twist, for its limits
        for foot, (_, shin, _) in zip(feet, part.leg_rig.legs):
            foot_dir = points[:, 2 * SIDES.index(foot.side) + 1] - points[:, 2 * SIDES.index(foot.side)]
            k = part.local[shin]
            angles = rotation_channels.ik_swing_twist(basis[:, k])
            roll, how = _knee_roll(angles, _mul(pose.orient(shin), aim[k]), foot_dir)
            report.knee_axes[foot.side] = how
            rolls[shin] = roll
            knee_angles[shin] = _rolled(angles, roll)
            rest_q[k] = _mul(rest_q[k], _about_y(roll))
            basis[:, k] = _mul(_mul(_about_y(-roll), basis[:, k]), _about_y(roll))
        rig = pose_channels.build_rig([part.bone_names[b] for b in part.part], part.parents, rest_q,
                                      part.rest_heads, part.leg_rig.lengths[part.part])
        limit_min, limit_max = _knee_limits(part, knee_angles)
        return cls(rig, rest_q, basis, aim, hip_orient, hip_loc, rolls, limit_min, limit_max)


def _knee_limits(part: _SolvePart, knee_angles) -> tuple[np.ndarray, np.ndarray]:
    """(limit_min, limit_max) (part, 3) of the solve: only the knees are limited."""
    limit_min = np.full((len(part.part), 3), -np.inf)
    limit_max = np.full((len(part.part), 3), np.inf)
    margin = 1e-6
    for shin, angles in knee_angles.items():
        k = part.local[shin]
        low, high = angles.min(axis=0) - margin, angles.max(axis=0) + margin
        # Flexion (x) never below the plain clip's least (nor 0 if it never straightens): no backward
        # bend, no more hyper-extension than the input has; up to a deep bend. Twist and side swing
        # stay within what the clip does.
        slack = _KNEE_SLACK
        limit_min[k] = [min(low[0], 0.0), low[1] - slack, low[2] - slack]
        limit_max[k] = [max(high[0], 2.6), high[1] + slack, high[2] + slack]
    return limit_min, limit_max


def _solve_call(part: _SolvePart, solve: _LegSolve, targets, frames, report, *, hips_move, threads, name):
    """The native solve of the whole clip as a call that touches no Blender data."""
    native = native_state.native()
    count = frames.size
    excluded = np.zeros(len(part.part), dtype=bool)
    excluded[[part.local[b] for b in part.between]] = True
    arguments = (solve.rig, np.ascontiguousarray(solve.basis.reshape(count, -1)),
                 np.ascontiguousarray(solve.hip_loc), np.ascontiguousarray(targets.reshape(count, -1)),
                 np.zeros((count, 0)), part.effectors)
    # The hips' translation is recruited only on frames where the legs alone cannot hold the feet: the
    # body stays on the source's scaled path wherever the legs can take up the difference.
    stage = np.zeros(len(part.part), dtype=np.int32)
    stage[0] = 1
    joints = native.IkJoints(limit_min=solve.limit_min, limit_max=solve.limit_max, excluded=excluded, stage=stage)
    options = native.IkOptions(**{"method": "dls", "max_iterations": 64, "reference": "input", **_SOLVE_OPTIONS},
                               root_translation=hips_move, root_rotation=False, warm_start=False, size=part.size,
                               threads=threads)

    def run():
        solve_started = time.perf_counter()
        try:
            with native_state.blender_frames(frames):
                result = native.ik_solve(*arguments, joints=joints, options=options)
        except ValueError as error:
            # The native message names the effector (foot, bone) and the frame.
            raise ValueError(f"foot cleanup on '{name}': {error}") from None
        report.solve_seconds = time.perf_counter() - solve_started
        return result

    return run


def _solved_channels(part: _SolvePart, solve: _LegSolve, pose, solved, frames, rotations, locations, in_place,
                     name) -> tuple[np.ndarray, np.ndarray]:
    """The solution as the legs' pose-basis rotations and the hips' location channel, written into
    (copies of) rotations and locations."""
    count, hip = frames.size, part.hip
    solved_basis = solved.rotations.reshape(count, len(part.part), 4)
    for shin, roll in solve.rolls.items():
        k = part.local[shin]
        solved_basis[:, k] = _mul(_mul(_about_y(roll), solved_basis[:, k]), _about_y(-roll))
    solved_basis = _mul(_mul(solve.aim[None], solved_basis), _conj(solve.aim)[None])
    q = solved_basis[:, [part.local[b] for b in part.changed]]  # (F, legs' bones, 4), a copy
    q /= np.linalg.norm(q, axis=2, keepdims=True)
    # Keep each bone's hemisphere as the input had it, so that quaternion curves do not flip.
    given = pose.basis.reshape(count, -1, 4)[:, [pose.columns[b] for b in part.changed]]
    q *= np.where(np.einsum("fbk,fbk->fb", q, given) < 0, -1.0, 1.0)[..., None]
    # The hips' move, from the solve's location (in its rest frame) to its own location channel: the
    # channel is applied in the bone's posed frame less its own basis rotation.
    moved = _rotate(np.broadcast_to(solve.rest_q[0], (count, 4)), solved.root_locations - solve.hip_loc)
    hip_basis = rotations[:, 4 * hip:4 * hip + 4]
    frame = _mul(solve.hip_orient, _conj(hip_basis / np.linalg.norm(hip_basis, axis=1, keepdims=True)))
    hip_location = locations[:, 3 * hip:3 * hip + 3] + _rotate(_conj(frame), moved)
    finite = np.isfinite(q).all(axis=(1, 2)) & np.isfinite(hip_location).all(axis=1)  # the only values this changes
    if not finite.all():
        raise ValueError(f"foot cleanup on '{name}': the IK solution is not finite at frame "
                         f"{_blender_frame(frames, np.flatnonzero(~finite)[0])}")
    out_rot = rotations if in_place else rotations.copy()
    out_loc = locations if in_place else locations.copy()
    for k, b in enumerate(part.changed):
        out_rot[:, 4 * b:4 * b + 4] = q[:, k]
    out_loc[:, 3 * hip:3 * hip + 3] = hip_location
    return out_rot, out_loc


# ---------------------------------------------------------------------------
# Fix foot sliding on any armature's action

def _channels(obj, rig: RigData, names, rotations, locations, hip):
    """Channels and values (c, frames) for the changed bones' rotations (each in its rotation mode) and
    the hips' location."""
    channels = [(f"{pose_channels.bone_path(hip)}.location", k, hip) for k in range(3)]
    h = rig.index(hip)
    rows = [locations[:, 3 * h:3 * h + 3].T]
    columns = (4 * np.array([rig.index(name) for name in names], dtype=np.int64)[:, None] + np.arange(4)).ravel()
    bone_channels, values = pose_channels.rotation_keys(obj, names, rotations[:, columns])
    return channels + bone_channels, np.vstack(rows + [values])


def plant(armature, frame_range=None, settings: ContactSettings | None = None, detect: bool = True, *,
          redetect: bool = False, feet=None, fps: float | None = None) -> Report:
    """Fix foot sliding on an armature's action: contacts (the action's contact curves when it has them,
    else detected on the armature itself and stored as curves), cleanup, keys written back into the
    action. Returns a Report.

    frame_range: (start, end) Blender frames: only contacts there are held (the whole action is read and
    its legs keyed on every frame, unchanged outside the range and its blends). detect=False refuses to detect (the
    stored curves must exist); redetect=True detects even when curves exist (and replaces them).
    feet: [Foot L, Foot R] or bone-name tuples, default found by MotionKit's bone map.
    fps: the clip's frame rate, default the action's own (motionkit.bvh.load records the file's), else the
    scene's.
    Everything is computed before anything changes; a ValueError changes nothing.
    """
    obj = armature
    if obj is None or not isinstance(obj, bpy.types.Object) or obj.type != 'ARMATURE':
        raise ValueError(f"'{getattr(obj, 'name', obj)}' is not an armature object")
    action = animdata.assigned_action(obj)
    if action is None:
        raise ValueError(f"'{obj.name}' has no action to clean up")
    if not any(len(fc.keyframe_points) for fc in animdata.fcurves(action, obj)
               if fc.data_path.startswith("pose.bones")):
        raise ValueError(f"'{obj.name}': action '{action.name}' has no keys on its bones")
    feet = _as_feet(feet) if feet is not None else find_feet(obj)
    if fps is None:
        fps = animdata.frame_rate(action)
    # The whole action is read and keyed (write_keys replaces a curve's keys: keying only the range
    # would drop the keys outside it); a frame range limits the contacts instead.
    frames = pose_channels.action_frames(action)
    inside = np.ones(frames.size, dtype=bool)
    if frame_range is not None:
        wanted = pose_channels.action_frames(action, frame_range)
        inside = (frames >= wanted[0]) & (frames <= wanted[-1])
        if not inside.any():
            raise ValueError(f"frame range {wanted[0]:g}..{wanted[-1]:g} is outside action '{action.name}' "
                             f"({frames[0]:g}..{frames[-1]:g})")
    rig = pose_channels.read_rig(obj)
    try:
        rotations = pose_channels.rotations(obj, action, rig.names, frames)
        locations, _ = pose_channels.locations(obj, action, rig.names, frames)  # both refuse values not finite
    except ValueError as error:
        # The message names the bone and frame; say which foot when it is a leg's.
        side = next((f.side for f in feet for b in (f.thigh, f.shin, f.foot, f.toe)
                     if b and f"'{b}'" in str(error)), None)
        if side is None:
            raise
        raise ValueError(f"foot {side}: {error}") from None
    stored = None if redetect else read_contacts(obj, action, feet, frames)
    if stored is None and not detect:
        raise ValueError(f"'{obj.name}': action '{action.name}' has no contact curves and detect=False")
    found = stored if stored is not None else find_contacts(rig, rotations, locations, feet, settings, fps)
    used = found & inside[:, None]
    out_rot, out_loc, report = cleanup(rig, frames, rotations, locations, feet, used, settings, fps=fps)
    report.source = "detected" if stored is None else "curves"
    hip = report.bones[0]
    channels, values = _channels(obj, rig, report.bones[1:], out_rot, out_loc, hip)
    if not np.isfinite(values).all():
        raise ValueError(f"foot cleanup on '{obj.name}': the keys are not finite")
    animdata.write_keys(obj, action, channels, frames, values)
    if stored is None:
        # All the contacts found (outside the range too), so that the animator sees them.
        write_contacts(obj, action, feet, frames, found)
    return report
