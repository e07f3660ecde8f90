"""Full-body IK that looks human (natural defaults), checked in a real Blender with its own evaluation.

On walk60 and on each sample character, with the walk playing under the IK:
- a hand target within 90 % of the arm's reach moves the arm and clavicle only (every other bone keeps
  its turn to the float32 evaluation's floor, the hips stay to a micrometre);
- a target out of reach with both feet pinned: the pins hold to 1e-6 m on every frame, the arm points
  at the target, the centre of mass stays over the feet (never less balanced than the input), no knee
  or elbow bends past straight (further than the input has it);
- a target passing in and out of reach: no popping from frame to frame (the clip's second pass).
Poses are read after frame_set from the depsgraph (pose_bone.matrix), not from the solver.
"""
import importlib
import math

import balance
import bpy
import numpy as np
import pytest
from mathutils import Vector
from rotations import matrix_angles

SUBJECTS = ["walk60", "MixamoT", "RigifyA", "UnrealA"]
FRAMES = (1, 30)


def module(mk, name):
    return importlib.import_module(f"{mk.__name__}.{name}")


def subject(mk, walk60, name):
    """An armature playing a walk, and its bone map."""
    if name == "walk60":
        obj, _ = mk.bvh.load(walk60, name="walker")
    else:
        import characters
        import generate
        spec = getattr(characters, {"MixamoT": "MIXAMO_T", "RigifyA": "RIGIFY_A", "UnrealA": "UNREAL_A"}[name])
        obj = generate.build_armature(spec)
        generate.add_walk(obj, spec, mk.animdata)
    labels = module(mk, "core.bone_mapping").classify(module(mk, "blender.pose_channels").armature_mapping_rig(obj))
    return obj, labels


def evaluate(obj, frames):
    """Per frame, every bone's world head and tail and its basis rotation (depsgraph, after frame_set)."""
    scene = bpy.context.scene
    world = obj.matrix_world
    names = [b.name for b in obj.pose.bones]
    heads, tails, basis = [], [], []
    for f in frames:
        scene.frame_set(int(f))
        heads.append([tuple(world @ b.head) for b in obj.pose.bones])
        tails.append([tuple(world @ b.tail) for b in obj.pose.bones])
        basis.append([tuple(b.matrix_basis.to_quaternion()) for b in obj.pose.bones])
    return names, np.array(heads), np.array(tails), np.array(basis)


def turn_degrees(a, b):
    """The angle between rotations (..., 4) w x y z, in degrees."""
    d = np.abs(np.sum(a * b, axis=-1)) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(2 * np.arccos(np.clip(d, 0.0, 1.0)))


def below(obj, names, tops) -> set:
    """Indices of the named bones and everything under them."""
    out = set()
    for i, name in enumerate(names):
        bone = obj.data.bones[name]
        if bone.name in tops or any(p.name in tops for p in bone.parent_recursive):
            out.add(i)
    return out


def reach(obj, labels, side="L"):
    scale = obj.matrix_world.to_scale()[0]
    return scale * sum(obj.data.bones[labels.limbs[f"{k}.{side}"]].length for k in ("upper_arm", "forearm", "hand"))


def targets_from(obj, labels, names, heads, scale, joints):
    """Targets scale x the arm's reach from the left shoulder, forwards, outwards and up."""
    shoulder = heads[:, names.index(labels.limbs["upper_arm.L"])]
    world = np.array(obj.matrix_world)[:3, :3]
    forward = world @ joints.facing
    left = np.cross([0.0, 0.0, 1.0], forward)
    direction = 0.7 * forward + 0.4 * left + 0.6 * np.array([0.0, 0.0, 1.0])
    direction /= np.linalg.norm(direction)
    return shoulder + scale * reach(obj, labels) * direction, shoulder


def feet(mk, labels):
    return [mk.ik.Effector(labels.limbs["foot.L"], pin=True, orientation=True),
            mk.ik.Effector(labels.limbs["foot.R"], pin=True, orientation=True)]


@pytest.mark.parametrize("pinned", [False, True], ids=["hand alone", "feet pinned, balance off"])
@pytest.mark.parametrize("name", SUBJECTS)
def test_a_target_within_reach_moves_the_arm_and_clavicle_only(mk, walk60, name, pinned):
    """(With the feet pinned and the balance on, a reach that takes the centre of mass past the feet's
    edge moves the hips as well: that is the balance's job, tested below.)"""
    obj, labels = subject(mk, walk60, name)
    joints = mk.ik.natural_defaults(obj)
    assert joints is not None, "the bone map should recognise a humanoid"
    frames = np.arange(FRAMES[0], FRAMES[1] + 1)
    names, heads0, tails0, basis0 = evaluate(obj, frames)
    targets, _ = targets_from(obj, labels, names, heads0, 0.9, joints)
    result = mk.ik.solve(obj, (feet(mk, labels) if pinned else []) +
                         [mk.ik.Effector(labels.limbs["hand.L"], target=targets)], frame_range=FRAMES,
                         balance=False)
    _, heads, tails, basis = evaluate(obj, frames)
    hand = names.index(labels.limbs["hand.L"])
    assert np.linalg.norm(tails[:, hand] - targets, axis=1).max() < 1e-3
    arm = below(obj, names, {labels.limbs[f"{k}.L"] for k in ("shoulder", "upper_arm", "forearm", "hand")
                             if f"{k}.L" in labels.limbs})
    others = [i for i in range(len(names)) if i not in arm]
    turned = turn_degrees(basis[:, others], basis0[:, others])
    worst = np.unravel_index(np.argmax(turned), turned.shape)
    hips = names.index(labels.hips)
    moved = np.linalg.norm(heads[:, hips] - heads0[:, hips], axis=1).max()
    print(f"\n{name}, {'feet pinned' if pinned else 'hand alone'}: within 90% of the reach: largest turn outside the arm {turned.max():.2e} deg "
          f"({names[others[worst[1]]]}), hips moved {1000 * moved:.2e} mm, hand error "
          f"{1000 * np.linalg.norm(tails[:, hand] - targets, axis=1).max():.3f} mm, "
          f"{result.iterations.mean():.1f} iterations a frame")
    # Measured 2.4e-6 degrees on every subject (Blender 3.4): the floor of reading an unmoved bone's turn
    # through float32 quaternions and arccos near 1, not a turn; held to ten times it. The hips do not
    # move at all (0 measured); held to 1e-6 m, ten times Blender's float32 rounding of a head a metre out.
    assert turned.max() <= 2.5e-5
    assert moved <= 1e-6


def hinge_bends(mk, obj, names, basis, joints, bones):
    """Each hinge's bend (radians, positive = flexion) from the basis rotations, by the defaults' axis."""
    order = [b.name for b in module(mk, "blender.pose_channels").depth_first(obj.data)]
    out = {}
    for name in bones:
        j = order.index(name)
        width = joints.limit_max[j] - joints.limit_min[j]
        axis = 0 if width[0] >= width[2] else 2  # the hinge's axis: the swing axis with the range
        sign = 1.0 if joints.limit_max[j, axis] > -joints.limit_min[j, axis] else -1.0
        q = basis[:, names.index(name)]
        w, x, y, z = q.T
        n = np.hypot(w, y)
        flip = np.where(w < 0, -1.0, 1.0)  # as the solver: the twist's w made positive
        tw, ty = flip * w / n, flip * y / n
        swing = np.stack([w * tw + y * ty, x * tw + z * ty, y * tw - w * ty, z * tw - x * ty], axis=1)
        swing *= np.where(swing[:, :1] < 0, -1.0, 1.0)
        angle = 2 * np.arccos(np.clip(swing[:, 0], -1.0, 1.0))
        s = np.sin(angle / 2)
        vector = swing[:, 1:] * np.where(s > 1e-12, angle / np.maximum(s, 1e-12), 2.0)[:, None]
        out[name] = sign * vector[:, axis]
    return out


def support_inside(ik_defaults, heads, tails, names, obj, labels, mass):
    """Per frame: how far the centre of mass lies inside the support polygon of the feet (negative: outside)."""
    feet_bones = below(obj, names, {labels.limbs["foot.L"], labels.limbs["foot.R"]})
    order = [b.name for b in obj.data.bones]
    masses = np.array([mass[order.index(n)] for n in names])
    out = []
    for f in range(len(heads)):
        com = balance.centre_of_mass(heads[f], tails[f], masses)
        points = np.vstack([heads[f, sorted(feet_bones)], tails[f, sorted(feet_bones)]])
        polygon = balance.support_polygon(points)
        side, ahead = balance.plane_axes([0.0, 0.0, 1.0])
        out.append(balance.inside_distance(polygon, [com @ side, com @ ahead]))
    return np.array(out)


@pytest.mark.parametrize("name", SUBJECTS)
def test_out_of_reach_the_pins_hold_the_arm_points_and_the_body_keeps_its_balance(mk, walk60, name):
    obj, labels = subject(mk, walk60, name)
    joints = mk.ik.natural_defaults(obj)
    ik_defaults = module(mk, "core.ik_defaults")
    frames = np.arange(FRAMES[0], FRAMES[1] + 1)
    names, heads0, tails0, basis0 = evaluate(obj, frames)
    targets, _ = targets_from(obj, labels, names, heads0, 1.6, joints)
    plan = mk.ik.plan(obj, feet(mk, labels) + [mk.ik.Effector(labels.limbs["hand.L"], target=targets)], FRAMES)
    assert plan.balance, "balance is on by default with a humanoid's feet pinned"
    mk.ik.apply_keys(plan)
    _, heads, tails, basis = evaluate(obj, frames)
    pins = max(np.linalg.norm(tails[:, names.index(labels.limbs[k])] - tails0[:, names.index(labels.limbs[k])],
                              axis=1).max() for k in ("foot.L", "foot.R"))
    shoulder = heads[:, names.index(labels.limbs["upper_arm.L"])]
    hand = tails[:, names.index(labels.limbs["hand.L"])]
    to_target, to_hand = targets - shoulder, hand - shoulder
    off_line = np.degrees(np.arccos(np.clip(np.sum(to_target * to_hand, axis=1) / (
        np.linalg.norm(to_target, axis=1) * np.linalg.norm(to_hand, axis=1)), -1.0, 1.0)))
    order = [b.name for b in obj.data.bones]
    depth_first = [b.name for b in module(mk, "blender.pose_channels").depth_first(obj.data)]
    mass = np.array([joints.mass[depth_first.index(n)] for n in order])
    inside0 = support_inside(ik_defaults, heads0, tails0, names, obj, labels, mass)
    inside = support_inside(ik_defaults, heads, tails, names, obj, labels, mass)
    hinges = [labels.limbs[f"{k}.{s}"] for k in ("shin", "forearm") for s in "LR"]
    bends0 = hinge_bends(mk, obj, names, basis0, joints, hinges)
    bends = hinge_bends(mk, obj, names, basis, joints, hinges)
    past = max(float(np.max(np.minimum(bends0[h], 0.0) - bends[h])) for h in hinges)
    print(f"\n{name}: out of reach: pins within {pins:.2e} m, hand {np.linalg.norm(hand - targets, axis=1).mean():.3f} m "
          f"short on average, {off_line.max():.2f} deg off the line to the target, centre of mass at least "
          f"{100 * (inside - np.minimum(inside0, 0.0)).min():.2f} cm inside (input {100 * inside0.min():.2f}, "
          f"solved {100 * inside.min():.2f}), hinges past straight beyond the input {math.degrees(past):.4f} deg")
    assert pins <= 1e-6
    assert off_line.max() <= 5.0, np.round(off_line, 1)
    assert np.all(inside >= np.minimum(inside0, 0.0) - 1e-4), np.round(1000 * (inside - np.minimum(inside0, 0.0)), 2)
    assert past <= math.radians(0.05)


# Per subject, the largest amount (degrees) by which a bone's turn from one frame to the next changes faster
# than in the input, measured over nine bakes each of the solver's input as Blender 3.4 and 5.2 evaluate it
# (AMD EPYC; 4.3 evaluates it as 5.2 does, to the same figures): the targets as given and nudged by 1e-12 (six
# ways), 1e-9 and 1e-7. The path is continuous in its input (the nudge test below): walk60, RigifyA and
# UnrealA give one figure everywhere (RigifyA 6.88 nudged by 1e-7), MixamoT 3.59 on 3.4 and 4.13 on 5.2 (3.57
# to 4.05 nudged). The test holds each to the largest plus POP_SLACK. On the three generated characters the
# balance has a share: at frames 30 to 33, as the swinging foot (a pinned foot counts as support) passes the
# standing one, the support polygon's binding edge turns within three frames, and the hips move to keep the
# centre of mass inside (the balance is checked on every frame below); the second pass starts them ahead of
# that move, so that they travel smoothly (with the balance off the sweep pops 2.78 on MixamoT, 2.58 on
# RigifyA, 5.47 on UnrealA). (Before, with the centre of mass computed from stale rotations on the bones no
# unknown turns: walk60 2.23, MixamoT 6.98 to 11.05, RigifyA 5.31, UnrealA 8.51; with it fixed and no lead for
# the hips: 1.34, 6.90 to 13.19, 6.11, 14.37.)
POP_MEASURED = {
    "walk60": 1.34,   # lShoulder 1.903 against the input's 0.563
    "MixamoT": 4.13,  # mixamorig:RightLeg 5.729 against 1.604 on 5.2 (LeftArm 3.59 on 3.4)
    "RigifyA": 6.94,  # upper_arm.L 7.721 against 0.782, frame 32, the arm turning as the target turns back
    "UnrealA": 3.15,  # upperarm_l 3.932 against 0.782
}
POP_SLACK = 0.5


@pytest.mark.parametrize("name", SUBJECTS)
def test_a_target_passing_in_and_out_of_reach_does_not_pop(mk, walk60, name):
    """The target sweeps from 70 % to 140 % of the reach and back over 60 frames, the feet pinned and
    the balance on. A pop is the pose jumping from one frame to the next: a bone's turn between frames
    changing suddenly, beyond what the input's own turn does. What is left is the bend a constraint asks for
    as it takes hold, rounded by the clip's second pass (the arm straightening at the reach limit, the hips
    answering the balance as a pinned walking foot turns the support polygon's edge within a few frames):
    each subject is held to its measured figure (POP_MEASURED) plus POP_SLACK degrees. The balance those
    hips answer holds on every frame (the centre of mass, from Blender's evaluated bones and de Leva's
    masses, never further outside the feet than the input has it), so the pop is not bought by dropping it."""
    obj, labels = subject(mk, walk60, name)
    joints = mk.ik.natural_defaults(obj)
    frames = np.arange(1, 61)
    names, heads0, tails0, basis0 = evaluate(obj, frames)
    scale = 0.7 + 0.7 * np.sin(np.linspace(0.0, np.pi, frames.size))
    near, shoulder = targets_from(obj, labels, names, heads0, 1.0, joints)
    targets = shoulder + (near - shoulder) * scale[:, None]
    mk.ik.solve(obj, feet(mk, labels) + [mk.ik.Effector(labels.limbs["hand.L"], target=targets)],
                frame_range=(1, 60))
    _, heads, tails, basis = evaluate(obj, frames)

    def jerk(q):
        turns = turn_degrees(q[1:], q[:-1])
        return np.abs(np.diff(turns, axis=0)).max(axis=0)

    solved, given = jerk(basis), jerk(basis0)
    worst = int(np.argmax(solved - given))
    order = [b.name for b in obj.data.bones]
    depth_first = [b.name for b in module(mk, "blender.pose_channels").depth_first(obj.data)]
    mass = np.array([joints.mass[depth_first.index(n)] for n in order])
    ik_defaults = module(mk, "core.ik_defaults")
    inside0 = support_inside(ik_defaults, heads0, tails0, names, obj, labels, mass)
    inside = support_inside(ik_defaults, heads, tails, names, obj, labels, mass)
    print(f"\n{name}: target in and out of reach: a bone's turn from frame to frame changes at most "
          f"{solved[worst] - given[worst]:.3f} deg faster than the input's ({names[worst]} {solved[worst]:.3f} "
          f"against {given[worst]:.3f}; held to {POP_MEASURED[name]} + {POP_SLACK}); centre of mass at least "
          f"{100 * (inside - np.minimum(inside0, 0.0)).min():.3f} cm inside where the input allows")
    assert (solved - given).max() <= POP_MEASURED[name] + POP_SLACK
    # 1e-4 m: the solver holds the balance to its tolerance (3e-7 of the rig's size); the rest is this
    # test's own hull and masses against the solver's, as in the out-of-reach test above.
    assert np.all(inside >= np.minimum(inside0, 0.0) - 1e-4), np.round(1000 * (inside - np.minimum(inside0, 0.0)), 2)


def sweep_targets(obj, labels, joints, frames):
    """The sweep's targets: from 70 % to 140 % of the arm's reach and back, from the shoulder."""
    names, heads0, _, _ = evaluate(obj, frames)
    scale = 0.7 + 0.7 * np.sin(np.linspace(0.0, np.pi, frames.size))
    near, shoulder = targets_from(obj, labels, names, heads0, 1.0, joints)
    return shoulder + (near - shoulder) * scale[:, None]


@pytest.mark.parametrize("name", SUBJECTS)
def test_a_sweep_nudged_by_1e_12_bakes_the_same_keys(mk, walk60, animdata, name):
    """The bake's path through the clip is continuous in its input: the sweep above (feet pinned, natural
    defaults) baked again with every target moved by about 1e-12 m three ways, as another processor's
    rounding would move it, keys every channel within 1e-6 of the first bake (the solver stops within
    3e-7 of the rig's size; a choice flipped by the nudge moved keys by up to 0.44 before). Blender keeps
    keys in float32 (a rounding of 6e-8 near 1), so the keys are compared as Blender stores them:
    measured at most 6.0e-8 on Blender 3.4 (walk60 1.5e-8, MixamoT 6.0e-8, RigifyA 3.0e-8, UnrealA 4.7e-10) and
    1.8e-7 on 4.3 and 5.2 (MixamoT's left arm; the others 1.5e-8 or less), a float32 key's last bits (about
    1e-7 over six nudges of the solver's own input, before float32); the bound is the solver's tolerance rather than ten
    times that, as another processor's libm may round a key the other way across several frames' solves.
    With the centre of mass computed from stale rotations again (a trial's pose left with another frame's on
    the bones no unknown turns), walk60's keys part by 2.3e-3, RigifyA's by 2.5e-2 and UnrealA's by 5.1e-3."""
    obj, labels = subject(mk, walk60, name)
    joints = mk.ik.natural_defaults(obj)
    source = animdata.assigned_action(obj)
    targets = sweep_targets(obj, labels, joints, np.arange(1, 61))
    keys = []
    for seed in (None, 36, 1, 2):
        moved = targets if seed is None else targets + 1e-12 * np.random.default_rng(seed).standard_normal(
            targets.shape)
        animdata.assign(obj, source)
        _, action = mk.ik.bake(obj, feet(mk, labels) + [mk.ik.Effector(labels.limbs["hand.L"], target=moved)],
                               (1, 60))
        keys.append({(c.data_path, c.array_index): np.array([k.co[1] for k in c.keyframe_points])
                     for c in animdata.fcurves(action, obj)})
    assert all(k.keys() == keys[0].keys() for k in keys)
    apart = {channel: max(float(np.abs(k[channel] - keys[0][channel]).max()) for k in keys[1:])
             for channel in keys[0]}
    worst = max(apart, key=apart.get)
    print(f"\n{name}'s sweep nudged by 1e-12: keys at most {apart[worst]:.1e} apart ({worst[0]}[{worst[1]}])")
    assert apart[worst] <= 1e-6


def test_a_rig_that_is_not_a_humanoid_gets_no_defaults(mk):
    """A chain of five bones: no bone map, so no stages, limits or balance: the solve with natural "auto"
    poses the chain exactly as natural=False does, both poses applied and read back from Blender's
    evaluation (pose_bone.matrix after a depsgraph update)."""
    arm = bpy.data.armatures.new("chain")
    obj = bpy.data.objects.new("chain", arm)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    parent = None
    for i in range(5):
        bone = arm.edit_bones.new(f"link{i}")
        bone.head, bone.tail = (0, 0, 0.3 * i), (0, 0, 0.3 * (i + 1))
        bone.parent, bone.use_connect = parent, parent is not None
        parent = bone
    bpy.ops.object.mode_set(mode='OBJECT')
    assert mk.ik.natural_defaults(obj) is None
    effectors = [mk.ik.Effector("link4", target=(0.5, 0.0, 1.0))]
    with pytest.raises(ValueError, match="not recognised as a humanoid"):
        mk.ik.plan(obj, effectors, natural=True)

    def posed(natural):
        for pose_bone in obj.pose.bones:
            pose_bone.location, pose_bone.rotation_quaternion = (0, 0, 0), (1, 0, 0, 0)
        plan = mk.ik.plan(obj, effectors, natural=natural)
        mk.ik.apply_pose(plan)
        bpy.context.view_layer.update()
        return plan, np.array([np.array(b.matrix) for b in obj.pose.bones]), tuple(obj.pose.bones["link4"].tail)

    plan, auto, tip = posed("auto")
    assert plan.joints is None and not plan.balance
    _, off, _ = posed(False)
    turn = np.degrees(matrix_angles(auto, off))
    moved = np.linalg.norm(auto[:, :3, 3] - off[:, :3, 3], axis=1)
    print(f"\nnot a humanoid: natural auto against off: bones turned {turn.max():.2e} deg, heads {moved.max():.2e} m "
          f"apart; tip {np.linalg.norm(np.subtract(tip, (0.5, 0.0, 1.0))):.2e} m from the target")
    assert turn.max() < 1e-3 and moved.max() < 1e-6
    assert np.linalg.norm(np.subtract(tip, (0.5, 0.0, 1.0))) < 1e-4


def test_the_defaults_are_editable_through_the_api(mk, walk60):
    obj, labels = subject(mk, walk60, "walk60")
    ik_defaults = module(mk, "core.ik_defaults")
    order = [b.name for b in module(mk, "blender.pose_channels").depth_first(obj.data)]
    knee = order.index(labels.limbs["shin.L"])
    stock = mk.ik.natural_defaults(obj)
    edited = mk.ik.natural_defaults(obj, {"knee_bend": 90.0, "spine_stiffness": 0.8})
    assert np.degrees(np.abs(stock.limit_max[knee] - stock.limit_min[knee]).max()) == pytest.approx(150.0)
    assert np.degrees(np.abs(edited.limit_max[knee] - edited.limit_min[knee]).max()) == pytest.approx(90.0)
    spine = order.index(labels.spine[0])
    assert edited.stiffness[spine, 0] == pytest.approx(0.8) and stock.stiffness[spine, 0] == pytest.approx(0.3)
    assert stock.stage[spine] == 1 and stock.stage[order.index(labels.hips)] == 2
    assert stock.stage[order.index(labels.limbs["forearm.L"])] == 0
    with pytest.raises(ValueError, match="unknown natural-default settings"):
        ik_defaults.NaturalDefaults.from_dict({"knee": 1.0})
