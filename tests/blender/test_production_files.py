"""Retargeting the files people bring: real Mixamo FBX clips through Blender's own importers, fingers, feet
on each rig's own floor whatever the armature's origin, scale, rotation or parent, facing-less captures from
Blender's BVH importer, FBX and glTF sources, twist bones, and bad files.

Every figure is read back through Blender's own evaluation (frame_set, matrix_world @ pose_bone.head/tail,
pose_bone.matrix), never the retargeting code's own numbers.
"""
import math
import os

import bpy
import numpy as np
import pytest
from mathutils import Matrix

import characters
import generate
import stances
from rotations import matrix_angles

FINGERS = ("Thumb", "Index", "Middle", "Ring", "Pinky")
# Directions and twists, joint to joint through Blender's evaluation: measured on Blender 3.4, 4.3, 5.2 at
# most 0.0006 deg for the fingers (the punch onto Y Bot, two-bone fingers, Rigify's DEF phalanges) and
# 0.0013 deg for arms, hands and fingers with automatic bone orientation or from an FBX file Blender wrote
# (0.0025 deg from 4.3's and 5.2's glTF exporter): the float32 pose matrices of bones a few centimetres long.
FINGER_DEG = 0.005
FBX_DEG = 0.01


@pytest.fixture(scope="session")
def fbx_dir(shared_dir):
    path = os.path.join(shared_dir, "data", "fbx")
    if not os.path.isfile(os.path.join(path, "ybot@punch.fbx")):
        if os.environ.get("CI") == "true":
            pytest.fail(f"{path} has no Mixamo FBX files, and CI=true requires them")
        pytest.skip(f"{path} has no Mixamo FBX files")
    return path


def import_fbx(path, **options):
    """Blender's own FBX importer: the armature it brings (scaled 0.01, turned 90 degrees about X), without
    the skinned meshes it brings too (remove_skins; the tests export armatures alone)."""
    before = set(bpy.data.objects)
    bpy.ops.import_scene.fbx(filepath=path, **options)
    armature = next(o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE')
    remove_skins()
    return armature


def remove_skins():
    """Removes every mesh an armature deforms (the bones' rest and axes came from their bind pose at import):
    these tests read bones only, and each frame_set would deform the meshes again for nothing (most of the
    tests' time)."""
    for obj in list(bpy.data.objects):
        if obj.type == 'MESH' and any(m.type == 'ARMATURE' for m in obj.modifiers):
            mesh = obj.data
            bpy.data.objects.remove(obj)
            if mesh.users == 0:
                bpy.data.meshes.remove(mesh)


def rename_prefix(obj, old, new):
    for bone in obj.data.bones:
        if bone.name.startswith(old):
            bone.name = new + bone.name[len(old):]


def phalanges(prefix, side="Left", count=3):
    return [f"{prefix}{side}Hand{finger}{k}" for finger in FINGERS for k in range(1, count + 1)]


def world_axes(obj, names, frames):
    """World Y axes (frames, bones, 3) and X axes of pose bones, by the depsgraph."""
    ys, xs = [], []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        world = obj.matrix_world.to_3x3()
        m = [world @ obj.pose.bones[n].matrix.to_3x3() for n in names]
        ys.append([tuple(a.col[1].normalized()) for a in m])
        xs.append([tuple(a.col[0].normalized()) for a in m])
    return np.array(ys), np.array(xs)


def limb_directions(obj, names, frames):
    """World directions (frames, bones, 3) from each bone's head to the head of the child that carries the
    most bones (a finger's next phalanx, its end bone for the last; a leaf's own tail): where the limb points,
    whatever the rig's bone axes are (an FBX import without automatic bone orientation), by the depsgraph."""
    def child(bone):
        kids = [c for c in bone.children if (c.head_local - bone.head_local).length > 1e-6]
        return max(kids, key=lambda c: (len(c.children_recursive), c.name)).name if kids else None

    ends = {n: child(obj.data.bones[n]) for n in names}
    out = []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        world = obj.matrix_world
        row = []
        for n in names:
            head = world @ obj.pose.bones[n].head
            end = world @ (obj.pose.bones[ends[n]].head if ends[n] else obj.pose.bones[n].tail)
            row.append(tuple((end - head).normalized()))
        out.append(row)
    return np.array(out)


def angles_deg(a, b):
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1)))


def palm_frames(obj, hand, frames):
    """World frames (frames, 3, 3) of a hand read from its joints, whatever its bone axes: Y from the wrist
    to the middle finger's first knuckle, X across the palm from the little finger's to the index's."""
    prefix = hand[:-len("LeftHand")] if hand.endswith("LeftHand") else hand[:-len("RightHand")]
    side = hand[len(prefix):-len("Hand")]
    out = []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        head = {n: np.array(obj.matrix_world @ obj.pose.bones[f"{prefix}{side}Hand{n}"].head, dtype=np.float64)
                for n in ("Middle1", "Index1", "Pinky1")}  # float64: newer mathutils hands numpy float32
        wrist = np.array(obj.matrix_world @ obj.pose.bones[hand].head, dtype=np.float64)
        y = head["Middle1"] - wrist
        y /= np.linalg.norm(y)
        x = head["Index1"] - head["Pinky1"]
        x -= y * x.dot(y)
        x /= np.linalg.norm(x)
        out.append(np.stack([x, y, np.cross(x, y)], axis=1))
    return np.array(out)


def worst_palm_deg(source, target, frames, prefix="mixamorig:"):
    """The largest turn (degrees) between the source's and the target's palms, either hand, any frame."""
    return max(frame_angles_deg(palm_frames(source, f"{prefix}{side}Hand", frames),
                                palm_frames(target, f"{prefix}{side}Hand", frames)).max()
               for side in ("Left", "Right"))


def frame_angles_deg(a, b):
    """Angle (degrees) of the turn between rotation matrices, elementwise over the leading axes (accurate
    near 0, where arccos of the trace loses half the digits)."""
    return np.degrees(matrix_angles(a, b))


def frames_of(action):
    first, last = (int(round(v)) for v in action.frame_range)
    return np.arange(first, last + 1)


# ---------------------------------------------------------------------------
# Fingers

@pytest.mark.parametrize("prefix", ["mixamorig:", "mixamorig6:", ""])
def test_mixamo_fingers_follow_the_source_on_every_frame(mk, fbx_dir, prefix):
    """The punch (Blender's FBX importer) onto Y Bot with the target's names under another prefix: all 30
    phalanges are paired, and each points within 1 degree of the source's, its twist following: the fist
    closes."""
    target = import_fbx(os.path.join(fbx_dir, "ybot.fbx"))
    rename_prefix(target, "mixamorig:", prefix)
    action = mk.retarget(os.path.join(fbx_dir, "ybot@punch.fbx"), target, imported_source="keep")
    remove_skins()
    source = next(o for o in bpy.data.objects if o.type == 'ARMATURE' and o is not target)
    pairs = dict(mk.retargeting.auto_map(source, target))
    fingers = [n for side in ("Left", "Right") for n in phalanges("mixamorig:", side)]
    assert all(pairs.get(n) == prefix + n[len("mixamorig:"):] for n in fingers), pairs
    frames = frames_of(action)
    src_y = limb_directions(source, fingers, frames)
    tgt_y = limb_directions(target, [pairs[n] for n in fingers], frames)
    worst = angles_deg(src_y, tgt_y).max()
    # The twist: each phalanx's X axis against the source's, both turned from the match poses (the rest).
    _, src_x = world_axes(source, fingers, frames)
    _, tgt_x = world_axes(target, [pairs[n] for n in fingers], frames)
    twist = np.abs(angles_deg(src_x, tgt_x) - angles_deg(src_x[:1], tgt_x[:1])).max()
    print(f"\nfingers ({prefix or 'no prefix'}): direction {worst:.6f} deg, twist {twist:.6f} deg")
    assert worst < FINGER_DEG and twist < FINGER_DEG
    # The punch closes the fist: the index's last phalanx turns as far from the hand's line as the source's.
    hand_y = limb_directions(target, [prefix + "LeftHand"], frames)
    source_hand_y = limb_directions(source, ["mixamorig:LeftHand"], frames)
    tip = fingers.index("mixamorig:LeftHandIndex3")
    curl = angles_deg(hand_y[:, 0], tgt_y[:, tip])
    assert curl.max() > 40.0 and np.abs(curl - angles_deg(source_hand_y[:, 0], src_y[:, tip])).max() < FINGER_DEG


def _keep_fingers(obj, keep, drop_last=False):
    """Deletes finger bones in Edit Mode: every finger not in keep, and with drop_last each finger's third
    phalanx (its end bone then hangs from the second)."""
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    bones = obj.data.edit_bones
    for bone in list(bones):
        name = bone.name.split(":")[-1]
        finger = next((f for f in FINGERS if f"Hand{f}" in name), None)
        if finger is None:
            continue
        if finger not in keep or (drop_last and name.endswith("3")):
            bones.remove(bone)
    bpy.ops.object.mode_set(mode='OBJECT')


def test_two_bone_fingers_and_a_hand_with_thumb_and_index_only(mk, fbx_dir):
    """3 -> 2 bones a finger (first with first, last with last) and a hand with only a thumb and an index:
    each target phalanx points within 1 degree of the source bone it is paired with."""
    target = import_fbx(os.path.join(fbx_dir, "ybot.fbx"))
    _keep_fingers(target, keep=("Thumb", "Index"), drop_last=True)
    action = mk.retarget(os.path.join(fbx_dir, "ybot@punch.fbx"), target, imported_source="keep")
    remove_skins()
    source = next(o for o in bpy.data.objects if o.type == 'ARMATURE' and o is not target)
    pairs = dict(mk.retargeting.auto_map(source, target))
    for side in ("Left", "Right"):
        for finger in ("Thumb", "Index"):
            first, last = (f"mixamorig:{side}Hand{finger}{k}" for k in (1, 3))
            assert pairs[first] == first and pairs[last] == f"mixamorig:{side}Hand{finger}2", pairs
        assert not [s for s in pairs if "Middle" in s or "Ring" in s or "Pinky" in s]
    frames = frames_of(action)
    sources = [s for s in pairs if "Thumb" in s or "Index" in s]
    src_y = limb_directions(source, sources, frames)
    tgt_y = limb_directions(target, [pairs[s] for s in sources], frames)
    worst = angles_deg(src_y, tgt_y).max()
    print(f"\ntwo-bone fingers: worst {worst:.6f} deg")
    assert worst < FINGER_DEG


# ---------------------------------------------------------------------------
# Feet on each rig's own floor

def _feet(mk, obj):
    return mk.contacts.find_feet(obj)


def _rest_floor(obj, feet):
    """The lowest world Z of the feet's bones (and all below them) at rest."""
    world, z = obj.matrix_world, []
    for foot in feet:
        stack = [obj.data.bones[foot.foot]]
        while stack:
            bone = stack.pop()
            stack += list(bone.children)
            z += [(world @ bone.head_local).z, (world @ bone.tail_local).z]
    return min(z)


def _rest_joints(obj, feet):
    """The lowest world Z of the feet's ankles (heads) and balls (the toe's head) at rest: the joints a
    standing foot stands on, which a heel bone or a toe's tip can lie below (_rest_floor's)."""
    world, z = obj.matrix_world, []
    for foot in feet:
        bone = obj.data.bones[foot.foot]
        ball = obj.data.bones[foot.toe].head_local if foot.toe else bone.tail_local
        z += [(world @ bone.head_local).z, (world @ ball).z]
    return min(z)


def _lowest(obj, feet, frames):
    """(frames, 2) the lowest world Z of each foot's ankle (head) and ball (the toe's head), and (frames, 2,
    3) the ankles, by the depsgraph."""
    low, ankles = [], []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        world = obj.matrix_world
        row, at = [], []
        for foot in feet:
            bone = obj.pose.bones[foot.foot]
            head = world @ bone.head
            ball = world @ (obj.pose.bones[foot.toe].head if foot.toe else bone.tail)  # the foot's tail need not
            row.append(min(head.z, ball.z))                                            # lie at the ball
            at.append(tuple(head))
        low.append(row)
        ankles.append(at)
    return np.array(low), np.array(ankles)


def _stance(low, ankles, leg, fps):
    """Where a foot stands, by the tests' own rule (stances.stance), not the product's contact detector."""
    return stances.stance(low, ankles, leg, fps)


def _world_leg(obj, feet):
    scale = obj.matrix_world.to_scale()[0]
    return scale * float(np.mean([obj.data.bones[f.thigh].length + obj.data.bones[f.shin].length for f in feet]))


def _move_origin_to_hips(mk, obj):
    hips = obj.data.bones[mk.bone_mapping.classify(mk.pose_channels.armature_mapping_rig(obj)).hips].head_local.copy()
    obj.data.transform(Matrix.Translation(-hips))
    obj.matrix_world = obj.matrix_world @ Matrix.Translation(hips)


def _as_fbx_leaves_it(obj):
    """Centimetres in the armature, the object scaled 0.01 and turned 90 degrees about X: the same world."""
    obj.data.transform(Matrix.Rotation(-math.pi / 2, 4, 'X') @ Matrix.Scale(100.0, 4))
    obj.matrix_world = obj.matrix_world @ Matrix.Rotation(math.pi / 2, 4, 'X') @ Matrix.Scale(0.01, 4)


def _parented(obj):
    parent = bpy.data.objects.new("Mover", None)
    bpy.context.scene.collection.objects.link(parent)
    parent.location = (0.3, -0.2, 0.5)
    parent.rotation_euler = (0.0, 0.0, 0.4)
    bpy.context.view_layer.update()
    world = obj.matrix_world.copy()
    obj.parent = parent
    obj.matrix_world = world
    # The character stands on the ground wherever its parent is: its rest soles are the floor either way.


VARIANTS = {"plain": lambda mk, obj: None, "origin at hips": _move_origin_to_hips,
            "FBX scale and turn": lambda mk, obj: _as_fbx_leaves_it(obj), "parented": lambda mk, obj: _parented(obj)}


# A foot's lowest point on the source's stance frames against where the source's stands, scaled by the leg
# ratio, in legs: measured on Blender 3.4, 4.3, 5.2 over every placement, planted or not (the long tier), and
# the kick; about ten times that.
FLOOR_ERROR = 1e-5  # measured 9e-7 at most (the kick onto an FBX-like rig; walk60 5e-7)
FLOOR_BELOW = 1e-6  # and how far below the floor (or the source's scaled height) any foot may come (1e-7)


def test_feet_stand_on_the_floor(mk, walk60):
    """The representative placement: centimetres in the armature, the object scaled and turned as an FBX
    import leaves it (every placement, planted and not: tests/long/test_production_files_long.py)."""
    check_feet_on_the_floor(mk, walk60, "FBX scale and turn", True)


def check_feet_on_the_floor(mk, walk60, variant, plant):
    """walk60 onto RigifyA (another rig's proportions) placed as VARIANTS[variant] says: on the source's
    stance frames (stances.stance, the tests' own rule) each target foot's lowest point stands where the
    source's does above its floor, scaled by the leg ratio, within FLOOR_ERROR of the leg; no foot ever
    lower than that allows."""
    source, _ = mk.bvh.load(walk60)
    target = generate.build_armature(characters.RIGIFY_A)
    VARIANTS[variant](mk, target)
    bpy.context.view_layer.update()
    plan = mk.retargeting.plan(source, target, plant_feet=plant)
    mk.retargeting.apply(plan)
    frames = plan.frames
    src_feet, tgt_feet = _feet(mk, source), _feet(mk, target)
    src_low, src_ankles = _lowest(source, src_feet, frames)
    tgt_low, _ = _lowest(target, tgt_feet, frames)
    # walk60's capture floor; the rig's rest soles: a standing foot's lowest joint stands as high above the
    # floor as at rest (the sample's ball joints ride 2.5 cm above the floor it was built on).
    src_floor, tgt_floor = 0.0, _rest_floor(target, tgt_feet)
    leg = _world_leg(target, tgt_feet)
    ratio = plan.path_scale * target.matrix_world.to_scale()[0] / source.matrix_world.to_scale()[0]
    wanted = tgt_floor + ratio * (src_low - src_floor)
    stance = _stance(src_low, src_ankles, _world_leg(source, src_feet), 60.0)
    error = np.abs(tgt_low - wanted)[stance] / leg
    hover = np.median((tgt_low - tgt_floor)[stance]) * 1000
    print(f"\n{variant}, planted {plant}: stance error median {100 * np.median(error):.5f} %, worst "
          f"{100 * error.max():.5f} % of the leg ({stance.sum()} foot-frames); lowest point above the floor "
          f"(median) {hover:.1f} mm")
    assert stance.sum() > 100
    assert error.max() < FLOOR_ERROR
    below = (tgt_low - np.minimum(wanted, tgt_floor)).min() / leg
    print(f"lowest below the floor or the source's height {100 * below:.5f} % of the leg")
    assert below > -FLOOR_BELOW


@pytest.mark.parametrize("planted", [False, True], ids=["not planted", "planted"])
def test_fbx_clip_onto_an_fbx_character_whose_origin_is_at_its_hips(mk, fbx_dir, planted):
    """The kick (FBX) onto MixamoT turned into an FBX-like rig with its origin at the hips: feet at the
    source's heights above the floor, scaled by the leg ratio, on the source's stance frames (the tests' own
    rule; FLOOR_ERROR of the leg), not a leg length in the air."""
    target = generate.build_armature(characters.MIXAMO_T)
    _move_origin_to_hips(mk, target)
    _as_fbx_leaves_it(target)
    bpy.context.view_layer.update()
    mk.retarget(os.path.join(fbx_dir, "ybot@kick.fbx"), target, imported_source="keep")
    remove_skins()
    source = next(o for o in bpy.data.objects if o.type == 'ARMATURE' and o is not target)
    frames = frames_of(target.animation_data.action)
    src_feet, tgt_feet = _feet(mk, source), _feet(mk, target)
    if not planted:
        mk.retarget(source, target, plant_feet=False)
    src_low, src_ankles = _lowest(source, src_feet, frames)
    # The source's stance frames by the tests' own rule (stances.stance), not the retarget's contacts.
    stance = _stance(src_low, src_ankles, _world_leg(source, src_feet),
                     mk.animdata.frame_rate(source.animation_data.action))
    tgt_low, _ = _lowest(target, tgt_feet, frames)
    src_floor, tgt_floor = _rest_floor(source, src_feet), _rest_floor(target, tgt_feet)
    leg = _world_leg(target, tgt_feet)
    # The leg ratio as docs/retargeting.md defines it (along the legs), in world units.
    ratio = mk.retargeting.plan(source, target, plant_feet=False).path_scale * \
        target.matrix_world.to_scale()[0] / source.matrix_world.to_scale()[0]
    assert stance.sum() > 10
    above = (tgt_low - tgt_floor)[stance] / leg
    source_above = ratio * (src_low - src_floor)[stance] / leg
    print(f"\nkick onto an FBX-like MixamoT (planted {planted}): worst {100 * np.abs(above - source_above).max():.5f} "
          f"% of the leg off; stance feet above the floor {100 * np.median(above):.2f} % of the leg "
          f"(the source's {100 * np.median(source_above):.2f} %)")
    assert np.abs(above - source_above).max() < FLOOR_ERROR


# A child as the source (../shared/data/fbx/child: Mixamo's `mixamorig6:` character, its ankles 26 % of its leg
# above its soles where an adult's stand 10 %), onto Y Bot through Blender's FBX importer. Measured on Blender
# 3.4: on the Kip Up's stance frames (the tests' own rule) Y Bot's feet stand where the child's stand, scaled,
# 0.03 % of the leg off at the median and 1.25 % on the worst frame (the first of a contact, eased in); the
# in-place walk, whose sliding feet make no stance frames by that rule, brings no foot below the floor by more
# than 0.5 % of the leg on any frame (the child's own feet come 0.7 % below theirs). Bounds at about twice
# those: a floor misread by the ankles' height is a fifth of a leg off.
CHILD_STANCE_MEDIAN, CHILD_STANCE_WORST, CHILD_BELOW = 0.002, 0.025, 0.01


@pytest.mark.parametrize("clip", ["Kip Up", "Standard Walk"])
def test_a_child_as_the_source_stands_an_adult_on_its_floor(mk, fbx_dir, clip):
    target = import_fbx(os.path.join(fbx_dir, "ybot.fbx"))
    mk.retarget(os.path.join(fbx_dir, "child", f"Ch09_nonPBR@{clip}.fbx"), target, imported_source="keep")
    source = next(o for o in bpy.data.objects if o.type == 'ARMATURE' and o is not target)
    frames = frames_of(target.animation_data.action)
    src_feet, tgt_feet = _feet(mk, source), _feet(mk, target)
    src_low, src_ankles = _lowest(source, src_feet, frames)
    tgt_low, _ = _lowest(target, tgt_feet, frames)
    src_floor, tgt_floor = _rest_floor(source, src_feet), _rest_floor(target, tgt_feet)
    leg, src_leg = _world_leg(target, tgt_feet), _world_leg(source, src_feet)
    stance = _stance(src_low, src_ankles, src_leg, mk.animdata.frame_rate(source.animation_data.action))
    off = np.abs((tgt_low - tgt_floor) - leg / src_leg * (src_low - src_floor))[stance] / leg
    below = (tgt_low.min(axis=1) - tgt_floor).min() / leg
    print(f"\nthe child's {clip} onto Y Bot: {stance.sum()} stance foot-frames, off {100 * (np.median(off) if off.size else 0.0):.2f} "
          f"% of the leg (median), {100 * off.max(initial=0):.2f} % (worst); lowest {100 * below:.2f} % of the leg "
          f"above the floor (the child's own {100 * (src_low.min() - src_floor) / src_leg:.2f} %)")
    assert below > -CHILD_BELOW
    if clip == "Kip Up":
        assert stance.sum() > 20
        assert np.median(off) < CHILD_STANCE_MEDIAN and off.max() < CHILD_STANCE_WORST
    for obj in (source, target):
        bpy.data.objects.remove(obj)


# ---------------------------------------------------------------------------
# Facing from the motion, FBX and glTF sources

@pytest.mark.skipif(bpy.app.version < (4, 0, 0),
                    reason="Blender 3.4's own BVH importer cannot run on its Python 3.11 (open(..., 'rU'))")
def test_a_capture_from_blenders_bvh_importer_with_a_zero_pose_faces_as_it_walks(mk, shared_dir):
    """The Bandai Namco dash (every offset along one axis at rest) through File > Import > BVH, onto MixamoT
    with the defaults: every mapped bone's world direction (joint to joint) is the source's (no quarter
    turn)."""
    bpy.ops.import_anim.bvh(filepath=os.path.join(shared_dir, "data", "bvh", "more", "bandai_dash_normal_001.bvh"),
                            global_scale=0.01)
    source = bpy.context.view_layer.objects.active
    target = generate.build_armature(characters.MIXAMO_T)
    action = mk.retarget(source, target, floor_fit="hips", plant_feet=False)  # these move the legs on purpose
    # Joint to joint: the bones with one child on both rigs (hips and chest branch; a toe's end differs).
    pairs = [(s, t) for s, t in mk.retargeting.auto_map(source, target)
             if len(source.data.bones[s].children) == 1 and len(target.data.bones[t].children) == 1]
    assert len(pairs) >= 12
    frames = frames_of(action)
    src_y = limb_directions(source, [s for s, _ in pairs], frames)
    tgt_y = limb_directions(target, [t for _, t in pairs], frames)
    per_bone = angles_deg(src_y, tgt_y).max(axis=0)
    worst = per_bone.max()
    print(f"\nBandai dash via Blender's BVH importer: worst direction {worst:.3f} deg "
          f"({pairs[int(per_bone.argmax())]})")
    assert worst < 0.1


def _export(kind, path, objects, animated=True):
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj in objects)
    bpy.context.view_layer.objects.active = objects[0]
    if kind == "glb":
        bpy.ops.export_scene.gltf(filepath=path, use_selection=True, export_format='GLB',
                                  export_animations=animated)
    else:  # only the assigned action: with every action, the file's first take is Y Bot's own 2-frame one
        bpy.ops.export_scene.fbx(filepath=path, use_selection=True, bake_anim_use_all_actions=False,
                                 bake_anim_use_nla_strips=False)


@pytest.mark.parametrize("kind", ["fbx", "glb"])
def test_fbx_and_gltf_files_are_sources(mk, fbx_dir, tmp_path, kind):
    """Y Bot playing the punch, written by Blender's FBX or glTF exporter and given to retarget() as a path:
    the target's fingers and arms follow the file's armature (as Blender imports it again), and
    imported_source="remove" leaves nothing of the file behind."""
    # Y Bot (its T-pose rest and bone axes come from its skin's bind pose) playing the punch, written out.
    clip = import_fbx(os.path.join(fbx_dir, "ybot@punch.fbx"))
    character = import_fbx(os.path.join(fbx_dir, "ybot.fbx"))
    character.animation_data_create()
    character.animation_data.action = clip.animation_data.action
    for action in list(bpy.data.actions):  # the exporters would write Y Bot's own still take too
        if action is not clip.animation_data.action:
            bpy.data.actions.remove(action)
    path = str(tmp_path / f"punch.{kind}")
    _export(kind, path, [character])
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    target = import_fbx(os.path.join(fbx_dir, "ybot.fbx"))
    before = {kind_: {i.name for i in getattr(bpy.data, kind_)} for kind_ in ("objects", "armatures", "meshes")}
    action = mk.retarget(path, target, imported_source="keep")
    remove_skins()
    source = next(o for o in bpy.data.objects if o.type == 'ARMATURE' and o is not target)
    pairs = [(s, t) for s, t in mk.retargeting.auto_map(source, target) if "Hand" in t or "Arm" in t]
    assert len(pairs) >= 32
    frames = frames_of(action)[::3]
    assert len(frames) >= 20  # the punch itself, not a still take
    src_y = limb_directions(source, [s for s, _ in pairs], frames)
    tgt_y = limb_directions(target, [t for _, t in pairs], frames)
    per_bone = angles_deg(src_y, tgt_y).max(axis=0)
    # The exporter writes the rest as the pose it finds (not a T-pose) with bone axes of its own: the hands'
    # turn about their own line comes from where the fingers spread, and the palms must face as the source's.
    palms = worst_palm_deg(source, target, frames)
    print(f"\npunch as .{kind}: worst arm, hand or finger direction {per_bone.max():.6f} deg "
          f"({pairs[int(per_bone.argmax())]}), palms {palms:.6f} deg")
    assert per_bone.max() < FBX_DEG and palms < FBX_DEG
    for obj in list(bpy.data.objects):
        if obj is not target and obj.name not in before["objects"]:
            bpy.data.objects.remove(obj)
    kept = {kind_: sorted(i.name for i in getattr(bpy.data, kind_)) for kind_ in before}
    mk.retarget(path, target, imported_source="remove")
    assert {kind_: sorted(i.name for i in getattr(bpy.data, kind_)) for kind_ in before} == kept


@pytest.mark.parametrize("source_oriented,target_oriented", [(True, True), (False, True), (True, False)])
def test_fbx_imports_with_automatic_bone_orientation(mk, fbx_dir, source_oriented, target_oriented):
    """Blender's FBX importer with automatic bone orientation on (bones laid along their limbs, rolls of
    its own) for the punch, for Y Bot or both: every mapped bone with a next joint points within 1 degree of
    the source's, fingers included, and the palms face as the source's."""
    source = import_fbx(os.path.join(fbx_dir, "ybot@punch.fbx"), automatic_bone_orientation=source_oriented)
    target = import_fbx(os.path.join(fbx_dir, "ybot.fbx"), automatic_bone_orientation=target_oriented)
    action = mk.retarget(source, target, floor_fit="hips", plant_feet=False)  # no leg moved on purpose
    pairs = [(s, t) for s, t in mk.retargeting.auto_map(source, target)
             if any((c.head_local - source.data.bones[s].head_local).length > 1e-6
                    for c in source.data.bones[s].children)]
    assert len(pairs) >= 50
    frames = frames_of(action)[::2]
    per_bone = angles_deg(limb_directions(source, [s for s, _ in pairs], frames),
                          limb_directions(target, [t for _, t in pairs], frames)).max(axis=0)
    palms = worst_palm_deg(source, target, frames)
    print(f"\nautomatic bone orientation source {source_oriented}, target {target_oriented}: worst direction "
          f"{per_bone.max():.6f} deg ({pairs[int(per_bone.argmax())]}), palms {palms:.6f} deg")
    assert per_bone.max() < FBX_DEG and palms < FBX_DEG


def test_bad_files_say_what_is_wrong_and_change_nothing(mk, fbx_dir, tmp_path):
    """An FBX with no armature and a glTF whose armature has no animation: a ValueError naming the file,
    and the scene as it was."""
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.active_object
    no_armature = str(tmp_path / "cube.fbx")
    _export("fbx", no_armature, [cube])
    still = import_fbx(os.path.join(fbx_dir, "ybot.fbx"))
    still_path = str(tmp_path / "still.glb")
    _export("glb", still_path, [still], animated=False)
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    target = generate.build_armature(characters.MIXAMO_T)
    names = lambda: {k: sorted(i.name for i in getattr(bpy.data, k))  # noqa: E731
                     for k in ("objects", "armatures", "meshes", "actions", "materials")}
    before = names()
    with pytest.raises(ValueError, match=r"cube\.fbx.*no armature"):
        mk.retarget(no_armature, target)
    assert names() == before
    with pytest.raises(ValueError, match=r"still\.glb.*no animation"):
        mk.retarget(still_path, target)
    assert names() == before
    with pytest.raises(ValueError, match="imported_source"):
        mk.retarget(still_path, target, imported_source="bin")
    assert names() == before


def test_the_old_option_name_still_works(mk, walk60):
    target = generate.build_armature(characters.MIXAMO_T)
    mk.retarget(walk60, target, plant_feet=False, bvh_source="remove")
    assert [o.name for o in bpy.data.objects] == [target.name]
    with pytest.raises(ValueError, match="say different things"):
        mk.retarget(walk60, target, bvh_source="remove", imported_source="keep")


# ---------------------------------------------------------------------------
# Twist bones

def _with_twist_bones(obj):
    """UnrealA with Unreal's twist leaves: upperarm_twist_01 near the shoulder, lowerarm_twist_01 near the
    wrist, each along its limb."""
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    bones = obj.data.edit_bones
    made = {}
    for side in ("l", "r"):
        for limb, name, at in ((f"upperarm_{side}", f"upperarm_twist_01_{side}", 0.1),
                               (f"lowerarm_{side}", f"lowerarm_twist_01_{side}", 0.8)):
            parent = bones[limb]
            bone = bones.new(name)
            axis = parent.tail - parent.head
            bone.head = parent.head + at * axis
            bone.tail = bone.head + 0.15 * axis
            bone.roll = parent.roll
            bone.parent = parent
            made[name] = (limb, at)
    bpy.ops.object.mode_set(mode='OBJECT')
    return made


def _twist_about(m_child, m_parent, axis_local):
    """The turn (rad) of m_child relative to m_parent (3x3 world) about the parent's local axis."""
    q = (m_parent.transposed() @ m_child).to_quaternion()
    angle = 2 * math.atan2(np.dot([q.x, q.y, q.z], axis_local), q.w)
    return (angle + math.pi) % (2 * math.pi) - math.pi


def test_twist_bones_share_their_limbs_twist(mk, walk60):
    """Each leaf twist bone turns about its limb's axis by its share of the limb's twist: near the shoulder
    the upper arm's twist is undone (fully at the joint, none at the elbow); near the wrist the forearm's
    twist bone takes the hand's twist by how far along it lies. Measured on Blender's pose matrices."""
    source, _ = mk.bvh.load(walk60)
    target = generate.build_armature(characters.UNREAL_A)
    made = _with_twist_bones(target)
    action = mk.retarget(source, target, plant_feet=False)
    body = mk.bone_mapping.classify(mk.pose_channels.armature_mapping_rig(target))
    assert set(body.twists) == set(made)
    rest = {n: target.data.bones[n].matrix_local.to_3x3() for n in target.data.bones.keys()}
    worst, turned = 0.0, 0.0
    for frame in frames_of(action)[::7]:
        bpy.context.scene.frame_set(int(frame))
        pose = {n: target.pose.bones[n].matrix.to_3x3() for n in target.pose.bones.keys()}
        for name, (limb, at) in made.items():
            parent = target.data.bones[limb].parent.name
            hand = "hand_" + limb[-1]
            # The limb's own twist (its local turn about Y against its rest under its posed parent), and the
            # hand's against the forearm.
            limb_twist = _twist_about(pose[limb], pose[parent] @ rest[parent].transposed() @ rest[limb], [0, 1, 0])
            hand_twist = _twist_about(pose[hand], pose[limb] @ rest[limb].transposed() @ rest[hand], [0, 1, 0])
            wanted = -(1 - at) * limb_twist if limb.startswith("upperarm") else at * hand_twist
            got = _twist_about(pose[name], pose[limb] @ rest[limb].transposed() @ rest[name], [0, 1, 0])
            worst = max(worst, abs(math.remainder(got - wanted, 2 * math.pi)))
            turned = max(turned, abs(got))
    print(f"\ntwist bones: worst {math.degrees(worst):.4f} deg off their share (largest turn "
          f"{math.degrees(turned):.1f} deg)")
    assert turned > math.radians(2)
    assert worst < math.radians(0.1)


def test_a_linked_rig_is_refused_with_what_to_do_and_an_override_works(mk, walk60, tmp_path):
    """A target linked from another .blend without a library override: a ValueError that says it is linked
    and how to make it editable, nothing changed; once overridden it takes the retarget."""
    rig = generate.build_armature(characters.MIXAMO_T)
    library = str(tmp_path / "rig.blend")
    bpy.data.libraries.write(library, {rig, rig.data})
    bpy.data.objects.remove(rig)
    with bpy.data.libraries.load(library, link=True) as (data_from, data_to):
        data_to.objects = [n for n in data_from.objects if n == "MixamoT"]
    linked = data_to.objects[0]
    bpy.context.scene.collection.objects.link(linked)
    source, _ = mk.bvh.load(walk60)
    actions = set(bpy.data.actions)
    with pytest.raises(ValueError, match=r"linked from the library .*library override"):
        mk.retarget(source, linked, plant_feet=False)
    assert set(bpy.data.actions) == actions and linked.animation_data is None
    overridden = linked.override_create(remap_local_usages=True)
    action = mk.retarget(source, overridden, plant_feet=False)
    assert overridden.animation_data.action == action


def test_rigify_finger_controls_are_keyed_and_its_fingers_close_the_fist(mk, fbx_dir):
    """The punch (FBX) onto a rig Rigify generates: its finger FK controls are keyed (no master or curl
    control), and after Blender evaluates the rig every DEF phalanx points within 1 degree of the source's
    (joint to joint) on every frame."""
    import rigify_rig
    rig = rigify_rig.generate()[0]
    before = set(bpy.data.objects)
    action = mk.retarget(os.path.join(fbx_dir, "ybot@punch.fbx"), rig, imported_source="keep")
    remove_skins()
    source = next(o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE')
    skeleton = mk.control_rigs.deform_rig(rig, mk.control_rigs.find_map(rig))
    pairs = [(a, b) for a, b in mk.retargeting.auto_map(source, skeleton) if "Hand" in a and not a.endswith("Hand")]
    assert len(pairs) == 30 and all(b.startswith("DEF-") for _, b in pairs)
    keyed = {fc.data_path.split('"')[1] for fc in mk.animdata.fcurves(action, rig)
             if fc.data_path.startswith("pose.bones")}
    assert {"thumb.01.L", "f_index.02.R", "f_pinky.03.L"} <= keyed
    assert not [k for k in keyed if "master" in k or k.startswith(("DEF-", "MCH-", "ORG-"))]
    frames = frames_of(action)
    src_y = limb_directions(source, [a for a, _ in pairs], frames)
    tgt_y, _ = world_axes(rig, [b for _, b in pairs], frames)
    worst = angles_deg(src_y, tgt_y).max()
    print(f"\nRigify fingers from the punch: worst {worst:.6f} deg")
    assert worst < FINGER_DEG


def test_planting_feet_on_a_target_without_feet_says_so(mk, walk60):
    """A target without feet (legs that end at the knee's shin, as a character in a long robe): asking for
    planted feet is a ValueError that names the target and what it lacks, with nothing changed; the defaults
    retarget it without planting."""
    target = generate.build_armature(characters.MIXAMO_T)
    bpy.context.view_layer.objects.active = target
    bpy.ops.object.mode_set(mode='EDIT')
    for bone in list(target.data.edit_bones):
        if "Foot" in bone.name or "Toe" in bone.name:
            target.data.edit_bones.remove(bone)
    bpy.ops.object.mode_set(mode='OBJECT')
    source, _ = mk.bvh.load(walk60)
    actions = sorted(a.name for a in bpy.data.actions)
    with pytest.raises(ValueError, match=r"plant_feet: the target has no feet to plant \(foot L: 'MixamoT' has no "
                                         r"foot bone"):
        mk.retarget(source, target, plant_feet=True)
    assert sorted(a.name for a in bpy.data.actions) == actions and target.animation_data is None
    action = mk.retarget(source, target)
    assert target.animation_data.action == action
