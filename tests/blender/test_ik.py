"""motionkit.ik in a real Blender, checked with Blender's own evaluation (depsgraph pose matrices).

The brief's lab checks on walk60's skeleton (simple, hard through the root,
the clip, the bonus), joint limits, Blender's own IK constraint as a peer,
live re-solving, the operators, and bad input.
"""
import math
import os

import bpy
import numpy as np
import pytest
from mathutils import Vector
from walker import still_walker
from rotations import quaternion_angles

LAB_TOLERANCE = 0.01  # metres, the brief's pass mark
REACHED = 1e-4  # metres: a reachable target met, in Blender's own evaluation
# Degrees: the elbow's largest turn between frames beyond the input's own, measured 18.8 (19.9 against the
# input's 1.1) over the clip's first frames, where the arm swings about the shoulder-wrist line as the solve
# leaves the input pose; after them it stays within 8.1.
ELBOW_STEP_BEYOND_INPUT = 19.5


@pytest.fixture()
def ik(mk):
    return mk.ik


def tail(obj, bone):
    bpy.context.view_layer.update()
    return obj.matrix_world @ obj.pose.bones[bone].tail


def empty(name, location):
    obj = bpy.data.objects.new(name, None)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.update()
    return obj


def test_lab_simple_root_fixed_wrist_to_a_target(mk, ik, walk60):
    obj = still_walker(mk, walk60)
    start = tail(obj, "lWrist")
    target = start + Vector((-0.25, -0.2, 0.3))
    result = mk.ik.solve(obj, [ik.Effector("lWrist", target=tuple(target))], root_translation=False,
                         root_rotation=False)
    assert (tail(obj, "lWrist") - target).length < REACHED
    assert result.errors.max() < 1e-4
    assert obj.pose.bones["RootJoint"].rotation_quaternion.angle < 1e-9  # the root stayed


@pytest.mark.parametrize("balance, natural", [(None, "auto"), (False, "auto"), (False, False)],
                         ids=["balance", "no balance", "plain"])
def test_lab_hard_toe_fixed_through_the_root(mk, ik, walk60, balance, natural):
    obj = still_walker(mk, walk60)
    toe = tail(obj, "lToeJoint")
    # Low and forward: the body must bend. Without the balance the target is reached; with it (on by
    # default with a pinned foot) the centre of mass may not leave the toe's support, which keeps the hand
    # short by a distance the posture decides (measured below).
    target = tail(obj, "lWrist") + Vector((0.1, -0.3, -0.6))
    mk.ik.solve(obj, [ik.Effector("lToeJoint", pin=True, orientation=True),
                      ik.Effector("lWrist", target=tuple(target))], balance=balance, natural=natural)
    short = (tail(obj, "lWrist") - target).length
    print(f"\nbalance {balance}, natural {natural}: the hand {short * 1e3:.4f} mm from the target, the toe "
          f"{(tail(obj, 'lToeJoint') - toe).length * 1e6:.4f} um from its pin")
    assert short < LAB_TOLERANCE  # the brief's pass mark
    # Plain, the target is reached: 0.1 um measured, held to ten times that. With natural defaults the
    # ranges (and the balance) leave the hand short by what the posture they allow reaches: measured
    # 2.781 mm without the balance and 5.833 mm with it (Blender 3.4), held to that plus 10 um, ten
    # times what a single frame's solve moves under a 1e-12 nudge of its input or Blender's float32
    # rounding of a pose a metre out (both below a micrometre).
    assert short < {"plain": 1e-6, "no balance": 2.781e-3 + 1e-5, "balance": 5.833e-3 + 1e-5}[
        "plain" if natural is False else "balance" if balance is None else "no balance"]
    assert (tail(obj, "lToeJoint") - toe).length < 1e-6  # measured 0.07 um
    assert obj.pose.bones["RootJoint"].location.length > 0.01  # the hips moved


def test_lab_clip_wrist_held_while_the_body_plays(mk, ik, walk60):
    obj, action = mk.bvh.load(walk60, name="clip")
    scene = bpy.context.scene
    frames = np.arange(1, 183)
    roots, legs = [], []
    for f in frames:
        scene.frame_set(int(f))
        roots.append(tuple(obj.matrix_world @ obj.pose.bones["RootJoint"].head))
        legs.append(tuple(obj.matrix_world @ obj.pose.bones["rToeJoint"].tail))
    roots = np.array(roots)
    elbow_input = elbow_rotations(obj, frames)
    # The left wrist 1.3 m up and 0.25 m to the root's left and 0.3 m ahead of it.
    targets = np.column_stack([roots[:, 0] + 0.25, roots[:, 1] - 0.3, np.full(len(frames), 1.3)])
    result = mk.ik.solve(obj, [ik.Effector("lWrist", target=targets)], frame_range=(1, 182),
                         root_translation=False, root_rotation=False)
    assert result.errors.max() < 1e-4
    worst = legs_moved = 0.0
    for i, f in enumerate(frames):
        scene.frame_set(int(f))
        worst = max(worst, (tail(obj, "lWrist") - Vector(targets[i])).length)
        legs_moved = max(legs_moved, (tail(obj, "rToeJoint") - Vector(legs[i])).length)
    assert worst < REACHED
    assert legs_moved < 1e-5  # the rest of the body still plays the clip
    # Warm starts: no popping between frames on the solved arm. The elbow's turn from one frame to the next
    # (Blender's evaluation) against the input's own: the target rides with the walking root, so the arm
    # moves about as much as the walk moves it.
    elbow = elbow_rotations(obj, frames)
    solved = quaternion_angles(elbow[1:], elbow[:-1])
    given = quaternion_angles(elbow_input[1:], elbow_input[:-1])
    print(f"\nelbow's largest turn between frames: solved {np.degrees(solved.max()):.3f} deg, "
          f"input {np.degrees(given.max()):.3f} deg")
    assert np.degrees(solved.max() - given.max()) <= ELBOW_STEP_BEYOND_INPUT


def elbow_rotations(obj, frames):
    """The left elbow's basis rotation (frames, 4) w x y z, as Blender evaluates it on each frame."""
    out = []
    for f in frames:
        bpy.context.scene.frame_set(int(f))
        out.append(tuple(obj.pose.bones["lElbow"].matrix_basis.to_quaternion()))
    return np.array(out)


def test_lab_bonus_both_hands_left_foot_fixed(mk, ik, walk60):
    obj = still_walker(mk, walk60)
    foot = tail(obj, "lToeJoint")
    left = tail(obj, "lWrist") + Vector((-0.3, -0.35, -0.2))
    right = tail(obj, "rWrist") + Vector((0.2, -0.4, 0.25))
    mk.ik.solve(obj, [ik.Effector("lToeJoint", pin=True, orientation=True),
                      ik.Effector("lWrist", target=tuple(left)), ik.Effector("rWrist", target=tuple(right))])
    assert (tail(obj, "lWrist") - left).length < REACHED
    assert (tail(obj, "rWrist") - right).length < REACHED
    assert (tail(obj, "lToeJoint") - foot).length < 1e-4


def swing_twist(q):
    """Blender pose quaternion -> (swing x, twist y, swing z) as ik.hpp defines the limits."""
    w, x, y, z = q
    twist = 2.0 * math.atan2(y, w)
    ct, st = math.cos(twist / 2), math.sin(twist / 2)
    # swing = q * twist^-1
    sw, sx, _, sz = w * ct + y * st, x * ct - z * st, y * ct - w * st, z * ct + x * st
    if sw < 0:
        sw, sx, sz = -sw, -sx, -sz
    angle = 2.0 * math.atan2(math.hypot(sx, sz), sw)
    norm = math.hypot(sx, sz)
    return (angle * sx / norm if norm > 1e-12 else 0.0, (twist + math.pi) % (2 * math.pi) - math.pi,
            angle * sz / norm if norm > 1e-12 else 0.0)


def test_joint_limits_hold_on_random_targets(mk, ik, walk60):
    obj = still_walker(mk, walk60)
    limited = ("lShoulder", "lElbow", "lWrist", "pelvis_lowerback", "lowerback_torso")
    for name in limited:
        pb = obj.pose.bones[name]
        pb.use_ik_limit_x = pb.use_ik_limit_z = True
        pb.ik_min_x, pb.ik_max_x = math.radians(-30), math.radians(40)
        pb.ik_min_z, pb.ik_max_z = math.radians(-50), math.radians(20)
        pb.lock_ik_y = True
    rng = np.random.default_rng(5)
    start = tail(obj, "lWrist")
    for _ in range(20):
        target = start + Vector(rng.uniform(-0.6, 0.6, 3))
        mk.ik.solve(obj, [ik.Effector("lWrist", target=tuple(target))], root_translation=False, root_rotation=False)
        for name in limited:
            x, y, z = swing_twist(tuple(obj.pose.bones[name].rotation_quaternion))
            assert math.radians(-30) - 1e-6 <= x <= math.radians(40) + 1e-6, (name, x)
            assert math.radians(-50) - 1e-6 <= z <= math.radians(20) + 1e-6, (name, z)
            assert abs(y) < 1e-6, (name, y)


@pytest.mark.parametrize("offset", [(-0.25, -0.2, 0.3), (0.1, -0.5, -0.4), (-2.0, -1.0, 1.0)],
                         ids=["reachable", "low", "unreachable"])
def test_residual_no_larger_than_blenders_ik_constraint(mk, ik, walk60, offset):
    obj = still_walker(mk, walk60)
    goal = empty("Goal", tail(obj, "lWrist") + Vector(offset))
    constraint = obj.pose.bones["lWrist"].constraints.new('IK')
    constraint.target = goal
    constraint.chain_count = 4  # lWrist, lElbow, lShoulder, lTorso_Clavicle
    bpy.context.view_layer.update()
    theirs = (tail(obj, "lWrist") - goal.location).length
    obj.pose.bones["lWrist"].constraints.remove(constraint)
    bpy.context.view_layer.update()
    # Blender's constraint knows no natural defaults (joint ranges, stages): the solvers alone are compared.
    mk.ik.solve(obj, [ik.Effector("lWrist", target=goal, chain_count=4)], root_translation=False,
                root_rotation=False, natural=False)
    ours = (tail(obj, "lWrist") - goal.location).length
    assert obj.pose.bones["lowerback_torso"].rotation_quaternion.angle < 1e-9  # the same four bones only
    print(f"\n{offset}: Blender's IK constraint {theirs:.2e} m, MotionKit {ours:.2e} m")
    assert ours <= theirs + 1e-6


def test_live_mode_follows_a_moving_target(mk, ik, walk60):
    obj = still_walker(mk, walk60)
    goal = empty("Goal", tail(obj, "lWrist") + Vector((-0.2, -0.2, 0.2)))
    item = obj.motionkit_ik.effectors.add()
    item.bone, item.target = "lWrist", goal
    obj.motionkit_ik.root_translation = obj.motionkit_ik.root_rotation = False
    obj.motionkit_ik.live = True
    try:
        bpy.context.view_layer.update()
        assert (tail(obj, "lWrist") - goal.location).length < 1e-3
        goal.location += Vector((0.05, -0.1, 0.1))
        bpy.context.view_layer.update()
        assert (tail(obj, "lWrist") - goal.location).length < 1e-3
    finally:
        obj.motionkit_ik.live = False


def test_operators_solve_bake_and_cancel_on_errors(mk, ik, walk60):
    obj, action = mk.bvh.load(walk60, name="baked")
    bpy.context.view_layer.objects.active = obj
    settings = obj.motionkit_ik
    assert not bpy.ops.motionkit.ik_solve.poll()
    bad = settings.effectors.add()
    bad.bone = "no such bone"
    bad.pin = True
    actions = set(bpy.data.actions)
    with pytest.raises(RuntimeError, match="no such bone"):
        bpy.ops.motionkit.ik_bake()
    assert set(bpy.data.actions) == actions and obj.animation_data.action == action
    bad.bone = "lToeJoint"
    hand = settings.effectors.add()
    goal = empty("Goal", (0.3, -0.4, 1.4))
    hand.bone, hand.target = "lWrist", goal
    settings.use_scene_range = False
    settings.frame_start, settings.frame_end = 1, 40
    # The goal is reached only by leaning further than the pinned toe's balance and a person's joint ranges
    # allow: this test is about the operators, on the solver as it stands without them.
    settings.balance, settings.natural = 'OFF', 'OFF'
    scene = bpy.context.scene
    toes = {}
    for frame in (5, 20, 40):
        scene.frame_set(frame)
        toes[frame] = tail(obj, "lToeJoint")
    assert bpy.ops.motionkit.ik_bake() == {'FINISHED'}
    baked = obj.animation_data.action
    assert baked != action and action.use_fake_user
    # Blender's own evaluation of the baked keys: the hand on the goal, the pinned toe where it was.
    for frame in (5, 20, 40):
        scene.frame_set(frame)
        assert (tail(obj, "lWrist") - goal.location).length < 1e-4, frame
        assert (tail(obj, "lToeJoint") - toes[frame]).length < 1e-4, frame
    goal.location = (0.2, -0.3, 1.3)
    bpy.context.view_layer.update()
    assert bpy.ops.motionkit.ik_solve() == {'FINISHED'}
    bpy.context.view_layer.update()
    assert (tail(obj, "lWrist") - goal.location).length < 1e-4
    # The effector list through the generic list operator: add selects the new row, remove the active one.
    assert bpy.ops.motionkit.list_edit(list="ik_effectors", action='ADD') == {'FINISHED'}
    assert len(settings.effectors) == 3 and settings.active_effector == 2
    settings.active_effector = 0
    assert bpy.ops.motionkit.list_edit(list="ik_effectors", action='REMOVE') == {'FINISHED'}
    assert [e.bone for e in settings.effectors] == ["lWrist", ""] and settings.active_effector == 0


def test_a_bake_that_fails_leaves_no_copy(mk, ik, walk60, animdata):
    """The new action is copied while the native solve runs; when the solve refuses its input, or the
    clip is refused before it, the copy goes again and the armature plays what it played."""
    obj, action = mk.bvh.load(walk60, name="broken")
    effectors = [ik.Effector("lWrist", target=(0.3, -0.4, 1.4))]
    actions = set(bpy.data.actions)
    with pytest.raises(ValueError, match="damping must be finite and >= 0"):  # only the native job checks it
        ik.bake(obj, effectors, (1, 40), new_action=True, damping=-1.0)
    assert set(bpy.data.actions) == actions and obj.animation_data.action == action
    path = 'pose.bones["lWrist"].rotation_quaternion'
    for k in range(4):
        points = animdata.find_fcurve(action, obj, path, k).keyframe_points
        points[9].co = (points[9].co[0], 0.0)
    with pytest.raises(ValueError, match="bone 'lWrist' rotation is zero or not finite at frame 10"):
        ik.bake(obj, effectors, (1, 40), new_action=True)
    assert set(bpy.data.actions) == actions and obj.animation_data.action == action


def test_bad_input_names_the_effector_and_changes_nothing(mk, ik, walk60):
    obj = still_walker(mk, walk60)
    before = [tuple(pb.rotation_quaternion) for pb in obj.pose.bones]
    with pytest.raises(ValueError, match="effector on 'lWrist'"):
        mk.ik.solve(obj, [ik.Effector("lWrist", target=(float("nan"), 0.0, 1.0))])
    with pytest.raises(ValueError, match="no target"):
        mk.ik.solve(obj, [ik.Effector("lWrist")])
    with pytest.raises(ValueError, match="unknown IK method"):
        mk.ik.solve(obj, [ik.Effector("lWrist", pin=True)], method="magic")
    assert [tuple(pb.rotation_quaternion) for pb in obj.pose.bones] == before


@pytest.mark.parametrize("root_moves", [False, True], ids=["root still", "root animated"])
def test_a_game_rig_with_a_floor_root_solves_below_it(mk, ik, root_moves):
    """UnrealA: root on the floor above pelvis, the walk's translation on pelvis. Feet pinned, a hand up to
    targets; the solve works in the floor root's posed frame (animated or not) and never moves it."""
    import characters
    import generate
    spec = characters.UNREAL_A
    obj = generate.build_armature(spec)
    action = generate.add_walk(obj, spec, mk.animdata)
    frames = np.arange(1, 31)
    if root_moves:  # the root carried forward and turning, as extracted root motion would be
        turn = np.radians(np.linspace(0, 30, frames.size))
        values = np.vstack([np.cos(turn / 2), 0 * turn, 0 * turn, np.sin(turn / 2),
                            np.zeros_like(turn), -0.02 * frames, np.zeros_like(turn)])
        mk.animdata.write_keys(obj, action, [('pose.bones["root"].rotation_quaternion', k) for k in range(4)]
                               + [('pose.bones["root"].location', k) for k in range(3)], frames.astype(float),
                               values)
    scene = bpy.context.scene
    root_before, hips = [], []
    for f in frames:
        scene.frame_set(int(f))
        root_before.append(tuple(obj.pose.bones["root"].matrix.col[3])[:3])
        hips.append(tuple(obj.matrix_world @ obj.pose.bones[spec.canonical["hips"]].head))
    targets = np.array(hips) + (0.3, -0.15, 0.55)
    result = mk.ik.solve(obj, [ik.Effector(spec.canonical["foot.L"], pin=True),
                               ik.Effector(spec.canonical["foot.R"], pin=True),
                               ik.Effector(spec.canonical["hand.L"], target=targets)], frame_range=(1, 30))
    assert result.errors.max() < 1e-4
    assert "root" not in result.bones
    for i, f in enumerate(frames):
        scene.frame_set(int(f))
        assert (tail(obj, spec.canonical["hand.L"]) - Vector(targets[i])).length < 1e-3
        assert np.abs(np.array(obj.pose.bones["root"].matrix.col[3])[:3] - root_before[i]).max() < 1e-6


def test_live_survives_saving_and_opening_the_file(mk, walk60, tmp_path):
    """Saved with Live on and opened again (Blender drops non-persistent handlers on load), moving the target
    still re-solves: the toggle never shows on over a dead handler. Run in a Blender of its own, since
    opening a file replaces everything this session's other tests hold."""
    import subprocess
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    script = os.path.join(root, "tests", "blender", "sessions", "live_after_reload.py")
    cmd = [bpy.app.binary_path, "--background", "--factory-startup", "--python-exit-code", "1", "--python", script,
           "--", os.environ["MOTIONKIT_ZIP"], walk60, str(tmp_path / "live.blend")]
    import conftest
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=conftest.fresh_blender_env(tmp_path))
    report = dict(line.split()[1:3] for line in out.stdout.splitlines() if line.startswith("LIVE "))
    assert out.returncode == 0 and len(report) == 3, out.stdout[-3000:] + out.stderr[-3000:]
    assert float(report["before-save"]) < 1e-3
    assert report["toggle-after-open"] == "True"
    assert float(report["after-open"]) < 1e-3, report


def keys_of(animdata, obj, action):
    """Every key of the action: {(data_path, index): co values}, to see that nothing changed."""
    out = {}
    for fcurve in animdata.fcurves(action, obj):
        co = np.empty(2 * len(fcurve.keyframe_points))
        fcurve.keyframe_points.foreach_get("co", co)
        out[fcurve.data_path, fcurve.array_index] = co
    return out


def unchanged(animdata, obj, actions, action, keys, pose):
    assert set(bpy.data.actions) == actions and obj.animation_data.action == action
    after = keys_of(animdata, obj, action)
    assert after.keys() == keys.keys()
    for channel, co in keys.items():
        np.testing.assert_array_equal(after[channel], co, err_msg=str(channel))
    assert [tuple(pb.rotation_quaternion) for pb in obj.pose.bones] == pose


def test_no_effectors_are_refused_and_change_nothing(mk, ik, walk60, animdata):
    obj, action = mk.bvh.load(walk60, name="none")
    actions, keys = set(bpy.data.actions), keys_of(animdata, obj, action)
    pose = [tuple(pb.rotation_quaternion) for pb in obj.pose.bones]
    for frame_range in (None, (1, 20)):
        with pytest.raises(ValueError, match="no effectors: give at least one bone and target"):
            ik.solve(obj, [], frame_range)
    unchanged(animdata, obj, actions, action, keys, pose)


def test_a_constrained_bone_is_refused_by_name_and_changes_nothing(mk, ik, walk60, animdata):
    """The solve poses bones by their channels alone: a working constraint on a bone it reads or keys is
    named (bone and constraint); a muted one, or one on a bone the solve does not see, is left alone."""
    obj, action = mk.bvh.load(walk60, name="constrained")
    effectors = [ik.Effector("lWrist", target=(0.3, -0.4, 1.4))]
    copy = obj.pose.bones["lElbow"].constraints.new('COPY_ROTATION')
    copy.name = "Follow"
    actions, keys = set(bpy.data.actions), keys_of(animdata, obj, action)
    pose = [tuple(pb.rotation_quaternion) for pb in obj.pose.bones]
    for frame_range in (None, (1, 20)):
        with pytest.raises(ValueError, match=r"bone 'lElbow' of 'constrained' has the constraint 'Follow' "
                                             r"\(COPY_ROTATION\)"):
            ik.solve(obj, effectors, frame_range)
    unchanged(animdata, obj, actions, action, keys, pose)
    copy.influence = 0.0
    ik.solve(obj, effectors, (1, 5))  # no influence: nothing to refuse
    animdata.assign(obj, action)
    copy.influence = 1.0
    if hasattr(copy, "enabled"):
        copy.enabled = False
    else:
        copy.mute = True
    ik.solve(obj, effectors, (1, 5))
    animdata.assign(obj, action)
    copy.mute = False
    if hasattr(copy, "enabled"):
        copy.enabled = True
    obj.pose.bones["lElbow"].constraints.remove(copy)
    # A constraint on a bone the solve neither reads nor keys (the right hand, for a left-hand target
    # without balance) is left alone.
    obj.pose.bones["rWrist"].constraints.new('COPY_ROTATION')
    ik.solve(obj, effectors, (1, 5), balance=False)


@pytest.mark.parametrize("channel, index, frame, message", [
    ('pose.bones["lElbow"].rotation_quaternion', 2, 10,
     r"bone 'lElbow' has a key that is not finite on rotation_quaternion\[2\] at frame 10"),
    ('pose.bones["RootJoint"].location', 1, 12,
     r"bone 'RootJoint' has a key that is not finite on location\[1\] at frame 12"),
], ids=["rotation", "root location"])
def test_nan_keys_in_the_source_are_named_by_bone_and_frame(mk, ik, walk60, animdata, channel, index, frame,
                                                           message):
    obj, action = mk.bvh.load(walk60, name="nan")
    fcurve = animdata.find_fcurve(action, obj, channel, index)
    point = next(p for p in fcurve.keyframe_points if p.co[0] == frame)
    point.co = (point.co[0], float("nan"))
    fcurve.update()
    actions, keys = set(bpy.data.actions), keys_of(animdata, obj, action)
    pose = [tuple(pb.rotation_quaternion) for pb in obj.pose.bones]
    for new_action in (True, False):
        with pytest.raises(ValueError, match=message):
            ik.solve(obj, [ik.Effector("lWrist", target=(0.3, -0.4, 1.4))], (1, 20), new_action=new_action)
    unchanged(animdata, obj, actions, action, keys, pose)
