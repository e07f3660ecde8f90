"""Blender's side of the measure against Mixamo's own retargets (san_protocol.py holds the measure):
the paired clips of ../shared/data/pairs imported with Blender's own importers, joints as Blender
evaluates them (frame_set, then each pose bone's head through the object's matrix_world), and the two
ways of retargeting that are not MotionKit's: the plain rotation copy and Blender's constraints + bake.
Used by bench/mixamo_pairs.py and tests/blender/test_mixamo_pairs.py."""
from __future__ import annotations

import builtins
import time
import os

import bpy
import numpy as np

import made_characters as made
import san_protocol as sp

SAN_CHARACTERS = ("Aj", "Kaya")
SAN_CLIPS = ("Jumping", "Running", "Catwalk Walk", "Getting Up")
FBX_CHARACTERS = ("girl1", "girl2")
FBX_CLIPS = ("Right Strafe Walk", "Left Strafe Walk", "Happy Walk Backward")

# import_anim.bvh's default axes (forward -Z, up Y) turn a file's (x, y, z) into Blender's (x, -z, y);
# the centimetre files are imported in metres.
BVH_TO_BLENDER = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
BVH_SCALE = 0.01
CONSTRAINT_WAYS = ("world", "local")


def pairs_dir(shared: str) -> str:
    return os.path.join(shared, "data", "pairs")


def san_path(shared: str, character: str, clip: str) -> str:
    return os.path.join(pairs_dir(shared), "san", character, clip + ".bvh")


def fbx_path(shared: str, character: str, clip: str) -> str:
    return os.path.join(pairs_dir(shared), "fbx", character, clip + ".fbx")


def _new_armature(before, path: str) -> bpy.types.Object:
    made = [o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE']
    if len(made) != 1:
        raise RuntimeError(f"{path}: the import made {len(made)} armatures, one expected")
    return made[0]


def import_bvh(path: str) -> bpy.types.Object:
    """The file's armature and clip through bpy.ops.import_anim.bvh (frame 1 = the file's first frame).
    3.4's importer opens its file with mode 'rU', which its Python 3.11 refuses; its module is given an
    open() that drops the 'U' (universal newlines are Python 3's default): the importer is unchanged. The
    scene is set to factory settings' 24 frames a second first: the importer records no rate, so the clip
    plays at the scene's, and a retarget's contacts and blends follow it (whatever an earlier test left)."""
    import io_anim_bvh.import_bvh as importer
    bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = 24, 1.0
    importer.open = lambda file, mode="r", *args, **kw: builtins.open(file, mode.replace("U", ""), *args, **kw)
    before = set(bpy.data.objects)
    result = bpy.ops.import_anim.bvh(filepath=path, global_scale=BVH_SCALE, frame_start=1, use_fps_scale=False,
                                     update_scene_fps=False, update_scene_duration=False)
    if result != {'FINISHED'}:
        raise RuntimeError(f"{path}: import_anim.bvh returned {result}")
    return _new_armature(before, path)


def import_fbx(path: str) -> bpy.types.Object:
    before = set(bpy.data.objects)
    bpy.ops.import_scene.fbx(filepath=path)
    arm = _new_armature(before, path)
    for obj in [o for o in bpy.data.objects if o not in before and o is not arm]:
        bpy.data.objects.remove(obj)  # the meshes: nothing measured, only slower frames
    return arm


def rest_copy(obj: bpy.types.Object, name: str) -> bpy.types.Object:
    """A fresh copy of the armature at rest: its own data, no animation, every pose channel cleared."""
    copy = obj.copy()
    copy.data = obj.data.copy()
    copy.name = name
    copy.animation_data_clear()
    bpy.context.scene.collection.objects.link(copy)
    for pose_bone in copy.pose.bones:
        pose_bone.location = (0.0, 0.0, 0.0)
        pose_bone.rotation_quaternion = (1.0, 0.0, 0.0, 0.0)
        pose_bone.rotation_euler = (0.0, 0.0, 0.0)
        pose_bone.scale = (1.0, 1.0, 1.0)
    return copy


def joints_world(obj, names, frames) -> np.ndarray:
    """(frames, joints, 3): each named pose bone's head in world space, as Blender evaluates the frame."""
    scene = bpy.context.scene
    bones = [obj.pose.bones[n] for n in names]
    out = np.empty((len(frames), len(bones), 3))
    for i, frame in enumerate(frames):
        scene.frame_set(int(frame))
        world = np.array(obj.matrix_world)
        heads = np.array([tuple(b.head) for b in bones])
        out[i] = heads @ world[:3, :3].T + world[:3, 3]
    return out


def bvh_to_blender(positions) -> np.ndarray:
    """Positions in a BVH file's space and units as import_bvh places them in Blender's world."""
    return BVH_SCALE * np.asarray(positions) @ BVH_TO_BLENDER.T


def armature_rotations(obj, names, frames) -> np.ndarray:
    """(frames, joints, 3, 3): each named bone's world orientation's turn from its rest, as Blender
    evaluates the frame (object matrix x pose_bone.matrix x rest matrix inverse, scale removed)."""
    scene = bpy.context.scene
    bones = [obj.pose.bones[n] for n in names]
    rest = np.array([np.array(b.bone.matrix_local)[:3, :3] for b in bones])
    out = np.empty((len(frames), len(bones), 3, 3))
    for i, frame in enumerate(frames):
        scene.frame_set(int(frame))
        world = np.array(obj.matrix_world)[:3, :3]
        world = world / np.cbrt(np.linalg.det(world))
        posed = np.array([np.array(b.matrix)[:3, :3] for b in bones])
        u, _, vt = np.linalg.svd(posed)  # a bone's own scale keys are no turn
        delta = (u @ vt) @ np.transpose(rest, (0, 2, 1))
        out[i] = world @ delta @ world.T
    return out


def constraint_way(source, target, pairs, hips, variant: str, frame_end: int) -> None:
    """Blender's own way onto target (a rest copy): on every paired target bone a COPY_ROTATION from its
    source bone (mix Replace, influence 1), target and owner space both World ("world": the bone turned
    to the source's orientation) or both Local ("local": the source's turn from its own rest applied
    from the target's rest, the usual offset recipe); COPY_LOCATION World -> World on the hips (hips =
    (source bone, target bone)); then nla.bake of frames 1..frame_end with visual keying, constraints
    cleared, pose only (location and rotation where the bake asks which channels)."""
    space = {"world": 'WORLD', "local": 'LOCAL'}[variant]
    layer = bpy.context.view_layer
    for other in layer.objects:
        other.select_set(other == target)
    layer.objects.active = target
    bpy.ops.object.mode_set(mode='POSE')
    for src, tgt in pairs:
        con = target.pose.bones[tgt].constraints.new('COPY_ROTATION')
        con.target, con.subtarget = source, src
        con.target_space = con.owner_space = space
    con = target.pose.bones[hips[1]].constraints.new('COPY_LOCATION')
    con.target, con.subtarget = source, hips[0]
    con.target_space = con.owner_space = 'WORLD'
    options = dict(frame_start=1, frame_end=frame_end, only_selected=False, visual_keying=True,
                   clear_constraints=True, use_current_action=False, bake_types={'POSE'})
    if "channel_types" in bpy.ops.nla.bake.get_rna_type().properties:
        options["channel_types"] = {'LOCATION', 'ROTATION'}
    result = bpy.ops.nla.bake(**options)
    bpy.ops.object.mode_set(mode='OBJECT')
    if result != {'FINISHED'}:
        raise RuntimeError(f"nla.bake returned {result}")


def world_plain_copy(source, target, pairs, hips, frames) -> dict[str, np.ndarray]:
    """The plain copy where the two skeletons differ (names, bone orientations): each paired target
    bone turned by its source bone's world-space turn from rest (armature space carried through each
    object's orientation), a bone without a pair by its parent's, the hips' path
    the source's world path times the ratio of the hip heights (rest hips above the lowest rest joint,
    world up; both clips stand on world z = 0), as san_protocol.plain_copy does with the files' paths;
    forward kinematics over the target's rest heads. Returns {bone name: (frames, 3)} in world."""
    deltas = armature_rotations(source, [s for s, _ in pairs], frames)
    by_target = {t: k for k, (_, t) in enumerate(pairs)}

    def rest_heads(obj):
        world = np.array(obj.matrix_world)
        return {b.name: world[:3, :3] @ np.array(b.head_local) + world[:3, 3] for b in obj.data.bones}

    src_rest, tgt_rest = rest_heads(source), rest_heads(target)
    src_path = joints_world(source, [hips[0]], frames)[:, 0]
    ratio = ((tgt_rest[hips[1]][2] - min(p[2] for p in tgt_rest.values()))
             / (src_rest[hips[0]][2] - min(p[2] for p in src_rest.values())))
    turn, out = {}, {}
    for bone in sorted(target.data.bones, key=lambda b: len(b.parent_recursive)):  # parents first
        parent = bone.parent.name if bone.parent else None
        turn[bone.name] = deltas[:, by_target[bone.name]] if bone.name in by_target else (
            turn[parent] if parent else np.tile(np.eye(3), (len(frames), 1, 1)))
        if parent is None:
            out[bone.name] = ratio * src_path
        else:
            out[bone.name] = out[parent] + turn[parent] @ (tgt_rest[bone.name] - tgt_rest[parent])
    return out


def rest_skeleton(obj, names_of=None):
    """(names, parents, offsets) of the armature's rest in world space (each bone's head from its
    parent's; the root's from the origin), for san_protocol.height."""
    world = np.array(obj.matrix_world)
    bones = list(obj.data.bones)
    names = [b.name for b in bones]
    heads = np.array([world[:3, :3] @ np.array(b.head_local) + world[:3, 3] for b in bones])
    parents = [names.index(b.parent.name) if b.parent else -1 for b in bones]
    offsets = np.array([heads[j] - (heads[p] if p >= 0 else 0.0) for j, p in enumerate(parents)])
    return names, parents, offsets


def remove(*objects) -> None:
    for obj in objects:
        data, action = obj.data, obj.animation_data.action if obj.animation_data else None
        bpy.data.objects.remove(obj)
        if data is not None and data.users == 0:
            bpy.data.armatures.remove(data)
        if action is not None and action.users == 0:
            bpy.data.actions.remove(action)


# "MotionKit, given map": MotionKit's defaults with the bone map the constraints use (every bone both
# rigs name alike, or the fixed correspondence), to tell the automatic map's share from the rest.
METHODS = ("plain copy", "constraints (world)", "constraints (local)", "MotionKit", "MotionKit, given map")


def _timed(run):
    started = time.perf_counter()
    result = run()
    return result, time.perf_counter() - started


# "MotionKit, Mixamo's stride": MotionKit with Scale Horizontal set so that the travel across the floor scales as
# Mixamo's does between the two characters (the stride: target's / source's, given by the caller, MIXAMO_STRIDE):
# what is left once the one factor no skeleton measure gives is known.
STRIDE = "MotionKit, Mixamo's stride"
# Mixamo's travel across the floor per character relative to Aj's: its hips' horizontal path on Catwalk Walk's
# excerpt (tests/data/mixamo_excerpts; Kaya's whole clip in ../shared) against Aj's on the same frames (numpy on
# the files, docs/benchmarks.md).
MIXAMO_STRIDE = {"Aj": 1.0, "Kaya": 0.881, "BigVegas": 1.232, "Goblin_m": 1.337, "Mousey_m": 0.548,
                 "SportyGranny": 1.078}


def _blender_methods(mk, source, template, pairs, hips, names, frames, last, methods, own=None, stride=None):
    """Each Blender-side method on a fresh rest copy of template: {method: (joints, seconds)}. own: an action
    of the target's own that MotionKit's copies play when the retarget starts; stride: STRIDE's."""
    out = {}
    for method in methods:
        if method == "plain copy":
            continue
        target = rest_copy(template, "retarget " + method)
        if own is not None and method.startswith("MotionKit"):
            mk.animdata.assign(target, own)
        if method == "MotionKit":
            _, seconds = _timed(lambda: mk.retarget(source, target))
        elif method == "MotionKit, given map":
            _, seconds = _timed(lambda: mk.retarget(source, target, bone_map=pairs))
        elif method == STRIDE:  # on top of MotionKit's own ratio of the rigs, which a plan tells
            wider = stride / mk.retargeting.plan(source, target).path_scale
            _, seconds = _timed(lambda: mk.retarget(source, target, scale_horizontal=wider))
        else:
            variant = method.split("(")[1].rstrip(")")
            _, seconds = _timed(lambda: constraint_way(source, target, pairs, hips, variant, last))
        out[method] = (joints_world(target, names, frames), seconds)
        remove(target)
    return out


def measure_san(mk, shared, source: str, target: str, clip: str, every: int = 1, methods=METHODS) -> dict:
    """One retarget of the SAN set: source's clip onto target's rest, measured against target's own clip
    (joints in Blender's world, metres). Returns frames, height, "sanity" (the largest distance between
    Blender's evaluation of target's own imported clip and san_protocol's forward kinematics, over the
    height), "errors" {method: san_protocol.errors}, "joint_pose" {method: per-joint pose-alone %, in
    BODY_JOINTS order}, "seconds" {method: wall time}, "positions" {method: (frames, joints, 3) in world}
    and "reference" (the target's own clip's, the same shape)."""
    paths = san_path(shared, source, clip), san_path(shared, target, clip)
    whole, own = (_base_names(sp.read_bvh(path)) for path in paths)
    if len(whole.values) != len(own.values):
        raise RuntimeError(f"{clip}: {source} has {len(whole.values)} frames, {target} {len(own.values)}")
    return _measure_bvh(mk, paths, (whole, own), target, 0, every, methods)


def _measure_bvh(mk, paths, clips, name: str, start: int, every: int, methods, stride=None) -> dict:
    """The source's clip retargeted onto the rest of the target's armature, measured on every every-th frame
    of the target's own clip (Mixamo's answer), whose frames are the source's from start (0-based) on:
    measure_san's figures, and "start". paths: (source, target) BVH files; clips: the same read, joints by
    their names less a character's prefix (_base_names)."""
    (source_path, target_path), (whole, own) = paths, clips
    count = min(len(own.values), len(whole.values) - start)
    rows = np.arange(0, count, every)  # the target clip's frames, 0-based
    frames = start + 1 + rows  # the same, as Blender's frames of the source's clip
    body = sp.body_indices(own.names)
    height = BVH_SCALE * sp.height(own.names, own.parents, own.offsets)
    reference = bvh_to_blender(sp.clip_positions(own)[rows][:, body])
    clip_obj = import_bvh(target_path)
    bones = [bone.name for bone in clip_obj.data.bones]
    names = [next(b for b in bones if b.split(":")[-1] == j) for j in sp.BODY_JOINTS]
    evaluated = joints_world(clip_obj, names, rows + 1)
    sanity = float(np.linalg.norm(evaluated - reference, axis=-1).max()) / height
    pose_sanity = float(np.linalg.norm((evaluated - evaluated[:, :1]) - (reference - reference[:, :1]),
                                       axis=-1).max()) / height
    template = rest_copy(clip_obj, name + " rest")
    remove(clip_obj)
    source_obj = import_bvh(source_path)
    joints, seconds = {}, {}
    if "plain copy" in methods:
        part = sp.Bvh(whole.names, whole.parents, whole.offsets, whole.channels, whole.values[start:start + count],
                      whole.frame_time)
        plain, seconds["plain copy"] = _timed(lambda: sp.plain_copy(part, own))
        joints["plain copy"] = bvh_to_blender(plain[rows][:, body])
    pairs = [(b.name, b.name) for b in template.data.bones if b.name in source_obj.data.bones]
    for method, (found, secs) in _blender_methods(mk, source_obj, template, pairs, (sp.HIPS, sp.HIPS), names,
                                                  frames, start + count, methods, stride=stride).items():
        joints[method], seconds[method] = found, secs
    remove(source_obj, template)
    return {"frames": len(rows), "start": start, "height": height, "sanity": sanity, "pose_sanity": pose_sanity,
            "seconds": seconds,
            "errors": {m: sp.errors(joints[m], reference, height) for m in methods},
            "joint_pose": {m: sp.joint_pose_errors(joints[m], reference, height) for m in methods},
            "positions": joints, "reference": reference}


# Mixamo's own four SAN clips on four more characters of the SAN test set, from the SAN repository (the README
# beside them): each file's hierarchy whole and a run of its frames, "head" (the clip's first) or "mid" (from
# its middle): Mixamo's answer for those frames of Aj's and Kaya's clip.
EXCERPTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data", "mixamo_excerpts")
EXCERPT_CHARACTERS = ("BigVegas", "Goblin_m", "Mousey_m", "SportyGranny")
EXCERPT_RUNS = (("Jumping", "head"), ("Jumping", "mid"), ("Running", "mid"), ("Catwalk Walk", "mid"),
                ("Getting Up", "mid"))
# The upper body's local rotations, which Mixamo keeps the same on every character (../shared/docs/BRIEF.md, section 8): where an
# excerpt's agree with a whole clip's, it starts there.
_UPPER = ("LeftArm", "RightArm", "LeftForeArm", "RightForeArm")


def excerpt_path(character: str, part: str, clip: str = "Jumping") -> str:
    return os.path.join(EXCERPTS, character, f"{clip}_{part}.bvh")


def _base_names(clip: sp.Bvh) -> sp.Bvh:
    """clip with its joints' names less a character's prefix (BigVegas's "newVegas:")."""
    return sp.Bvh([n.split(":")[-1] for n in clip.names], clip.parents, clip.offsets, clip.channels, clip.values,
                  clip.frame_time)


def excerpt_start(whole: sp.Bvh, excerpt: sp.Bvh) -> int:
    """The frame (0-based) of whole at which excerpt's frames begin: where their upper-body rotations agree."""
    def columns(clip):
        return np.concatenate([clip.values[:, clip.first[clip.index(n)]:clip.first[clip.index(n)] + 3]
                               for n in _UPPER], axis=1)
    a, e = columns(whole), columns(excerpt)
    gaps = [np.abs(a[s:s + len(e)] - e).max() for s in range(len(a) - len(e) + 1)]
    start = int(np.argmin(gaps))
    if gaps[start] > 1.5:  # degrees: the same frames differ by under one, the clip a frame away by 2.3 or more
        raise RuntimeError(f"no run of the whole clip's frames agrees with the excerpt ({gaps[start]:.2f} deg)")
    return start


def measure_excerpt(mk, source_path: str, target: str, part: str,
                    methods=("plain copy", "MotionKit"), clip: str = "Jumping") -> dict:
    """source_path's whole clip retargeted onto the rest of target's excerpt of clip (Blender's BVH importer),
    its body joints on the excerpt's frames against the excerpt's own (Mixamo's answer), as measure_san. With
    STRIDE among the methods, the stride is MIXAMO_STRIDE's between the source (named by its folder) and target."""
    paths = source_path, excerpt_path(target, part, clip)
    clips = tuple(_base_names(sp.read_bvh(path)) for path in paths)
    source = os.path.basename(os.path.dirname(source_path))
    stride = MIXAMO_STRIDE[target] / MIXAMO_STRIDE[source] if STRIDE in methods else None
    return _measure_bvh(mk, paths, clips, target, excerpt_start(*clips), 1, methods, stride)


def fbx_body(character: str) -> dict:
    """Mixamo joint name -> the character's bone name (girl1 carries Mixamo's names with its prefix)."""
    if character == "girl2":
        return dict(sp.GIRL2_JOINTS)
    return {j: "mixamorig:" + j for j in sp.BODY_JOINTS}


def measure_fbx(mk, shared, source: str, target: str, clip: str, every: int = 1, methods=METHODS,
                own: str | None = None) -> dict:
    """One retarget of the FBX pairs, as measure_san (both sides evaluated in Blender: no sanity figure);
    the plain copy and the constraints through the fixed correspondence of the body joints. own: another
    clip of the target's that it plays when the retarget starts (as a character downloaded with its
    animation does); None: it stands at rest, playing nothing."""
    clip_obj = import_fbx(fbx_path(shared, target, clip))
    last = int(round(clip_obj.animation_data.action.frame_range[1]))
    frames = np.arange(1, last + 1, every)
    src_body, tgt_body = fbx_body(source), fbx_body(target)
    measured = [j for j in sp.BODY_JOINTS if j in tgt_body]
    names = [tgt_body[j] for j in measured]
    reference = joints_world(clip_obj, names, frames)
    skeleton = rest_skeleton(clip_obj)
    height = sp.height(*skeleton, toe=tgt_body[sp.TOE], head=tgt_body[sp.HEAD])
    template = rest_copy(clip_obj, target + " rest")
    remove(clip_obj)
    own_action = None
    if own is not None:
        own_obj = import_fbx(fbx_path(shared, target, own))
        own_action = own_obj.animation_data.action
        own_action.use_fake_user = True  # kept past its object until the methods are measured
        remove(own_obj)
    source_obj = import_fbx(fbx_path(shared, source, clip))
    pairs = [(src_body[j], tgt_body[j]) for j in sp.BODY_JOINTS if j in src_body and j in tgt_body]
    hips = (src_body[sp.HIPS], tgt_body[sp.HIPS])
    joints, seconds = {}, {}
    if "plain copy" in methods:
        plain, seconds["plain copy"] = _timed(lambda: world_plain_copy(source_obj, template, pairs, hips, frames))
        joints["plain copy"] = np.stack([plain[n] for n in names], axis=1)
    for method, (found, secs) in _blender_methods(mk, source_obj, template, pairs, hips, names, frames, last,
                                                  methods, own_action).items():
        joints[method], seconds[method] = found, secs
    remove(source_obj, template)
    if own_action is not None:
        bpy.data.actions.remove(own_action)
    hips_column = measured.index(sp.HIPS)
    return {"frames": len(frames), "height": height, "sanity": None, "seconds": seconds, "joints": len(names),
            "errors": {m: sp.errors(joints[m], reference, height, hips_column) for m in methods}}


def measure_made(mk, whole_path: str, made_path: str, made_is_source: bool, scratch: str) -> dict:
    """A character made from an excerpt (made_characters: its own clip still Mixamo's answer for it) as the
    target of whole_path's clip, or, made_is_source, as the source onto the rest of whole_path's character,
    measured on the excerpt's frames against whole_path's own clip cut to them (written into scratch)."""
    whole, excerpt = (_base_names(sp.read_bvh(path)) for path in (whole_path, made_path))
    start = excerpt_start(whole, excerpt)
    if not made_is_source:
        return _measure_bvh(mk, (whole_path, made_path), (whole, excerpt), "made", start, 1,
                            ("plain copy", "MotionKit"))
    answer = os.path.join(scratch, "answer.bvh")
    made.write_bvh(made.frames(sp.read_bvh(whole_path), start, len(excerpt.values)), answer)
    return _measure_bvh(mk, (made_path, answer), (excerpt, _base_names(sp.read_bvh(answer))), "answer", 0, 1,
                        ("plain copy", "MotionKit"))
